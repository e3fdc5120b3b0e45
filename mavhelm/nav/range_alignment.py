"""The heading from the ranges: the dead-reckoned track turned until the ranges fit it.

:mod:`mavhelm.nav.alignment` takes a heading far out from the course made good between
position fixes. Where the fixes are an LSQ's from a few beacons they are good to metres
(Plaza1: 5 m RMS), and runs of ``alignment.RUN`` between them rarely agree within its spread:
a filter booted under way with its heading sensor half a turn out (Plaza1 replayed from
600 s with the heading drifting 180° in five minutes) steered its dead reckoning away, was
re-initialised from the LSQ twice and scored 13 m RMS against the LSQ's 5 m.

The ranges themselves are good to a metre. The track dead-reckoned from the body velocity and
the heading sensor's raw readings over the last ``WINDOW`` s, shifted and turned, must fit the
ranges heard along it (with a range scale and an offset shared by every beacon, and a speed
scale: :func:`mavhelm.nav.survey_check.fit_tracks`). Fitted from ``STARTS`` turns round the
circle, the best fit's turn is the sensor's offset from the true heading, wherever it lies,
and its shift says where the vehicle is. It is believed when the track spans ``MIN_SPAN`` s
and ``MIN_TRAVEL`` m, the ranges reach ``MIN_BEACONS`` beacons, the best fit is good and
``RATIO`` times better (robust χ² per degree of freedom) than any other turn's. The owner
acts on it where the filter's bias is ``MIN_TURN`` or more from it. A reading the filter
refused (a kicked or stuck sensor) would bend the track (Plaza1's drifting and kicked heading,
one draw, 0.79 → 1.06 m when fitted so): the heading the filter holds the sensor to read
stands in for it (``refused_heading``), the yaw rate's continuation of the readings it took.
Until then the owner asked nothing for 40 s after a refusal, and a compass turned half a
round from the start and kicked as the robot first moved dead-reckoned it 10-16 m off twice
(Plaza1, 1.19 m RMS; stood in for, 0.61 m). Where the rate itself comes into question
(:mod:`mavhelm.nav.rate_sense`) the readings are restored (``restore_refused``) and the
owner asks nothing while the question is open and for a window after. Not on
the fit's position alone: restarting a filter whose heading the ranges confirm wherever a fit
put the vehicle 5 m from it cost Plaza1's kicked compass 0.36 → 0.89 m on one draw (a window
mostly of the robot standing still, fitted at χ² 1.3-1.9), for 2.5 → 1.4 m on the starts
under way whose heading was learned too late to keep the position.

Fitted with the headings negated too, the same track tells which way round the sensor reads
(``sense``), where a yaw rate turned against it (:mod:`mavhelm.nav.rate_sense`): read the
wrong way round, it bends the track the other way through every turn, and only negated does
it fit.

Range outliers count at most ``TRUNCATE`` σ each in a fit's χ², but they count in every fit
alike and narrow the ratios between them: with a fifth of Plaza1's ranges 5–50 m long (rays
round an obstacle) and its heading read the wrong way round, the track fitted 1.2–1.9 times
better negated and the sense was never told from the ranges (12.9 m RMS). So the fits of a
window are scored on the ranges the best of them finds within ``TRUNCATE`` σ, the same
ranges for every fit (``_rescored``; 0.83 m), unless it finds more than ``MAX_OUTLIERS``
beyond or leaves fewer than ``MIN_KEPT``: a fit of the wrong turn or shape calls good
ranges outliers too, and left with the ranges it fits, it would pass.

Pure logic: the navigator (:mod:`mavhelm.nav.fusion`) feeds it every reading and asks it only
once it has a reason to doubt the heading (a re-initialisation, the filter found adrift, the
heading doubted), so a healthy run pays nothing for it.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, replace
from typing import Final

import numpy as np

from mavhelm.nav.ekf import Beacon, wrap_angle
from mavhelm.nav.survey_check import PRIOR_SIGMA, TRUNCATE, Fit, fit_tracks

WINDOW: Final = 40.0
"""s of readings kept and fitted."""
MIN_SPAN: Final = 10.0
"""s the track must span."""
MIN_TRAVEL: Final = 5.0
"""m the track must cover: a still vehicle's track turns any way. Asked at every start from
rest under doubt, the ranges answer a few metres into the run: Plaza1 with its heading
sensor 180° out from the start, the heading found 57 s in against 87 s at 15 m (NAV RMS
0.93 → 0.62 m); no fault run lost by it (the ``RATIO`` and ``MAX_CHI2`` tests and two
answers in a row keep a short track from deciding wrongly)."""
MIN_RANGES: Final = 15
MIN_BEACONS: Final = 3
STARTS: Final = 8
"""Turns the fits start from, evenly round the circle."""
MIN_TURN: Final = math.radians(30.0)
"""rad: a bias error under this is the bias state's to learn; fits whose turns differ by
less are one answer."""
RATIO: Final = 2.0
"""How many times better the best fit must be than the best of any other answer. The still
part of the window fits any turn alike and dilutes the χ² per degree of freedom of both, so
the ratio a few metres into a run is small even where the answer is clear: Plaza1 with half
its ranges and the heading sensor 90-180° out from the start, the right turn 2.1-3.2 times
better than any other from the first fit on, answered 4.4 s later at 4 than at 2 while the
dead reckoning ran backwards (NAV 0.86-0.99 → 0.65-0.71 m RMS, seeds 1-6). Every Plaza1
fault, seeds 1-6, and the offset joined with each, seeds 1-3, the same or better (offset
and a speed scale 0.71 → 0.52 m); two answers in a row must still agree, and ``MAX_CHI2``
holds."""
SENSE_RATIO: Final = 3.0
"""How many times better the track must fit one way round than the other (at its best turn
each) to tell which way the headings turn."""
SENSE_EITHER: Final = 2.0
"""The same where one way round is known to be wrong, the question only which (a yaw rate
turned against a heading: one of the two is reversed). Range outliers raise both fits' χ²
(each counted at most ``survey_check.TRUNCATE`` σ), which narrows the ratio: Plaza1 with
its heading reversed and range outliers (seeds 2-3) fitted 2.0-2.9 times better negated
for 30-50 s before a ratio of 3 told it (0.71, 0.87 m RMS; the defaults' mission with the
rate reversed, seed 2, 2.25 m); at 2 it is told 10-12 s after the question opens, as
without outliers (0.52, 0.43, 0.55 m). Every answer of Plaza1's reversed heading or rate,
alone or joined with outliers, jumps, drift or a beacon moved, on starts under way and
thinned ranges, was the right one at either ratio."""
MAX_OUTLIERS: Final = 0.4
MIN_KEPT: Final = 30
"""The share of the window's ranges the best fit may find beyond ``TRUNCATE`` σ and leave
out of every fit's χ² (``_rescored``), and the ranges that must remain (five per parameter
fitted); else the window is judged with them in. A wrong fit calls good ranges outliers too:
Plaza1 with half its ranges, a fifth of them long (seed 3), a window 4 m into the run
fitted a turn 105° out from every start, with 26 of its 30 ranges at χ² 0.7 (2.1 with all
30): the heading turned round, 1.30 → 2.08 m RMS."""
MAX_CHI2: Final = 2.0
"""The best fit's robust χ² per degree of freedom at most (the ranges' σ as the filter
weighs them): a track of the wrong shape (a stuck sensor's, the vehicle turning) fits no
turn well (Plaza1, heading wandering and stuck: 5.0-5.7, a sensor turned round 0.3)."""


@dataclass(frozen=True)
class RangeHeading:
    """The sensor reads ``bias`` (rad, yaw) off the true heading; the fit puts the vehicle at
    (``x``, ``y``) to 1-σ ``sigma`` (m) at time ``t``, moving at ``velocity`` (east, north,
    m/s). ``chi2`` is the best fit's, ``chi2_other`` the best of the fits that turned the
    track ``MIN_TURN`` or more from it."""

    t: float
    bias: float
    x: float
    y: float
    sigma: float
    velocity: tuple[float, float]
    chi2: float
    chi2_other: float


class RangeAlignment:
    """``add_heading``, ``add_body_velocity`` and ``add_range`` as readings come (in time
    order); ``estimate`` when the owner doubts the heading."""

    def __init__(self, beacons: dict[str, Beacon]) -> None:
        self.beacons = beacons
        self._headings: deque[tuple[float, float]] = deque()
        self._refused: dict[float, float] = {}
        """The sensor's own readings where the filter's heading stands in for them."""
        self._velocities: deque[tuple[float, float, float]] = deque()
        self._ranges: deque[tuple[float, str, float, float, float]] = deque()

    def clear(self) -> None:
        self._headings.clear()
        self._refused = {}
        self._velocities.clear()
        self._ranges.clear()

    def add_heading(self, t: float, yaw: float) -> None:
        """A raw reading of the orientation sensor (rad, yaw = −heading)."""
        _keep(self._headings, (t, yaw))

    def refused_heading(self, t: float, yaw: float) -> None:
        """The reading at ``t`` was refused by the filter: ``yaw``, the heading the filter
        holds the sensor to read, stands in for it (until :meth:`restore_refused`), so a
        kicked sensor's jump does not bend the window's track."""
        headings = self._headings
        for k in range(len(headings) - 1, -1, -1):
            if headings[k][0] == t:
                self._refused.setdefault(t, headings[k][1])
                headings[k] = (t, yaw)
                break
            if headings[k][0] < t:
                break
        refused = self._refused
        while refused and headings:  # in time order: the oldest first
            oldest = next(iter(refused))
            if oldest >= headings[0][0]:
                break
            del refused[oldest]

    def restore_refused(self) -> None:
        """The refused readings back as the sensor gave them: the filter's own heading, which
        stood in for them, turned with a yaw rate now in question."""
        if self._refused:
            raw = self._refused
            self._headings = deque((t, raw.get(t, yaw)) for t, yaw in self._headings)
            self._refused = {}

    def add_body_velocity(self, t: float, forward: float, starboard: float | None) -> None:
        _keep(self._velocities, (t, forward, starboard or 0.0))

    def add_range(self, t: float, beacon: str, z: float, sigma: float,
                  height: float = 0.0) -> None:
        """A range (m, its σ) heard ``height`` m above the origin, accepted by the filter
        or not."""
        if beacon in self.beacons and math.isfinite(z):
            _keep(self._ranges, (t, beacon, z, sigma, height))

    def estimate(self, near: tuple[float, float]) -> RangeHeading | None:
        """The sensor's bias and the position from the window's fits; None where the track
        or the ranges are too few, the best fit is poor, or another turn fits nearly as
        well. ``near`` is a position guess for now (m)."""
        fitted = self._fits(near, mirrored=False)
        if fitted is None:
            return None
        fitted = _rescored(fitted)
        best, turn, stretch, _ = min(fitted, key=lambda f: f[0].chi2)
        others = [f[0].chi2 for f in fitted if abs(wrap_angle(f[1] - turn)) >= MIN_TURN]
        chi2_other = min(others, default=math.inf)
        if best.chi2 > MAX_CHI2 or chi2_other < RATIO * best.chi2:
            return None
        c, s = math.cos(turn), math.sin(turn)
        vx, vy = self._velocity()
        velocity = ((1 + stretch) * (c * vx - s * vy), (1 + stretch) * (s * vx + c * vy))
        return RangeHeading(best.t, wrap_angle(-turn), best.x, best.y, best.sigma, velocity,
                            best.chi2, chi2_other)  # the true yaw: the reading turned

    def sense(self, near: tuple[float, float], ratio: float = SENSE_RATIO) -> bool | None:
        """Whether the headings turn the wrong way: True where the track dead-reckoned from
        them negated fits the ranges ``ratio`` times better (robust χ² per degree of
        freedom) than from them as read, at any turn of either, False where as read fits so
        much better, None where the window cannot tell (a straight track is its own mirror
        image turned)."""
        both = []
        for mirrored in (False, True):
            fitted = self._fits(near, mirrored)
            if fitted is None:
                return None
            both.append(fitted)
        rescored = _rescored(both[0] + both[1])
        as_read = min(f[0].chi2 for f in rescored[:len(both[0])])
        negated = min(f[0].chi2 for f in rescored[len(both[0]):])
        if negated <= MAX_CHI2 and as_read >= ratio * negated:
            return True
        if as_read <= MAX_CHI2 and negated >= ratio * as_read:
            return False
        return None

    def mirror(self) -> None:
        """The headings kept so far negated: the sensor is now read the other way round."""
        self.restore_refused()
        self._headings = deque((t, -yaw) for t, yaw in self._headings)

    def _fits(self, near: tuple[float, float], mirrored: bool
              ) -> list[tuple[Fit, float, float, np.ndarray]] | None:
        """The window's track fitted from each of ``STARTS`` turns: (fit, turn, stretch,
        residuals in σ) each; None where the track or the ranges are too few."""
        track = self._track(mirrored)
        if track is None:
            return None
        times, east, north = track
        ranges = [r for r in self._ranges if times[0] <= r[0] <= times[-1]]
        if len(ranges) < MIN_RANGES or len({r[1] for r in ranges}) < MIN_BEACONS:
            return None
        rt = np.array([r[0] for r in ranges])
        ex, ey = np.interp(rt, times, east), np.interp(rt, times, north)
        columns = np.array([(z - self.beacons[b].offset, sd, self.beacons[b].x,
                             self.beacons[b].y, (self.beacons[b].z - h) ** 2, 0.0, 0.0)
                            for _, b, z, sd, h in ranges])
        columns[:, 5], columns[:, 6] = ex - ex[0], ey - ey[0]
        now = (float(east[-1] - ex[0]), float(north[-1] - ey[0]))
        kept = np.ones((1, len(ranges)), dtype=bool)
        found = []
        for k in range(STARTS):
            turn = 2 * math.pi * k / STARTS
            c, s = math.cos(turn), math.sin(turn)
            start = (near[0] - (c * now[0] - s * now[1]), near[1] - (s * now[0] + c * now[1]))
            try:
                fits, p, residual = fit_tracks(columns, kept, start, now, float(times[-1]),
                                               np.array([[turn, 0.0, 0.0, 0.0]]))
            except np.linalg.LinAlgError:
                continue
            if math.isfinite(fits[0].chi2):
                found.append((fits[0], float(p[0, 2]), float(p[0, 3]), residual[0]))
        return found or None

    def _track(self, mirrored: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The body velocity turned by the sensor's heading, integrated over the window:
        times, east and north (m); None when it spans too little time or ground."""
        if len(self._velocities) < 2 or not self._headings:
            return None
        v = np.array(self._velocities)
        h = np.array(self._headings)
        if v[-1, 0] - v[0, 0] < MIN_SPAN:
            return None
        # the heading at each body velocity: the latest reading at or before it
        at = np.clip(np.searchsorted(h[:, 0], v[:, 0], side="right") - 1, 0, len(h) - 1)
        yaw = -h[at, 1] if mirrored else h[at, 1]
        s, c = np.sin(yaw), np.cos(yaw)
        east = -v[:, 1] * s + v[:, 2] * c
        north = v[:, 1] * c + v[:, 2] * s
        dt = np.diff(v[:, 0])
        east = np.concatenate([[0.0], np.cumsum(east[:-1] * dt)])
        north = np.concatenate([[0.0], np.cumsum(north[:-1] * dt)])
        if float(np.sum(np.abs(v[:-1, 1]) * dt)) < MIN_TRAVEL:
            return None
        return v[:, 0], east, north

    def _velocity(self) -> tuple[float, float]:
        """The latest body velocity turned by the latest heading (east, north, m/s)."""
        _, forward, starboard = self._velocities[-1]
        yaw = self._headings[-1][1]
        s, c = math.sin(yaw), math.cos(yaw)
        return -forward * s + starboard * c, forward * c + starboard * s


