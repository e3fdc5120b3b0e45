"""The gains that suit a fitted vehicle, chosen by predicting how each candidate flies.

The heading loop (spec 1.4.1) is a PD on the heading error whose rudder becomes a commanded
turn rate (full rudder = ``MaxTurnRate``); the vehicle follows that rate through its fitted
model (lag τ, delay d, rate limit r_max, acceleration limit a_max). ``MaxTurnRate`` is r_max /
K: full rudder asks for the fastest turn the vehicle makes (asking for more only winds up the
autopilot's rate controller), and never less than r_max: a fit whose gain K comes out above 1
is a poor one (the real SITL motorboat-skid at 5 m/s, whose turn rate overshoots its command,
fitted K 2.3 once, and MaxTurnRate 44 swung 2 m after every turn). The rest is searched, not
read off a formula: a linear design (a PD zero on τ, a phase margin on d) misses what sets the
swing after a turn — the rate and acceleration limits, the helm's tick and its 5-tap derivative
(measured on the real SITL in ``benchmarks/bench_tracking.py``).

Every candidate (the heading loop's gain Kψ = KP·K·MaxTurnRate/MAXRUDDER, KD/KP and the
tasks' ``LeadTime``) is simulated on the model, all at once (numpy over the candidates):

- a 30° heading step: how long to stay within 1°, and the overshoot;
- a survey's U-turn at the cruise speed (a leg, the 20 m join, the next leg, the turn planned
  and flown as ``mavhelm.tasks.turn_plan`` does it: one half circle beyond the legs' ends
  where the candidate's Lead makes it one, else an arc at each corner, each line left its
  turn-in early and the next entered along the arc; the track over the ground following the
  heading the fitted course lag late, the sideslip and the fix's latency): the largest
  cross-track error on the next leg from 10 m along it (the issue's window), and how long
  after the leg starts its cross-track error stays within 0.1 m.

The heading step is flown with the candidate's heading loop (``YAW_PID``, the heading tasks');
the U-turn with the line tasks' own loop (``LINE_PID``), whose gain is not searched but kept at
``LINE_LOOP_GAIN`` with no derivative: the model cannot rank line loops among those that
settle (it predicted soft ones best, and on the real SITL they swung 0.23-0.54 m after a
U-turn where the stiff one held 0.11-0.32 m), so the tune keeps the loop measured best on every
model. On a vehicle slower than any it was measured on (``LINE_MAX_LAG``: a derivative and a
longer Lead may be what holds its line) the line loop is searched as the heading loop is,
each candidate flying the U-turn on its own gains, and taken if predicted to swing less.

Each with the loop's delay (the fitted one and the telemetry's age when the helm steers on
it) and up to 0.1 s more (``DELAY_STEPS``: GPS latency and what the fit does not see), the
U-turn at 0.9–1.1 of the speed, the worst counting. The baseline (the product's defaults) is
one of the candidates, and a candidate is taken only if it is predicted no slower and no less
damped than the baseline on every one of these, so the tune never writes gains predicted
worse than the defaults.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from mavhelm.tuning.model import YawModel

FIR_TAPS = 5
"""The helm's derivative averages this many differences (``mavhelm.tasks.pid``)."""
DT = 0.02
"""Simulation step, s."""
DELAY_STEPS = (0.0, 0.05, 0.1)
"""Delays added to the fitted one, s: telemetry and GPS latency the fit does not see."""
SPEED_SPREAD = (0.9, 1.0, 1.1)
"""The U-turn is flown at these fractions of the cruise speed: a line's speed varies, and the
swing after a turn is sensitive to it (one run to the next on the SITL differs by ±0.3 m at
5 m/s), so a candidate must do well across them, not at one lucky point."""
KPSI = tuple(float(v) for v in np.geomspace(0.7, 5.0, 10))
"""Loop gains tried, 1/s (degrees per second of turn per degree of heading error); down to 0.7:
with the turns planned, a vehicle of long delay (0.8 s) is best served by a loop below 1 /s."""
KD_RATIOS = (0.0, 0.1, 0.2, 0.3, 0.45, 0.6)
"""KD/KP tried: the helm's derivative is a 5-tap average two ticks late, so more adds lag."""
LEAD_TIMES = (0.8, 1.0, 1.25, 1.5, 2.0)
"""LeadTime tried, s."""
MIN_LEAD = 1.0
HEADING_STEP = 30.0
HEADING_TOLERANCE = 1.0
HEADING_RISE = 5.0
"""Degrees: a heading step has risen once this close to the new heading."""
HEADING_HORIZON = 12.0
LINE_TOLERANCE = 0.1
JOIN = 20.0
"""The survey's join between legs, m (``benchmarks/bench_tracking.py``'s pattern)."""
LEG_WINDOW = (10.0, 60.0)
"""Where on the next leg the swing is measured, m along it."""
SLACK = 1.02
"""A candidate may be this much (2 %) worse than the baseline on one figure (a tie)."""
LINE_LOOP_GAIN = 4.5
"""The line tasks' heading loop (``LINE_PID``) as commanded, degrees per second of turn asked per
degree of heading error (LINE_PID_KP × MaxTurnRate / MAXRUDDER): LINE_PID_KP 1.0, KD 0 at
MaxTurnRate 90 and MAXRUDDER 20, the loop that held every real SITL model's lines best at 5 m/s
(``mavhelm.tasks.pid.HelmGains.line_pid``). The tune scales LINE_PID_KP so the loop asks for
the same at the MaxTurnRate it writes. Not by the fitted turn-rate gain K: the loop measured
best was measured so, on vehicles whose fits gave K 0.8-1.1 (one boat 0.79-1.14 from one tune
to the next), and scaled by K the model's preference for softer line loops (the wrong way,
above) kept the defaults."""
LINE_MAX_LAG = 0.5
"""s: the fitted turn-rate time constant plus the loop's delay (the fitted one and the
telemetry's age) up to which the tune keeps the stiff line loop. The real SITL models it was
measured best on fit 0.07-0.33 s (eighteen tunes, 2026-12-02; the motorboat 0.15-0.33 from one
tune to the next), well under this; the stiff loop's own time constant is 0.22 s. Not the model's
prediction of the U-turn: on the skid boat in the stock wind it predicted the stiff loop would
swing 1.50 m and chose a soft one with KD, which flew 0.32-0.37 m where the stiff loop flies
0.18-0.25 m."""
DEFAULT_LINE_KP = 1.0
"""``LINE_PID_KP``'s default (``mavhelm.tasks.pid``, restated: tuning imports only core)."""


