"""The heading from the motion: an orientation sensor's offset from the course made good.

A heading sensor can read far off the truth and stay there: an odometry-integrated heading
started from the wrong initial heading (a recording's ``init_heading_offset``), a compass
mounted turned round, an AHRS 180° out after a reset. The EKF's heading-bias state learns a
bias by linearising about its estimate, which reaches a few tens of degrees, not 90° or 180°:
Plaza1 with its heading 90° out scored 3.2 m RMS, 180° out 36 m with 45 re-initialisations,
the filter steering its dead reckoning backwards while the ranges pulled it home.

The position data say which way the vehicle moves whatever the sensor says. Over a run of
``RUN`` metres between two fixes (LSQ fixes or an XY sensor's), with the sensor's headings
over that time within ``MAX_TURN`` of their mean (the vehicle went straight), the heading the
filter takes from the sensor (each reading less the bias the filter held then) is off the
course made good by the correction its bias needs. ``SAMPLES`` such runs within ``WINDOW``
seconds agreeing within ``MAX_SPREAD``, and spanning ``MIN_SPAN`` with no gap over ``MAX_GAP``
unless the sensor reads turned round, make an estimate: coarse alignment, as an inertial
system aligns its heading from GPS. Taken against the bias held at each reading, a bias the
filter follows as it drifts (an integrated heading, 0.6°/s) leaves no correction, where the
sensor's raw offset averaged over the window would lag it. A run while any body-velocity
reading says the vehicle goes astern, or crabs beyond ``MAX_TURN``, is not used (its course
is not its heading), nor one the body velocity says the vehicle did not travel (``MOVED``: the
fixes moved, not the vehicle).

A filter that refuses the sensor (it contradicts the motion: kicked, stuck) holds its heading
from the motion meanwhile, and the bias it holds goes stale; its heading is then right, and
turning it by the bias's change, as for a filter that followed the sensor, makes it wrong
(Plaza1, the heading drifting and stuck at once: 12.5 m RMS). So each reading also gives its
offset from the filter's own heading (``held``), and each run the filter's heading error
against the course. That offset has no course in it, none of the fixes' error (runs between
LSQ fixes 5 m apart: courses 10-20° out, the offset to a degree), so runs agreeing on it
across gaps make an estimate too: a steady offset, not a kick, once they span ``MIN_SPAN``.

The same runs tell which way round the sensor reads (``sense``), where a yaw rate turned
against it (:mod:`mavhelm.nav.rate_sense`): read the right way round, its offset from the
courses holds across the vehicle's turns; the wrong way round, it turns twice as far as the
vehicle.

Pure logic: the navigator (:mod:`mavhelm.nav.fusion`) feeds it and decides when to use it.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Final

WINDOW: Final = 60.0
"""s: how long fixes, headings and runs are kept."""
RUN: Final = 8.0
"""m: the shortest run a course made good is measured over (a 1 m fix error is 6° on it)."""
MAX_TURN: Final = math.radians(20.0)
"""rad: a run whose headings stray further than this from their mean was a turn."""
STRAIGHT: Final = math.cos(MAX_TURN)
"""The cosine of a reading's angle from the run's mean heading, at least, in a straight run."""
SAMPLES: Final = 3
"""Runs (one per new fix) that must agree before the offset is believed."""
MIN_SPAN: Final = 25.0
"""s: the runs that agree on an offset short of ``TURNED_ROUND`` must span this long: an
offset that lasts, not a compass kicked 30–90° for 5–20 s by a motor, which the heading
watch rejects while it lasts (taken from three runs in a kick, the heading was turned twice
and the bias left 18° wrong: Plaza1 1.74 m RMS on one draw of the jumps)."""
MAX_GAP: Final = 15.0
"""s: and follow one another within this. Runs agreeing across a silence (a turn, no fixes)
do not show an offset that lasted: on Plaza1 as recorded, two runs at 1766–1771 s and three
22 s later agreed on 24°, and the heading was turned by it at 1824 s (a 0.8 m bump); with the
heading jumps (one draw), a run 30 s before a 14 s kick and three in it agreed on 65°, and
the heading was turned by it as the kick ended (1.6 m RMS over the last 100 s). With the
rule, clean Plaza1 0.37 → 0.36 m RMS, p95 0.72 → 0.65 m; of the heading faults' draws
(seeds 1–3) none is realigned and none scores worse."""
TURNED_ROUND: Final = math.radians(120.0)
"""rad: an offset this large (a sensor mounted or reset turned round) is taken at once: the
filter would steer its dead reckoning backwards in the meantime."""
MAX_SPREAD: Final = math.radians(15.0)
"""rad: their circular spread at most."""
MOVED: Final = 0.5
"""A run whose length the body-velocity readings over it do not make this share of is a fix
error, not motion: a vehicle standing still between two LSQ fixes a range outlier threw 8 m
apart (Plaza1 with 5 % of its ranges wrong: 25 such runs agreed within 2° on a −78° offset,
and the heading was turned by it, 0.15 → 21.9 m)."""
SENSE_RUNS: Final = 6
"""Runs the course made good must have been measured over before it is asked which way the
headings turn (:meth:`MotionAlignment.sense`)."""
SENSE_SPREAD: Final = math.radians(20.0)
"""rad: the circular spread of the sensor's offsets from the courses, read one way round,
at most for that way to be believed ..."""
SENSE_RATIO: Final = 3.0
"""... and the other way's at least this many times larger (along one course, or any
straight line, the two spread alike: no answer)."""
HEADING_EVERY: Final = 0.2
FIX_EVERY: Final = 0.5
"""s: readings and fixes closer in time to the last one kept are not kept: a run's mean is as
well told by 5 headings a second, and 2 runs a second are plenty to agree on; a 20 Hz heading
and a 5 Hz GPS would otherwise cost a pass over a hundred readings five times a second."""


def course_yaw(dx: float, dy: float) -> float:
    """The course of a run (dx east, dy north) as a yaw (rad, yaw = −heading)."""
    return -math.atan2(dx, dy)


@dataclass(frozen=True)
class Sense:
    """Which way round the headings turn against the courses made good: ``reversed`` where
    only negated they keep one offset from them; ``bias`` (rad, yaw) is the offset of the
    reading taken the right way round from the course, to ``spread``, over ``runs`` runs;
    ``velocity`` (east, north, m/s) the latest run's."""

    reversed: bool
    bias: float
    spread: float
    runs: int
    velocity: tuple[float, float]


