"""TrackLine (spec 1.4.3): hold the line from P1 to P2, and the route machinery of the tasks
that fly chains of track lines (XYPattern, Orbit, Survey).

The control law, in one line (the vehicle's heading then follows it through the helm's heading
PID, spec 1.4.1; Lead is LeadTime × V unless given):

    desired heading = line bearing − atan(XTE / Lead) − c,    dc/dt = XTE · V / (3 · Lead²)

with XTE the signed cross-track error (positive to starboard), V the vehicle's speed along the
line over the ground, and c, the learned correction, clamped to ±``XTE_LIMIT`` (20°) and
learned only while the vehicle holds an offset (the gate, below).

Pure pursuit ("carrot and donkey", spec 1.4.3). Every tick the vehicle's position is projected
onto the line and the *carrot* is put ``Lead`` metres further along it (never beyond P2); the
bearing to the carrot is ``line bearing − atan(XTE / Lead)``. Far from the line that is a
bounded approach angle (never more than 90° off the line's direction); near it, it turns the
vehicle onto the line with a time constant of Lead / V and arrives on the line's heading.

How short a Lead can be is set by the heading loop: the line tasks' own (``LINE_PID_*``,
``HelmGains.line_pid``; the other steering tasks use ``YAW_PID_*``). Taking that loop as a
first-order lag of gain Kψ = LINE_PID_KP × MaxTurnRate / MAXRUDDER (per second: degrees per
second of turn per degree of heading error, KD neglected), the cross-track loop near the line
is ``e'' + Kψ·e' + Kψ·(V/Lead)·e = 0``, of damping ζ = ½·√(Kψ·Lead/V): it depends on the
*lead time* Lead / V, not on the Lead. So the default Lead is a lead time, ``LeadTime`` seconds
of the speed over the ground (measured from the fixes, ``Speedometer``; at least 1 m), and one
default fits every speed; a ``Lead`` given in metres is kept whatever the speed (``mavhelm
tune`` writes one for the task's speed). The defaults, MaxTurnRate 90 and LINE_PID_KP 1.0 with
no KD (Kψ 4.5 /s) with LeadTime 1.5 s (ζ ≈ 1.3 on this model; its delays make the real loop
less damped), are what held every model's lines best on the real SITL at 5 m/s
(``benchmarks/bench_tracking.py``, ``docs/tracking.md``); the heading tasks' YAW_PID_KP 0.75
with KD 0.2 (Kψ 3.4 /s), which the lines flew until 2026-12-02 and which measured best on the
motorboat at 2 m/s, swung the skid boat up to 0.8–0.9 m in the stock wind at 5 m/s, and a
derivative only made the skid boat worse; the former MaxTurnRate 45, KP 0.5 (Kψ 1.1 /s) with
Lead 5 swung 1–1.3 m after each turn. A heading task wants the softer loop: a 30° heading step
overshoots 13–23° at KP 1.0 without KD. At 2 m/s the stiff loop holds every model within
0.03 m RMS and 0.12 m max (Lead 3); with a shorter lead time (Lead 2 at 2 m/s) it swung ±0.8 m
for 15 s after a turn on one leg in sixteen: the loop's delays (the helm's tick, telemetry,
GPS latency) are close. The lead time is also how early a turn
is anticipated (below), and the time a vehicle of turn rate ω needs to turn 90° is about
1 / ω plus its delay: 1.5 s suits the SITL boat at 5 m/s (it turns about 50°/s).

Why the integral. Pure pursuit alone leaves a steady offset whenever something pushes the
vehicle sideways or its heading is not what it believes — a cross current, wind and leeway (at
0.3 m/s across a 1.6 m/s boat it settles about 1 m off with Lead 5), a biased compass or EKF
heading (on the ArduPilot SITL motorboat pure pursuit sits 0.8° of heading off in calm water,
1.7° in the stock wind and waves), an autopilot that does not quite hold the commanded
heading — because the only way it can crab into the set is by sitting Lead · tan(crab angle)
off the line. The integral learns that crab angle instead. Its rate is
set in pursuit time constants: c is learned with an integral time of 3 × Lead / V, so,
linearised, the loop is ``e''' + Kψ·e'' + Kψ·(V/Lead)·e' + Kψ·V²/(3·Lead²)·e = 0``: an offset
goes in about 3 × Lead / V (4.5 s with Lead 3 at 2 m/s, 9 s with Lead 5 at 1.6 m/s), and the
pursuit keeps its damping whatever the Lead and the speed (a well-damped pursuit stays at
ζ ≈ 0.9). The former fixed rate (1° of heading per metre-second: an integral time of
57 / Lead seconds) was about as fast with Lead 5 but ever slower with the shorter Leads a
faster heading loop allows. V is measured, not commanded: the progress along the line over
the gate's 1 s baseline (below).

Measured on the real ArduPilot SITL motorboat (``bench_tracking.py``: four 100 m legs 20 m
apart at 2 m/s, XTE from 10 m into each leg to 5 m before its end; ArduPilot's own AUTO: 0.13 m
RMS, 0.20 m max in calm water). At the tuned settings above: without the integral 0.04 m RMS
in calm water and 0.09 m in the stock wind and waves, with the former fixed rate 0.02 and
0.04 m, with this one 0.01 and 0.02 m (max ≤ 0.11 m), as a Survey and as a chain of
TrackLines alike. At the product's defaults (Lead 5, YAW_PID_KP 0.5, MaxTurnRate 45) the steady
part is as good and the RMS 0.11–0.13 m, nearly all of it the swing after each 90° turn onto a
leg.

The gate. The hard part of any integral on a line follower is wind-up: XTE during an approach
to the line or a turn onto it is transient, pure pursuit removes it by itself, and integrating
it only makes the vehicle overshoot (in the simulator, integrating whenever within a Lead of
the line tripled the XTE after a 90° turn). So the integral learns only what pure pursuit
cannot fix, an *offset held*:

- it runs only while the vehicle is within one Lead of the line, making way along it
  (≥ 0.1 m/s), and its track over the ground (from fixes ≥ 1 s apart) has stayed within 10° of
  the line's direction for 2 s — a vehicle held off by a set runs parallel to the line, one
  closing on it or turning does not, and the far point of a swing is parallel only for a
  moment. Heading alone could not tell these apart: a vehicle crabbing into a current points
  at the line while it runs along it;
- it is integrated on the navigation's own time stamps (like the PID, spec 1.4.1), at most 1 s
  per step (a gap in the data is not a long offset), and clamped to ±20° (anti-windup; enough
  to crab against a set of a third of the vehicle's speed);
- it is reset when the task goes active, when the helm comes back online after a human had the
  vehicle, and at the start of every line of a route, because a set learned on one line is
  wrong on a line in another direction.

In the simulator, 0.3 m/s of current across the line leaves pure pursuit 0.75 m off (RMS);
with the integral it holds 0.2 m, as in still water.

The turn onto a line. A route that knows its next line plans the turn onto it
(``turn_plan``; Survey and chained TrackLines): a corner is an arc of one Lead's radius tangent
to both lines (smaller where it would not fit in half of either), and a survey's U-turn over a
short join (half the join within 0.5–2 Leads) one half circle beyond the legs' ends, whose
diameter is the join. The line is left ``RouteTask.turn_in`` before its end, where the arc
starts plus the heading loop's lag run (``TURN_LAG_S`` of the speed), and the next line is
entered along that arc: the heading asked is the path's direction a lag's run ahead of the
vehicle's projection on it (the turn rate's feed-forward), less atan(offset / Lead), so the
vehicle comes out of the turn on the line and on its heading. Pursuit of a carrot across the
corner, as before, could not both turn and settle on a 20 m join at 5 m/s (4 s long): on the
real SITL motorboat it turned at its 62 deg/s limit, overshot the join by 1 m and swung
0.2–1.1 m on the next leg 10–15 m along it; planned, 0.13–0.32 m in calm water and the stock
wind (once 0.52 m, the companion's data stalled at the turn's end), the skid boat 0.15–0.45 m
(``benchmarks/bench_tracking.py``). A corner too slight (< 1°), too sharp (> 179°) or too
tight for an arc of 0.5 m keeps pursuit's turn-in (``turn_in_distance``: Lead · tan(Δ/2), at most
one Lead and half of either line, plus the lag run times sin Δ onto a longer line). A chain of
TrackLine tasks does the same: when exactly one TrackLine starts on this one's FinishFlag and
continues from its P2 (its P1 given, within ``CHAIN_GAP``), the helm links the two at load
(``link_track_lines``), this one's capture radius becomes at least the turn-in, and the next
one enters its line by the planned turn from this one's; at the old defaults, each chained line
flown to its Radius (1 m) swung 1.0–1.25 m after every corner.

A sharp corner is slowed for (``corner_speed``). The arc of one Lead leaves the line
Lead · tan(Δ/2) before a corner of Δ (2.4 Leads at 135°: 18 m at 5 m/s), so where the line after
the corner turns back by more than 90°, a route that plans its turns and whose Lead is a lead
time votes cot²(Δ/2) of its thrust from its braking distance before the slowed arc's turn-in
(``RouteTask.corner_fraction``; the line is then left at that arc's turn-in, the turn-in at
the corner's speed), keeps it while the arc onto the next line is flown, and votes its full
thrust again once on that line. Corners up to 90° and a survey's U-turns are flown at full
thrust. On the real SITL motorboat a 135° zig-zag at 5 m/s went from 5–6 m off in the held
part of each line to 0.07 m (``docs/tracking.md``).

Tried and not kept: letting the carrot run on round the corner onto the next line of a route
(Survey, XYPattern, Orbit), so that the vehicle starts its turn early. At the defaults it took
a Survey from 0.11 to 0.07 m RMS on the real SITL; at the tuned settings it made it no
better; and it needs another rule for reaching a corner: cutting a turn of more than 90°, the
vehicle never passes P2 along the line (in the kinematic unit test it circled P2). A 20 Hz
AppTick with 20 Hz telemetry measured no better than 10 Hz.

Every tick the task posts ``<NAME>_XTE``, the signed cross-track error in metres (positive: the
vehicle is to starboard of the line, looking from P1 to P2).

The line and its end. Without ``P1`` the line starts where the vehicle is when the task goes
active (its first tick with a position): the "previous waypoint" when TrackLine tasks are chained
by their flags, each one's FinishFlag the next one's StartFlag. The task completes when the
vehicle is within ``Radius`` of P2, or when its along-track distance passes the end of the line
(it has gone by P2 to one side: turning back for it would be worse than going on).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Iterable
from typing import NamedTuple

from mavhelm.core.geodesy import wrap_degrees
from mavhelm.core.params import Alias, Number, Param, Point
from mavhelm.tasks import corner_speed, turn_plan
from mavhelm.tasks.base import HEADING, NavState, Task, Votes
from mavhelm.tasks.geometry import DEGENERATE, Point2, bearing, carrot, distance, track_position
from mavhelm.tasks.pid import ScalarPID
from mavhelm.tasks.steering import SteeringTask
from mavhelm.tasks.turn_plan import Arc
from mavhelm.tasks.waypoint import RADIUS

LEAD = Number(1.0, 10_000.0)
"""The carrot's lead along the line in metres (MOOS: at least 1 m)."""
MIN_LEAD = 1.0
"""The shortest lead a lead time gives (LEAD's minimum): at rest the carrot is still ahead."""