@dataclass(frozen=True)
class Gains:
    yaw_kp: float
    yaw_kd: float
    max_turn_rate: float
    lead_time: float
    """The tasks' LeadTime, s: the Lead is this many seconds of the speed."""
    loop_gain: float = math.nan
    """Kψ on the fitted vehicle, 1/s: degrees per second of turn per degree of heading
    error."""
    line_kp: float = DEFAULT_LINE_KP
    line_kd: float = 0.0
    """The line tasks' heading loop (``LINE_PID_KP``, ``LINE_PID_KD``)."""

    def lead(self, speed: float) -> float:
        """The TrackLine/Survey Lead (m) for a task run at ``speed`` (m/s)."""
        return max(MIN_LEAD, round(max(speed, 0.0) * self.lead_time, 1))


@dataclass(frozen=True)
class Prediction:
    heading_settle: float
    """Seconds for a 30° heading step to stay within 1°."""
    heading_overshoot: float
    """Degrees past the new heading."""
    line_settle: float | None
    """Seconds from the start of a survey's next leg, after the U-turn onto it, until the
    cross-track error stays within 0.1 m (None: no speed)."""
    turn_swing: float | None = None
    """Largest cross-track error (m) on a survey's next leg from 10 m along it, after the
    U-turn onto it (None: no speed)."""
    heading_rise: float | None = None
    """Seconds for a 30° heading step to first come within ``HEADING_RISE`` of the new
    heading: a loop too slow to matter can tie with the defaults on the settling (neither
    settling within 1° in the horizon on a vehicle that limit-cycles), not on this."""

    def no_worse_than(self, other: Prediction) -> bool:
        """At least as fast and as well damped as ``other`` on every figure (within SLACK)."""
        pairs = [(self.heading_settle, other.heading_settle),
                 (self.heading_overshoot, max(other.heading_overshoot, 0.5)),
                 (self.line_settle, other.line_settle), (self.turn_swing, other.turn_swing),
                 (self.heading_rise, other.heading_rise)]
        return all(a <= b * SLACK + 1e-9 for a, b in pairs if a is not None and b is not None)

    def describe(self, speed: float | None) -> str:
        rise = "" if self.heading_rise is None else \
            f"comes within {HEADING_RISE:g} deg in {self.heading_rise:.1f} s, "
        text = (f"a {HEADING_STEP:g} deg heading step {rise}settles within "
                f"{HEADING_TOLERANCE:g} deg in {self.heading_settle:.1f} s (overshoot "
                f"{self.heading_overshoot:.1f} deg)")
        if self.line_settle is not None and speed is not None:
            text += (f"; at {speed:.2f} m/s a survey's U-turn swings {self.turn_swing:.2f} m "
                     f"on the next leg from 10 m along it, within {LINE_TOLERANCE:g} m "
                     f"{self.line_settle:.1f} s after the leg starts")
        return text