@dataclass(frozen=True)
class Alignment:
    """The heading bias the filter held is short of the sensor's offset from the course made
    good by ``correction`` (rad, yaw), to ``spread``, over ``runs`` runs; ``velocity``
    (east, north, m/s) is the latest run's. ``stale`` is the sensor's offset from the
    filter's own heading beyond the bias held, to ``stale_spread`` (no course in it, so no
    fix error): near zero while the filter follows the sensor, the bias's staleness while
    it holds its heading from the motion and refuses the sensor. ``heading_error`` (rad,
    yaw) is how far the filter's heading was off the course made good over the runs (the
    correction itself when the filter followed the sensor). ``told``: the correction is
    told (the runs agree on it and lasted)."""

    correction: float
    spread: float
    runs: int
    velocity: tuple[float, float]
    heading_error: float
    stale: float
    stale_spread: float
    told: bool


class MotionAlignment:
    """``add_fix``, ``add_heading`` and ``add_body_velocity`` as data come (in time order);
    ``estimate()`` when asked (kept until the next run); ``clear()`` once one has been used.
    Each queue keeps ``WINDOW`` seconds, so the work per reading is bounded by its run."""

    def __init__(self) -> None:
        self._fixes: deque[tuple[float, float, float]] = deque()
        self._headings: deque[tuple[float, ...]] = deque()
        """(t, sine, cosine) of each reading less the bias held, then the sine and cosine of
        its offset from the filter's own heading then, then of the reading itself; computed
        once."""
        self._astern: deque[float] = deque()
        self._speeds: deque[tuple[float, float]] = deque()
        """(t, speed over the ground the body velocity says, m/s)."""
        self._runs: deque[tuple[float, ...]] = deque()
        """(t, sine, cosine) of each run's correction, then of the sensor's offset from the
        filter's heading over it, then of the filter's heading error (the two's difference);
        their sums kept as runs come and go."""
        self._sums: tuple[float, ...] = (0.0,) * 6
        self._gaps: deque[tuple[float, float]] = deque()
        """(t, the time since the run before) of the runs whose gap is larger than every
        later run's: the first is the window's largest gap, kept as runs come and go."""
        self._courses: deque[tuple[float, ...]] = deque()
        """(t, sine, cosine) of the sensor's mean raw reading less the course made good over
        each straight run, then of the reading negated less the course: which way round the
        sensor turns (:meth:`sense`); their sums kept as runs come and go, as the runs'."""
        self._course_sums: tuple[float, ...] = (0.0,) * 4
        self._velocity = (0.0, 0.0)
        self._bias = 0.0
        """The bias the filter held for the latest reading."""
        self._off: float | None = None
        """When position fixes last said the filter is off (:meth:`filter_off`)."""
        self._estimate: Alignment | None = None
        self._fresh = True

    def clear(self) -> None:
        self._fixes.clear()
        self._headings.clear()
        self._astern.clear()
        self._speeds.clear()
        self._runs.clear()
        self._gaps.clear()
        self._courses.clear()
        self._sums = (0.0,) * 6
        self._course_sums = (0.0,) * 4
        self._off = None
        self._estimate, self._fresh = None, True

    def filter_off(self, t: float) -> None:
        """Position fixes refused in a row as the vehicle moved said the filter is off, not
        the fixes (:mod:`mavhelm.nav.fix_watch`): runs that agree need not last
        ``MIN_SPAN``. A kick the filter followed would have to outlast the fix watch's run
        and still agree with the courses; a filter steering its dead reckoning by a sensor
        out from the start runs off at once (the box patrol on GPS, its compass 113° out:
        the runs agreed within 1° from 11 s, taken at 35 s, 23 m off by then)."""
        self._off = t
        self._fresh = False

    def add_heading(self, t: float, yaw: float, bias: float = 0.0,
                    held: float | None = None) -> None:
        """A reading of the orientation sensor (rad, yaw = −heading), the heading bias the
        filter holds for it then, and the filter's own yaw then (``held``; by default the
        reading less the bias, a filter that follows the sensor)."""
        headings = self._headings
        if headings and t - headings[-1][0] < HEADING_EVERY:
            return
        self._bias = bias
        a = yaw - bias
        off = 0.0 if held is None else a - held
        headings.append((t, math.sin(a), math.cos(a), math.sin(off), math.cos(off),
                         math.sin(yaw), math.cos(yaw)))
        while headings[0][0] < t - WINDOW:
            headings.popleft()

    def add_body_velocity(self, t: float, forward: float, starboard: float | None) -> None:
        """A body-velocity reading (m/s): how far the vehicle went, and going astern, or
        crabbing beyond ``MAX_TURN``, the course is not the heading."""
        speeds = self._speeds
        if not speeds or t - speeds[-1][0] >= HEADING_EVERY:
            speeds.append((t, math.hypot(forward, starboard or 0.0)))
            while speeds[0][0] < t - WINDOW:
                speeds.popleft()
        if forward < 0.0 or (starboard is not None
                             and abs(math.atan2(starboard, forward)) > MAX_TURN):
            astern = self._astern
            astern.append(t)
            while astern[0] < t - WINDOW:
                astern.popleft()

    def add_fix(self, t: float, x: float, y: float) -> None:
        """A position fix; a run ending at it is measured when one long enough exists."""
        fixes, runs = self._fixes, self._runs
        if fixes and t - fixes[-1][0] < FIX_EVERY:
            return
        while fixes and fixes[0][0] < t - WINDOW:
            fixes.popleft()
        while runs and runs[0][0] < t - WINDOW:
            _, *old = runs.popleft()
            self._sums = tuple(a - b for a, b in zip(self._sums, old, strict=True))
            self._fresh = False
        gaps = self._gaps
        while gaps and (not runs or gaps[0][0] <= runs[0][0]):  # its run before has left
            gaps.popleft()
        courses = self._courses
        while courses and courses[0][0] < t - WINDOW:
            _, *old = courses.popleft()
            self._course_sums = (tuple(a - b for a, b in zip(self._course_sums, old, strict=True))
                                 if courses else (0.0,) * 4)
        start = None
        for fix in reversed(fixes):  # the latest fix a run's length back
            if math.hypot(x - fix[1], y - fix[2]) >= RUN:
                start = fix
                break
        fixes.append((t, x, y))
        if start is None or start[0] >= t:
            return
        t0, x0, y0 = start
        if any(t0 <= ta <= t for ta in _since(self._astern, t0)):
            return
        dx, dy = x - x0, y - y0
        speeds = [v for tv, v in _since(self._speeds, t0) if tv <= t]
        if speeds and sum(speeds) / len(speeds) * (t - t0) < MOVED * math.hypot(dx, dy):
            return
        readings = [h for h in _since(self._headings, t0) if h[0] <= t]
        if len(readings) < 2:
            return
        # the six sums in one pass over the run's readings
        s1 = c1 = s2 = c2 = s3 = c3 = 0.0
        for _, a, b, c, d, e, f in readings:
            s1 += a
            c1 += b
            s2 += c
            c2 += d
            s3 += e
            c3 += f
        mean = math.atan2(s1, c1)
        sm, cm = math.sin(mean), math.cos(mean)
        for h in readings:
            if h[2] * cm + h[1] * sm < STRAIGHT:  # it strays more than MAX_TURN: a turn
                return
        course = course_yaw(dx, dy)
        raw = math.atan2(s3, c3)
        offsets = (math.sin(raw - course), math.cos(raw - course),
                   math.sin(-raw - course), math.cos(-raw - course))
        courses.append((t, *offsets))
        self._course_sums = tuple(a + b for a, b in zip(self._course_sums, offsets, strict=True))
        correction = mean - course
        stale = math.atan2(s2, c2)
        run = (math.sin(correction), math.cos(correction), math.sin(stale), math.cos(stale),
               math.sin(correction - stale), math.cos(correction - stale))
        if runs:
            gap = t - runs[-1][0]
            while gaps and gaps[-1][1] <= gap:
                gaps.pop()
            gaps.append((t, gap))
        runs.append((t, *run))
        self._sums = tuple(a + b for a, b in zip(self._sums, run, strict=True))
        self._velocity = (dx / (t - t0), dy / (t - t0))
        self._fresh = False

    def estimate(self) -> Alignment | None:
        """Once ``SAMPLES`` runs span ``MIN_SPAN``: the correction, where they agree on it
        within ``MAX_SPREAD`` and followed one another within ``MAX_GAP`` (or it is
        ``TURNED_ROUND``); or the sensor's offset from the filter's heading, where they agree
        on that within ``MAX_SPREAD`` and it is larger than that, gaps or not: free of the
        courses' errors, it is a steady offset, not a kick that runs in it happened to
        share. The span is waived once the fixes said the filter is off (:meth:`filter_off`),
        and the sensor's raw offset from the courses is taken instead of the corrections
        where it agrees more tightly (:meth:`_steady`). Else None."""
        if self._fresh:
            return self._estimate
        self._fresh, self._estimate = True, None
        n = len(self._runs)
        if n < SAMPLES:
            return None
        correction, spread = _circular(self._sums[0], self._sums[1], n)
        stale, stale_spread = _circular(self._sums[2], self._sums[3], n)
        heading_error, _ = _circular(self._sums[4], self._sums[5], n)
        first, last = self._runs[0][0], self._runs[-1][0]
        spanned = last - first >= MIN_SPAN
        lasted = (spanned and self._gaps[0][1] <= MAX_GAP) or (
            self._off is not None and self._off >= last - WINDOW)
        told = spread <= MAX_SPREAD and (lasted or abs(correction) >= TURNED_ROUND)
        steady = self._steady(lasted)
        if steady is not None and (not told or steady[1] < spread):
            (correction, spread), told = steady, True
        if told or (spanned and stale_spread <= MAX_SPREAD and abs(stale) >= MAX_SPREAD):
            self._estimate = Alignment(correction, spread, n, self._velocity, heading_error,
                                       stale, stale_spread, told)
        return self._estimate

    def _steady(self, lasted: bool) -> tuple[float, float] | None:
        """The correction and its spread where the sensor's raw offsets from the courses
        agree within ``MAX_SPREAD`` (and ``lasted``, or it is ``TURNED_ROUND``): a steady
        offset, taken against the bias the filter holds now. The runs' corrections, each
        against the bias held then, tell a bias the filter follows as it drifts; they cannot
        agree while the filter learns its bias from position fixes, and added to the bias
        now they count what it learned twice (the simulator's box patrol on GPS, compass,
        DVL and gyro, its compass 117° out from the start: the bias learned 47° in 25 s,
        the corrections spread past 15° until then, and the heading was taken 152° out,
        18.9 m off, 2.15 m RMS). Where both agree, the tighter is taken."""
        if len(self._courses) < SAMPLES:
            return None
        offset, spread = self._raw_offset(1.0)
        correction = math.remainder(offset - self._bias, 2 * math.pi)
        if spread > MAX_SPREAD or not (lasted or abs(correction) >= TURNED_ROUND):
            return None
        return correction, spread

    def _raw_offset(self, sign: float) -> tuple[float, float]:
        """The circular mean and spread of the sensor's mean raw reading (negated where
        ``sign`` is −1: read the wrong way round) less the course, over the straight runs."""
        sines, cosines = (self._course_sums[:2] if sign > 0 else self._course_sums[2:])
        return _circular(sines, cosines, len(self._courses))

    def sense(self) -> Sense | None:
        """Which way round the sensor turns, from the window's straight runs: read as it is,
        or negated (its sense the wrong way round), the readings keep one offset from the
        courses made good across the vehicle's turns, where the other way's offsets turn
        with them. None with fewer than ``SENSE_RUNS`` runs, or where neither way is
        clearly the one (runs all along one course cannot tell)."""
        n = len(self._courses)
        if n < SENSE_RUNS:
            return None
        as_read, spread = self._raw_offset(1.0)
        negated, negated_spread = self._raw_offset(-1.0)
        if negated_spread <= SENSE_SPREAD and spread >= SENSE_RATIO * negated_spread:
            return Sense(True, negated, negated_spread, n, self._velocity)
        if spread <= SENSE_SPREAD and negated_spread >= SENSE_RATIO * spread:
            return Sense(False, as_read, spread, n, self._velocity)
        return None


def _circular(sines: float, cosines: float, n: int) -> tuple[float, float]:
    """The circular mean and spread (rad) of ``n`` angles given by their sums of sines and
    cosines."""
    s, c = sines / n, cosines / n
    r = min(math.hypot(s, c), 1.0)
    return math.atan2(s, c), (math.sqrt(-2.0 * math.log(r)) if r > 0.0 else math.inf)


def _since(queue: deque, t0: float) -> list:
    """The entries of a time-ordered queue (times first, or times themselves) from ``t0``
    on, found from the newest end."""
    out = []
    for item in reversed(queue):
        if (item if isinstance(item, float) else item[0]) < t0:
            break
        out.append(item)
    out.reverse()
    return out