LEAD_TIME = Number(0.1, 60.0)
DEFAULT_LEAD_TIME = 1.5
"""The carrot's lead in seconds of the vehicle's speed over the ground (see the module
docstring: the pursuit's damping depends on the lead time, not on the lead)."""

LEAD_PARAMS = (
    Param("Lead", LEAD, None, "m",
          "the carrot's lead along the line beyond the vehicle's projection on it, fixed; "
          "default: LeadTime × the speed over the ground (the original's default is 1 m, "
          "which turns a boat sharply onto the line)"),
    Param("LeadTime", LEAD_TIME, DEFAULT_LEAD_TIME, "s",
          "without Lead, the carrot leads by this many seconds of the speed over the "
          "ground (at least 1 m), so the line is held as well at any speed",
          attr="lead_time"),
)
"""The lead settings of every task that flies track lines (TrackLine, Survey)."""

TURN_LAG_S = 0.5
"""How long a turn takes to start after the helm asks for it (the helm's tick, telemetry, the
vehicle's yaw response: 0.3–0.5 s on the real SITL motorboat); the turn onto a longer line is
asked for this much earlier (``RouteTask.turn_in``)."""

SPEED_BASELINE_S = 1.0
"""The speed over the ground is measured between fixes at least this far apart (GPS noise)."""