@dataclass(frozen=True)
class Candidates:
    """Arrays of gains, one entry per candidate."""

    kp: np.ndarray
    kd: np.ndarray
    max_turn_rate: np.ndarray
    lead_time: np.ndarray
    line_kp: np.ndarray
    line_kd: np.ndarray

    @classmethod
    def of(cls, gains: list[Gains]) -> Candidates:
        return cls(*(np.array([getattr(g, f) for g in gains], dtype=float)
                     for f in ("yaw_kp", "yaw_kd", "max_turn_rate", "lead_time", "line_kp",
                               "line_kd")))


class _Loop:
    """The heading loop of every candidate, stepped together: the helm's PD with its 5-tap
    derivative at each tick, the rudder as a turn rate, the vehicle's delay, lag and limits."""

    def __init__(self, kp: np.ndarray, kd: np.ndarray, max_turn_rate: np.ndarray,
                 yaw: YawModel, delay: float, max_rudder: float, app_tick: float,
                 psi0: float = 0.0) -> None:
        n = len(kp)
        self.kp, self.kd, self.yaw, self.max_rudder = kp, kd, yaw, max_rudder
        self.per_rudder = max_turn_rate / max_rudder
        self.period = 1.0 / app_tick
        self.psi = np.full(n, psi0)
        self.rate = np.zeros(n)
        self.last_err = np.zeros(n)
        self.diffs: list[np.ndarray] = []
        self.pending = [np.zeros(n) for _ in range(max(1, round(delay / DT)))]
        self.command = np.zeros(n)
        self.next_tick = 0.0
        self.lag = 1.0 - math.exp(-DT / max(yaw.time_constant, 1e-3))

    def step(self, desired: np.ndarray, t: float) -> None:
        if t >= self.next_tick - 1e-9:
            err = (desired - self.psi + 180.0) % 360.0 - 180.0
            if self.next_tick > 0.0:
                diff = (err - self.last_err + 180.0) % 360.0 - 180.0
                self.diffs = [*self.diffs[-(FIR_TAPS - 1):], diff / self.period]
            self.last_err = err
            d = sum(self.diffs) / len(self.diffs) if self.diffs else 0.0
            rudder = np.clip(self.kp * err + self.kd * d, -self.max_rudder, self.max_rudder)
            self.command = rudder * self.per_rudder
            self.next_tick += self.period
        self.pending.append(self.command)
        applied = self.pending.pop(0)
        yaw = self.yaw
        target = np.clip(yaw.gain * applied, -yaw.rate_limit, yaw.rate_limit)
        change = (target - self.rate) * self.lag
        bound = yaw.accel_limit * DT
        self.rate += np.clip(change, -bound, bound)
        self.psi += self.rate * DT