def _rescored(fitted: list[tuple[Fit, float, float, np.ndarray]]
              ) -> list[tuple[Fit, float, float, np.ndarray]]:
    """Each fit's χ² per degree of freedom over the ranges the best fit of them all finds
    within ``TRUNCATE`` σ: outliers (each counted at ``TRUNCATE`` σ) raise every fit's χ²
    alike and narrow the ratios between them, by more than the answer can spare where they
    are many. Left as fitted where the best fit finds more than ``MAX_OUTLIERS`` of them or
    leaves fewer than ``MIN_KEPT``."""
    best = min(fitted, key=lambda f: f[0].chi2)[3]
    inliers = np.abs(best) <= TRUNCATE
    count = int(inliers.sum())
    if count == len(best) or count < max((1.0 - MAX_OUTLIERS) * len(best), MIN_KEPT):
        return fitted
    dof = max(count - len(PRIOR_SIGMA), 1)  # one per parameter fitted
    return [(replace(fit, chi2=float(np.sum(np.minimum(np.abs(r[inliers]), TRUNCATE) ** 2))
                     / dof), turn, stretch, r)
            for fit, turn, stretch, r in fitted]


def _keep(queue: deque, item: tuple) -> None:
    """Append a reading, forgetting those older than ``WINDOW`` before it."""
    queue.append(item)
    while queue[0][0] < item[0] - WINDOW:
        queue.popleft()