CHAIN_GAP = 0.1
"""A TrackLine whose P1 is this close (m) to the P2 of the TrackLine that starts it continues
that line: the first turns in to it (``link_track_lines``)."""

XTE_TI_LEADS = 3.0
"""The integral's time constant in pursuit time constants (Lead / speed): the correction grows
at XTE · speed / (XTE_TI_LEADS · Lead²) radians per second."""
XTE_LIMIT = 20.0
"""Largest heading correction the integral may make, in degrees."""
GATE_ANGLE = 10.0
"""The integral runs only while the track over the ground is within this many degrees of the
line's direction (the vehicle is holding an offset, not closing on the line or turning)."""
RATE_BASELINE_S = 1.0
"""The ground track is measured between fixes at least this far apart (GPS noise)."""
STEADY_S = 2.0
"""...and only once that has held this long: at the far point of a swing off the line the
track is parallel to it for a moment, which is not an offset to learn."""
MIN_PROGRESS = 0.1
"""Nor while the vehicle makes less than this many m/s along the line (stopped, held back)."""

MAX_STEP_S = 1.0
"""Longest time step integrated at once: a gap in the navigation is not a long offset."""

MAX_ADVANCES_PER_TICK = 1000
"""A route moves on at most this many lines in one tick (bounds the work of any route)."""