def _settle(err: np.ndarray, ts: np.ndarray, tol: float) -> np.ndarray:
    """Per candidate (column), the time after which |err| stays within ``tol``."""
    outside = np.abs(err) > tol
    last = np.where(outside.any(axis=0), len(ts) - 1 - np.argmax(outside[::-1], axis=0), -1)
    return np.where(last < 0, 0.0, ts[np.minimum(last + 1, len(ts) - 1)])


def _heading_step(c: Candidates, yaw: YawModel, delay: float, max_rudder: float,
                  app_tick: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    loop = _Loop(c.kp, c.kd, c.max_turn_rate, yaw, delay, max_rudder, app_tick)
    desired = np.full(len(c.kp), HEADING_STEP)
    steps = int(HEADING_HORIZON / DT)
    errs = np.empty((steps, len(c.kp)))
    for i in range(steps):
        loop.step(desired, i * DT)
        errs[i] = HEADING_STEP - loop.psi
    ts = np.arange(steps) * DT
    near = np.abs(errs) <= HEADING_RISE
    rise = np.where(near.any(axis=0), ts[np.argmax(near, axis=0)], HEADING_HORIZON)
    return _settle(errs, ts, HEADING_TOLERANCE), np.maximum(0.0, -errs.min(axis=0)), rise


FIT = 0.5
"""A planned turn's arc joins each line no further than this fraction of it from the corner
(``mavhelm.tasks.turn_plan.FIT``)."""
U_TURN_LEADS = (0.5, 2.0)
"""A U-turn is one half circle when half its join is within these many Leads
(``mavhelm.tasks.turn_plan.U_TURN_LEADS``)."""


@dataclass(frozen=True)
class _Arcs:
    """One planned turn per candidate (``mavhelm.tasks.turn_plan.Arc``), as arrays: the
    start, the end, the centre, the radius, the direction in (degrees) and the signed sweep
    (radians, positive clockwise)."""

    sx: np.ndarray
    sy: np.ndarray
    ex: np.ndarray
    ey: np.ndarray
    cx: np.ndarray
    cy: np.ndarray
    radius: np.ndarray
    heading_in: np.ndarray
    sweep: np.ndarray


def _bearing(x0: np.ndarray, y0: np.ndarray, x1: np.ndarray, y1: np.ndarray) -> np.ndarray:
    return np.degrees(np.arctan2(x1 - x0, y1 - y0)) % 360.0


def _arc_heading(a: _Arcs, x: np.ndarray, y: np.ndarray, lead: np.ndarray,
                 ahead: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(desired heading, distance along the entry path, offset) of each candidate flying its
    planned turn, as ``Arc.heading`` and ``Arc.locate`` do."""
    side = np.sign(a.sweep)
    sweep = np.degrees(np.abs(a.sweep))
    length = a.radius * np.abs(a.sweep)
    heading_out = (a.heading_in + np.degrees(a.sweep)) % 360.0
    turned = (side * (_bearing(a.cx, a.cy, x, y) - _bearing(a.cx, a.cy, a.sx, a.sy))) % 360.0
    on_arc = turned <= sweep
    out = ~on_arc & (turned < (sweep + 360.0) / 2.0)
    ho, hi = np.radians(heading_out), np.radians(a.heading_in)
    past = (x - a.ex) * np.sin(ho) + (y - a.ey) * np.cos(ho)
    xte_out = (x - a.ex) * np.cos(ho) - (y - a.ey) * np.sin(ho)
    before = (x - a.sx) * np.sin(hi) + (y - a.sy) * np.cos(hi)
    xte_in = (x - a.sx) * np.cos(hi) - (y - a.sy) * np.sin(hi)
    s = np.where(on_arc, np.radians(turned) * a.radius, np.where(out, length + past, before))
    xte = np.where(on_arc, side * (a.radius - np.hypot(x - a.cx, y - a.cy)),
                   np.where(out, xte_out, xte_in))
    fraction = np.clip((s + ahead) / np.maximum(length, 1e-9), 0.0, 1.0)
    aim = a.heading_in + np.degrees(a.sweep) * fraction - np.degrees(np.arctan(xte / lead))
    return aim % 360.0, s, xte


def _u_turn_plan(lead: np.ndarray, leg: float, lag: float
                 ) -> tuple[np.ndarray, list[np.ndarray], list[_Arcs | None]]:
    """The survey's U-turn as ``mavhelm.tasks.turn_plan`` plans it, per candidate (a leg east
    to (0, 0), the join south to (0, -JOIN), the next leg west): (whether it is one half
    circle, how far before each corner the line is left, the entry path of the join and of
    the next leg, None where it has none)."""
    n = len(lead)
    half = JOIN / 2.0
    one = (U_TURN_LEADS[0] * lead <= half) & (half <= U_TURN_LEADS[1] * lead)
    r = np.minimum(lead, FIT * min(JOIN, leg))  # a 90° corner: tan 45° = 1
    leave = [np.where(one, min(lag, FIT * leg), np.minimum(r + lag, FIT * leg)),
             np.where(one, 0.0, np.minimum(r + lag, FIT * JOIN)), np.zeros(n)]
    full = np.full(n, 1.0)
    join = _Arcs(np.where(one, 0.0, -r), np.zeros(n), np.where(one, 0.0, 0.0),
                 np.where(one, -JOIN, -r), np.where(one, 0.0, -r), np.where(one, -half, -r),
                 np.where(one, half, r), full * 90.0, np.where(one, np.pi, np.pi / 2.0))
    onto_leg = _Arcs(np.zeros(n), -JOIN + r, -r, full * -JOIN, -r, -JOIN + r, r, full * 180.0,
                     full * np.pi / 2.0)
    return one, leave, [None, join, onto_leg]


def _pursuit(p1: np.ndarray, p2: np.ndarray, x: np.ndarray, y: np.ndarray,
             lead: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(desired heading, along, xte) of carrot-and-donkey on each candidate's line."""
    dx, dy = p2[:, 0] - p1[:, 0], p2[:, 1] - p1[:, 1]
    length = np.hypot(dx, dy)
    ux, uy = dx / length, dy / length
    rx, ry = x - p1[:, 0], y - p1[:, 1]
    along, xte = rx * ux + ry * uy, rx * uy - ry * ux
    s = np.minimum(along + lead, length)
    gx, gy = p1[:, 0] + s * ux, p1[:, 1] + s * uy
    return np.degrees(np.arctan2(gx - x, gy - y)), along, xte


@dataclass(frozen=True)
class Course:
    """What the lines are flown at: the cruise speed, the tasks' turn-in lag (s) and the lag
    of the track behind the heading."""

    speed: float | None
    turn_lag: float = 0.5
    course_lag: float = 0.0
    """How far the measured track over the ground lags the heading, s."""


def _u_turn(c: Candidates, yaw: YawModel, delay: float, max_rudder: float, app_tick: float,
            speed: float, course: Course) -> tuple[np.ndarray, np.ndarray]:
    """A leg east along y = 0 to (0, 0), the join south to (0, -JOIN), the next leg west,
    the track following the heading ``course.course_lag`` late: (largest |XTE| on the next
    leg in LEG_WINDOW, seconds from the start of that leg until its XTE stays within
    LINE_TOLERANCE)."""
    n = len(c.kp)
    lead = np.maximum(MIN_LEAD, c.lead_time * speed)
    leg = 10.0 * LEG_WINDOW[1]
    ahead = course.turn_lag * speed
    one, leave, entries = _u_turn_plan(lead, leg, ahead)
    corners = np.array([[-leg, 0.0], [0.0, 0.0], [0.0, -JOIN], [-leg, -JOIN]])
    run_in = JOIN + 2.0 * speed * max(LEAD_TIMES)
    x = np.full(n, -run_in)
    y = np.zeros(n)
    k = np.zeros(n, dtype=int)
    on_entry = np.zeros(n, dtype=bool)
    loop = _Loop(c.line_kp, c.line_kd, c.max_turn_rate, yaw, delay, max_rudder, app_tick,
                 psi0=90.0)
    track = [loop.psi.copy() for _ in range(round(course.course_lag / DT) + 1)]
    swing, settle, leg_start, last_big = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)
    t = 0.0
    horizon = (run_in + JOIN + np.pi * JOIN / 2.0 + LEG_WINDOW[1]) / max(speed, 0.1) + 10.0
    while t < horizon:
        _, along, _ = _pursuit(corners[k], corners[k + 1], x, y, lead)
        length = np.hypot(*(corners[k + 1] - corners[k]).T)
        turn_in = np.choose(k, leave)
        advance = (k < 2) & (along >= length - np.maximum(turn_in, 1.0))
        k = np.where(advance, k + 1, k)
        on_entry = np.where(advance, (k == 1) | ((k == 2) & ~one), on_entry)
        leg_start = np.where(advance & (k == 2), t, leg_start)
        desired, along, xte = _pursuit(corners[k], corners[k + 1], x, y, lead)
        for line, arcs in enumerate(entries):
            if arcs is None or not (on_entry & (k == line)).any():
                continue
            aim, s, offset = _arc_heading(arcs, x, y, lead, ahead)
            flying = on_entry & (k == line) & (s < arcs.radius * np.abs(arcs.sweep))
            on_entry &= ~(on_entry & (k == line)) | flying
            desired = np.where(flying, aim, desired)
            xte = np.where(flying, offset, xte)
        on_leg = k == 2
        window = on_leg & (along >= LEG_WINDOW[0]) & (along <= LEG_WINDOW[1])
        swing = np.where(window, np.maximum(swing, np.abs(xte)), swing)
        last_big = np.where(on_leg & (np.abs(xte) > LINE_TOLERANCE), t, last_big)
        settle = np.where(on_leg & (along <= LEG_WINDOW[1]),
                          np.maximum(last_big - leg_start, 0.0), settle)
        loop.step(desired, t)
        track.append(loop.psi.copy())
        heading = np.radians(track.pop(0))
        x += speed * np.sin(heading) * DT
        y += speed * np.cos(heading) * DT
        t += DT
    return swing, settle


def predict_all(gains: list[Gains], yaw: YawModel, course: Course, *, max_rudder: float,
                app_tick: float) -> list[Prediction]:
    """Each candidate's prediction: the worst over DELAY_STEPS and SPEED_SPREAD."""
    c = Candidates.of(gains)
    speed = course.speed if course.speed is not None and course.speed > 0.05 else None
    figures = []
    for extra in DELAY_STEPS:
        delay = yaw.loop_delay + extra
        settle, overshoot, rise = _heading_step(c, yaw, delay, max_rudder, app_tick)
        for factor in SPEED_SPREAD if speed is not None else (1.0,):
            swing = line = np.full(len(gains), np.nan)
            if speed is not None:
                swing, line = _u_turn(c, yaw, delay, max_rudder, app_tick, speed * factor,
                                      course)
            figures.append(np.vstack([settle, overshoot, line, swing, rise]))
    worst = np.fmax.reduce(np.stack(figures), axis=0)
    out = []
    for i in range(len(gains)):
        h_settle, h_over, l_settle, l_swing, h_rise = (float(v) for v in worst[:, i])
        out.append(Prediction(h_settle, h_over, None if speed is None else l_settle,
                              None if speed is None else l_swing, h_rise))
    return out


def predict(gains: Gains, yaw: YawModel, speed: float | None, *, max_rudder: float,
            app_tick: float, turn_lag: float = 0.5) -> Prediction:
    """One set of gains' prediction on this vehicle at ``speed``."""
    return predict_all([gains], yaw, Course(speed, turn_lag), max_rudder=max_rudder,
                       app_tick=app_tick)[0]