def turn_in_distance(lead: float, turn: float, following: float, current: float,
                     speed: float) -> float:
    """``RouteTask.turn_in`` for a turn of ``turn`` radians (at most π/2) from a line of
    length ``current`` onto one of length ``following`` at ``speed``: Lead · tan(turn/2), at
    most one Lead, plus the heading loop's lag run onto a longer line, at most half of either
    line. (The tune's model of the helm flies the same.)"""
    ahead = min(lead * math.tan(turn / 2.0), lead)
    if following > current:
        ahead += TURN_LAG_S * speed * math.sin(turn)
    return min(ahead, 0.5 * following, 0.5 * current)


class LineFollower:
    """Carrot-and-donkey steering on one segment, with the bounded XTE integral (see above)."""

    def __init__(self, p1: Point2, p2: Point2, lead: float) -> None:
        self.p1 = p1
        self.p2 = p2
        self.lead = lead
        self.length = distance(p1, p2)
        self.along = 0.0
        self.xte = 0.0
        self.correction = 0.0
        """The integral's heading correction in degrees (subtracted from the carrot bearing),
        within ±XTE_LIMIT."""
        self.progress = 0.0
        """Speed along the line (m/s) over the last baseline, while the gate measures it."""
        self.integrating = False
        """Whether the last step was integrated (the gate was open)."""
        self._last_time: float | None = None
        self._fixes: deque[tuple[float, float, float]] = deque()
        self._steady_since: float | None = None
        self.entry: Arc | None = None
        """The planned turn onto this line from the one before (``turn_plan``), flown until
        the vehicle is past its end."""
        self.ahead = 0.0
        """How far ahead (m) the entry path's direction is asked for: the heading loop's lag."""

    def reset(self) -> None:
        """Forget the learned correction (the vehicle was driven by someone else)."""
        self.correction = 0.0
        self.integrating = False
        self._last_time = None
        self._fixes.clear()
        self._steady_since = None

    def _holding_offset(self, t: float) -> bool:
        """The gate: near the line, moving along it, its ground track parallel to it for a
        while."""
        steady = self._parallel(t)
        if not steady:
            self._steady_since = None
            return False
        if self._steady_since is None:
            self._steady_since = t
        return t - self._steady_since >= STEADY_S

    def _parallel(self, t: float) -> bool:
        fixes = self._fixes
        fixes.append((t, self.along, self.xte))
        while len(fixes) > 1 and t - fixes[1][0] >= RATE_BASELINE_S:
            fixes.popleft()
        t0, along0, xte0 = fixes[0]
        span = t - t0
        if span < RATE_BASELINE_S or abs(self.xte) >= self.lead:
            return False
        self.progress = progress = (self.along - along0) / span
        sideways = (self.xte - xte0) / span
        return progress >= MIN_PROGRESS and \
            abs(math.degrees(math.atan2(sideways, progress))) < GATE_ANGLE

    def measure(self, p: Point2) -> None:
        self.along, self.xte = track_position(self.p1, self.p2, p)

    def reached(self, p: Point2, radius: float) -> bool:
        """Within ``radius`` of P2, past the end of the line along it, or past the end of an
        entry path that ends at P2 (a U-turn's half circle: its join is then flown whole, and
        steering on along the join would turn the vehicle square off the line out)."""
        self.measure(p)
        if distance(p, self.p2) < radius or self.along >= self.length:
            return True
        entry = self.entry
        return entry is not None and distance(entry.end, self.p2) < DEGENERATE \
            and entry.done(p)

    def heading(self, p: Point2, t: float) -> float:
        """Desired heading (degrees) for a vehicle at ``p`` whose position was measured at ``t``."""
        self.measure(p)
        if self.length < DEGENERATE:
            return bearing(p, self.p2)
        if self.entry is not None:
            if not self.entry.done(p):
                aim, self.xte = self.entry.heading(p, self.lead, self.ahead)
                return aim
            self.entry = None
        if self._last_time is None or t > self._last_time:
            self.integrating = self._holding_offset(t)
            if self.integrating and self._last_time is not None:
                step = min(t - self._last_time, MAX_STEP_S)
                rate = self.xte * self.progress / (XTE_TI_LEADS * self.lead ** 2)
                self.correction = max(-XTE_LIMIT, min(XTE_LIMIT, self.correction
                                                      + math.degrees(rate * step)))
            self._last_time = t
        goal = carrot(self.p1, self.p2, p, self.lead)
        if distance(p, goal) < DEGENERATE:
            aim = bearing(self.p1, self.p2)
        else:
            aim = bearing(p, goal)
        return wrap_degrees(aim - self.correction) % 360.0


class FlownLine(NamedTuple):
    """A line a route has flown: its ends, and whether it was entered by a U-turn's half
    circle (then the line after it is entered straight, with no turn of its own)."""

    p1: Point2
    p2: Point2
    half_circle: bool = False


class Speedometer:
    """Speed over the ground from the position fixes, over a baseline of at least
    ``SPEED_BASELINE_S`` (GPS noise). Shared by the TrackLines of a chain, so a line that
    starts mid-turn knows the speed at once."""

    def __init__(self) -> None:
        self.speed: float | None = None
        self._fixes: deque[tuple[float, float, float]] = deque()

    def update(self, t: float, p: Point2) -> None:
        fixes = self._fixes
        if fixes and t <= fixes[-1][0]:
            return
        fixes.append((t, p[0], p[1]))
        while len(fixes) > 1 and t - fixes[1][0] >= SPEED_BASELINE_S:
            fixes.popleft()
        t0, x0, y0 = fixes[0]
        if t - t0 >= SPEED_BASELINE_S:
            self.speed = math.hypot(p[0] - x0, p[1] - y0) / (t - t0)


class RouteTask(SteeringTask):
    """A task that flies a chain of track lines: target 0 from where the vehicle is when the
    task goes active, then target k-1 → target k. A subclass says where the targets are.

    Hooks: ``plan(start, now)`` once, on the first tick with a position; ``target(k)`` (None
    after the last); ``capture_radius(k)``; ``begin(k, now)`` when the line to target k starts;
    ``arrived(k, now)`` when target k is reached; ``after(k)``, the point after target k (the
    next target unless the subclass knows more). ``lead`` is the carrot's lead in metres, or
    None for ``lead_time`` seconds of the speed over the ground.
    """

    lead: float | None = None
    lead_time: float = DEFAULT_LEAD_TIME
    follower: LineFollower | None = None
    speedometer: Speedometer | None = None
    index = -1
    plans_turns = False
    """Whether the route's corners are planned turns (``turn_plan``): its lines are then left
    a turn-in early (``turn_in``) and each is entered by its planned path."""
    last_flown: FlownLine | None = None
    """The line flown before the current one."""

    slowing = 1.0
    """The thrust fraction asked for the current line's corner (``corner_speed``), latched once
    the slow-down for it has begun; 1 until then."""
    slow_speed: float | None = None
    """The speed (m/s) the current line's corner is taken at, once the slow-down has begun."""
    turning = 1.0
    """The thrust fraction kept while the current line's planned entry is flown: the one the
    line before slowed to for the corner between them."""
    u_turn_held = False
    """The current line ends in a U-turn flown as one half circle, held since the vehicle came
    within where the two-corner plan would leave the line (a Lead plus the lag). Whether a
    U-turn is one half circle depends on the Lead, so on the speed measured, which a fix
    stamped late can drop 20 % in one tick (the real SITL rover-skid at 4 m/s, its fixes
    0.02-0.25 s old when heard): switched then, the plan's turn would start behind the vehicle
    (2.1 m past its arc's start, a 3 m swing at the corner, 0.5 m on the next leg)."""

    def current_lead(self) -> float:
        """The carrot's lead now, metres: ``lead``, or ``lead_time`` of the speed."""
        return self.lead_at(self.speed_source().speed or 0.0)

    def lead_at(self, speed: float) -> float:
        """The carrot's lead at ``speed`` (m/s): ``lead``, or ``lead_time`` of it, at least
        ``MIN_LEAD``."""
        if self.lead is not None:
            return self.lead
        return max(MIN_LEAD, self.lead_time * speed)

    def heading_pid(self) -> ScalarPID:
        """The line's heading controller (``LINE_PID_*``, ``HelmGains.line_pid``)."""
        return self.gains.line_pid()

    def speed_source(self) -> Speedometer:
        if self.speedometer is None:
            self.speedometer = Speedometer()
        return self.speedometer

    def needs(self) -> set[str]:
        return {"NAV_X", "NAV_Y", HEADING}

    def initialise(self, now: float) -> None:
        self.follower = None
        self.index = -1  # the target steered for; -1 until the first tick with a position
        self.segment_start_time = now
        self.last_flown = None
        self.slowing = self.turning = 1.0
        self.slow_speed = None
        self.u_turn_held = False

    def resume(self, now: float | None = None) -> None:
        super().resume(now)
        self.slowing, self.slow_speed = 1.0, None
        if self.follower is not None:
            self.follower.reset()

    def describe_goal(self) -> str | None:
        p2 = self.target(self.index) if self.index >= 0 else None
        if p2 is None:
            return f"{self.keyword} route"
        return f"{self.keyword} line to ({p2[0]:.0f}, {p2[1]:.0f})"

    # ---- hooks -------------------------------------------------------------------------

    def plan(self, start: Point2, now: float) -> None:
        """The vehicle's position on the task's first tick: lay the route out."""

    def target(self, k: int) -> Point2 | None:
        raise NotImplementedError

    def capture_radius(self, k: int) -> float:
        raise NotImplementedError

    def begin(self, k: int, now: float) -> None:
        """The line to target k has started."""

    def arrived(self, k: int, now: float) -> None:
        """Target k is reached (within its capture radius, or passed along the line)."""

    def after(self, k: int) -> Point2 | None:
        """The point the line after target k runs to (None: the route ends at target k)."""
        return self.target(k + 1)

    def beyond(self, k: int) -> Point2 | None:
        """The point the line after ``after(k)`` runs to (None: unknown, or the end)."""
        return self.target(k + 2)

    def line_before(self, p1: Point2) -> Point2 | None:
        """The start of the line flown before the one that starts at ``p1``, if it ended
        there."""
        last = self.last_flown
        if last is not None and distance(last.p2, p1) < CHAIN_GAP:
            return last.p1
        return None

    def turn_in(self, k: int, speed: float | None = None) -> float:
        """How far before target k to start the line after it, in metres, as a skipper turns
        in before a corner so as to come out of the turn on the new line rather than swing
        past it: where the route plans its turns, ``turn_plan.turn_in``; elsewhere, and at
        corners with no planned turn, pursuit's (``turn_in_distance``: Lead · tan(Δ/2) for a
        turn of Δ onto the next line, the carrot then on the new line as far ahead as the
        vehicle is off it, at most one Lead; onto a longer line, also the way run during the
        heading loop's lag, ``TURN_LAG_S`` of the speed, times sin Δ; at most half of either
        line). 0 at the last target. ``speed``: at that speed (m/s), not the one measured."""
        p2, after = self.target(k), self.after(k)
        follower = self.follower
        if p2 is None or after is None or follower is None:
            return 0.0
        turn = abs(wrap_degrees(bearing(p2, after) - bearing(follower.p1, p2)))
        if turn < 1.0:
            return 0.0
        measured = speed is None and k == self.index
        if speed is None:
            speed = self.speed_source().speed or 0.0
            slow = self.corner_speed() if k == self.index else None
            if slow is not None:    # the turn is made at the corner's speed
                speed = min(speed, slow)
        lead = self.lead_at(speed)
        if self.plans_turns:
            lag = TURN_LAG_S * speed
            planned = turn_plan.turn_in(
                follower.p1, p2, after, self.beyond(k), lead, lag,
                on_half_circle=turn_plan.is_half_circle(follower.entry),
                u_turn=self._hold_u_turn(k, lead, lag) if measured else None)
            if planned is not None:
                return planned
        return turn_in_distance(lead, math.radians(min(turn, 90.0)),
                                distance(p2, after), follower.length, speed)

    def _hold_u_turn(self, k: int, lead: float, lag: float) -> bool | None:
        """True once the current line's end is held as a U-turn (``u_turn_held``), holding it
        when it is one at ``lead`` and the vehicle is within ``lead`` + ``lag`` of its end;
        None while undecided."""
        follower, after = self.follower, self.after(k)
        if self.u_turn_held:
            return True
        if follower is None or after is None or follower.length - follower.along > lead + lag \
                or not turn_plan.is_u_turn(follower.p1, follower.p2, after, self.beyond(k),
                                           lead):
            return None
        self.u_turn_held = True
        return True

    def held_u_turn(self, k: int) -> bool:
        """Whether the line before the one to target k ended in a held U-turn
        (``u_turn_held``): the new line is then that U-turn's join."""
        return self.u_turn_held

    def corner_fraction(self) -> float:
        """The fraction of its thrust the route asks for now (``corner_speed``): the one the
        last corner was slowed for while its planned entry is flown, then that of the corner
        ahead once within its braking distance of where that corner's turn, at the slower
        speed, starts; 1 where there is no sharp corner."""
        follower = self.follower
        if follower is not None and follower.entry is not None and self.turning < 1.0:
            return self.turning
        self.turning = 1.0
        slow = self.corner_speed()
        speed = self.speed_source().speed
        if self.slowing < 1.0 or slow is None or not speed or follower is None:
            return self.slowing
        if follower.length - follower.along <= \
                self.turn_in(self.index, slow) + corner_speed.braking_distance(speed, slow):
            self.slowing = min(1.0, slow / speed)
            self.slow_speed = slow
        return self.slowing

    def corner_speed(self) -> float | None:
        """The speed (m/s) to take the current line's corner at (``corner_speed.fraction`` of
        the speed measured, until the slow-down begins), or None at full speed: no sharp
        corner, a fixed Lead (the arc would not tighten), turns not planned, or no thrust of
        its own to lower (steering only: the line is left where the turn at the speed measured
        starts)."""
        if self.slow_speed is not None:
            return self.slow_speed
        follower = self.follower
        if follower is None or not self.plans_turns or self.lead is not None or \
                self.thrust is None or self.thrust <= 0.0:
            return None
        p2, after = self.target(self.index), self.after(self.index)
        speed = self.speed_source().speed
        if p2 is None or after is None or not speed:
            return None
        turn = abs(wrap_degrees(bearing(p2, after) - bearing(follower.p1, p2)))
        share = corner_speed.fraction(turn, speed, self.lead_time, MIN_LEAD)
        return share * speed if share < 1.0 else None

    def slowed_for(self, k: int) -> float:
        """The thrust fraction the line before the one to target k was slowed to for the corner
        between them (``corner_fraction``), kept while the turn onto the new line is flown."""
        return self.slowing

    # ---- driving -------------------------------------------------------------------------

    def start_line(self, k: int, p1: Point2, now: float,
                   entry_from: Point2 | None = None) -> bool:
        """Steer from ``p1`` for target k; False (and no line) when the route is over.
        ``entry_from``: the start of the line that ends at ``p1``, whose corner with this one
        is then flown as a planned turn (``turn_plan.entry_path``) where one fits."""
        p2 = self.target(k)
        self.index = k
        if self.follower is not None:
            self.last_flown = FlownLine(self.follower.p1, self.follower.p2,
                                        turn_plan.is_half_circle(self.follower.entry))
        if p2 is None:
            self.follower = None
            return False
        slowed = self.slowed_for(k)
        held = self.held_u_turn(k)
        self.slowing, self.slow_speed = 1.0, None
        self.u_turn_held = False
        lead = self.current_lead()
        self.follower = LineFollower(p1, p2, lead)
        if entry_from is not None and self.plans_turns:
            last = self.last_flown
            after_half_circle = last is not None and last.half_circle and \
                distance(last.p2, p1) < CHAIN_GAP
            self.follower.entry = turn_plan.entry_path(entry_from, p1, p2, self.after(k), lead,
                                                       after_half_circle=after_half_circle,
                                                       u_turn=True if held else None)
        self.turning = slowed if self.follower.entry is not None else 1.0
        self.segment_start_time = now
        self.begin(k, now)
        return True

    def update(self, nav: NavState, now: float) -> Votes | None:
        assert nav.x is not None and nav.y is not None
        here = (nav.x, nav.y)
        t = nav.time("NAV_X")
        self.speed_source().update(now if t is None else t, here)
        if self.index < 0:
            self.plan(here, now)
            if not self.start_line(0, here, now):
                self.complete()
                return None
        for _ in range(MAX_ADVANCES_PER_TICK):
            follower = self.follower
            if follower is None:
                break
            if not follower.reached(here, self.capture_radius(self.index)):
                break
            self.arrived(self.index, now)
            self.start_line(self.index + 1, follower.p2, now, entry_from=follower.p1)
        return self.steer_on_line(nav, now)

    def steer_on_line(self, nav: NavState, now: float) -> Votes | None:
        """Votes for the current line (posting the XTE), or complete if the route is over."""
        follower = self.follower
        if follower is None:
            self.complete()
            return None
        assert nav.x is not None and nav.y is not None
        t = nav.time("NAV_X")
        follower.lead = self.current_lead()
        follower.ahead = TURN_LAG_S * (self.speed_source().speed or 0.0)
        heading = follower.heading((nav.x, nav.y), now if t is None else t)
        self.post(f"{self.name}_XTE", round(follower.xte, 3))
        votes = self.drive(heading, nav)
        if votes.get("THRUST", 0.0) > 0.0:
            votes["THRUST"] *= self.corner_fraction()
        return votes