def candidates(yaw: YawModel, max_rudder: float, *, stiff_lines: bool = True) -> list[Gains]:
    """The searched gains: MaxTurnRate r_max / K (at least r_max), every Kψ, KD/KP and
    LeadTime; the line loop ``LINE_LOOP_GAIN`` with no KD (``stiff_lines``), else the
    candidate's heading loop."""
    max_turn_rate = float(max(5.0, min(180.0, round(yaw.rate_limit / min(yaw.gain, 1.0)))))
    per_rudder = yaw.gain * max_turn_rate / max_rudder
    stiff = (round(LINE_LOOP_GAIN * max_rudder / max_turn_rate, 3), 0.0)
    out = []
    for kpsi in KPSI:
        for ratio in KD_RATIOS:
            kp, kd = round(kpsi / per_rudder, 3), round(ratio * kpsi / per_rudder, 3)
            out += [Gains(kp, kd, max_turn_rate, lead_time, kpsi,
                          *(stiff if stiff_lines else (kp, kd)))
                    for lead_time in LEAD_TIMES]
    return out


def score(p: Prediction) -> float:
    """Smaller is better: the swing after a turn first, then how fast the loop settles."""
    swing = p.turn_swing if p.turn_swing is not None else 0.0
    line = p.line_settle if p.line_settle is not None else 0.0
    return swing + 0.02 * line + 0.02 * p.heading_settle + 0.01 * p.heading_overshoot