class TrackLine(RouteTask):
    keyword = "TrackLine"
    plans_turns = True
    summary = ("holds the line P1→P2 (carrot and donkey, with a bounded cross-track integral); "
               "completes within Radius of P2 or once past it; posts <NAME>_XTE")
    params = (
        Param("P1", Point(), None, "m",
              "start of the line (x,y); default: where the vehicle is when the task goes "
              "active, i.e. the previous waypoint of a chain"),
        Param("P2", Point(), unit="m", doc="end of the line (x,y), the goal",
              aliases=(Alias("Location"),)),
        *LEAD_PARAMS,
        Param("Radius", RADIUS, 3.0, "m",
              "capture radius at P2: the task completes closer than this (or once past P2; "
              "the original's default is 0)"),
    )
    p1: tuple[float, float, float | None] | None
    p2: tuple[float, float, float | None]
    radius: float
    next_point: Point2 | None = None
    """The P2 of the TrackLine this one starts, when that one continues from this P2
    (``link_track_lines``): this line is then left a turn-in early."""
    previous: TrackLine | None = None
    """The TrackLine whose FinishFlag starts this one and whose P2 is this P1
    (``link_track_lines``): the turn from its line onto this one is a planned turn."""
    following: TrackLine | None = None
    """The TrackLine this one starts and that continues from its P2 (``next_point`` its P2)."""

    def check(self, block) -> None:
        if self.p1 is not None and math.hypot(self.p2[0] - self.p1[0],
                                              self.p2[1] - self.p1[1]) < DEGENERATE:
            entry = block.entry("P2") or block
            raise entry.error(f"P1 and P2 are the same point: task {self.name} has no line "
                              "to follow (use GoToWayPoint for a point)")

    def target(self, k: int) -> Point2 | None:
        return (self.p2[0], self.p2[1]) if k == 0 else None

    def after(self, k: int) -> Point2 | None:
        return self.next_point if k == 0 else None

    def beyond(self, k: int) -> Point2 | None:
        following = self.following
        return following.next_point if k == 0 and following is not None else None

    def capture_radius(self, k: int) -> float:
        return max(self.radius, self.turn_in(k))

    def start_line(self, k: int, p1: Point2, now: float,
                   entry_from: Point2 | None = None) -> bool:
        """The line from P1 (or from ``p1``, where the vehicle is, without one), entered by the
        planned turn from the previous TrackLine's line when the vehicle is within a Lead of
        that turn's path (else the previous line was flown long ago, or not to its end)."""
        here = p1
        if k == 0 and self.p1 is not None:
            p1 = (self.p1[0], self.p1[1])
            if self.previous is not None:
                self.last_flown = self.previous.last_flown
            if entry_from is None:
                entry_from = self.line_before(p1)
        started = super().start_line(k, p1, now, entry_from)
        follower = self.follower
        if follower is not None and follower.entry is not None and \
                abs(follower.entry.locate(here)[1]) > follower.lead:
            follower.entry = None
        return started

    def slowed_for(self, k: int) -> float:
        """The first line's corner was slowed for by the TrackLine before, if it is chained."""
        if k == 0 and self.previous is not None:
            return self.previous.slowing
        return super().slowed_for(k)

    def held_u_turn(self, k: int) -> bool:
        """The first line is the join of a U-turn held by the TrackLine before, if chained."""
        if k == 0 and self.previous is not None:
            return self.previous.u_turn_held
        return super().held_u_turn(k)


def link_track_lines(tasks: Iterable[Task]) -> None:
    """Chain the TrackLines a mission chains by its flags: when exactly one TrackLine is
    started by this one's FinishFlag and continues from its P2 (its P1 within ``CHAIN_GAP``),
    this one knows the next line and turns in to it as a route does (``RouteTask.turn_in``),
    and the two share their measure of the speed."""
    lines = [t for t in tasks if isinstance(t, TrackLine)]
    links = [(first, nexts[0]) for first in lines
             if len(nexts := _continuations(first, lines)) == 1]
    for first, then in links:
        first.next_point = (then.p2[0], then.p2[1])
        then.previous = first
        first.following = then
    for _ in range(len(links)):
        changed = [then for first, then in links if then.speedometer is not first.speed_source()]
        if not changed:
            break
        for first, then in links:
            then.speedometer = first.speed_source()


def _continuations(first: TrackLine, lines: list[TrackLine]) -> list[TrackLine]:
    """The TrackLines that ``first``'s FinishFlag starts and that begin at its P2."""
    finish = set(first.finish_flags)
    end = (first.p2[0], first.p2[1])
    return [t for t in lines if t is not first and finish & set(t.start_flags)
            and t.p1 is not None and distance((t.p1[0], t.p1[1]), end) < CHAIN_GAP]