def design(yaw: YawModel, *, max_rudder: float, app_tick: float, course: Course | None = None,
           baseline: Gains | None = None, search: bool = True
           ) -> tuple[Gains, Prediction, Prediction | None]:
    """The best candidate predicted no worse than ``baseline`` (which is kept if none is):
    (gains, their prediction, the baseline's prediction). ``search`` False keeps the
    baseline (a model whose predictions are not trusted), predicted all the same. The line
    loop is the stiff one on a vehicle within ``LINE_MAX_LAG``."""
    course = course or Course(None)
    if baseline is not None:
        baseline = replace(baseline, loop_gain=baseline.yaw_kp * yaw.gain
                           * baseline.max_turn_rate / max_rudder)
    best = _best(candidates(yaw, max_rudder) if search or baseline is None else [], yaw,
                 course, baseline, max_rudder=max_rudder, app_tick=app_tick)
    swing = best[1].turn_swing
    if search and swing is not None and yaw.time_constant + yaw.loop_delay > LINE_MAX_LAG:
        searched = _best(candidates(yaw, max_rudder, stiff_lines=False), yaw, course,
                         baseline, max_rudder=max_rudder, app_tick=app_tick)
        if searched[1].turn_swing is not None and searched[1].turn_swing < swing:
            best = searched
    return best


def _best(pool: list[Gains], yaw: YawModel, course: Course, baseline: Gains | None, *,
          max_rudder: float, app_tick: float) -> tuple[Gains, Prediction, Prediction | None]:
    """The best-scored of ``pool`` predicted no worse than ``baseline`` (appended to it)."""
    pool = [*pool, *([baseline] if baseline is not None else [])]
    predictions = predict_all(pool, yaw, course, max_rudder=max_rudder, app_tick=app_tick)
    reference = predictions[-1] if baseline is not None else None
    best = min((i for i, p in enumerate(predictions)
                if reference is None or p.no_worse_than(reference)),
               key=lambda i: score(predictions[i]))
    return pool[best], predictions[best], reference
