"""Which beacon is off its survey, told from the track (spec 2.2.6): leave-one-out fits.

A beacon ``d`` metres from its surveyed position is wrong by about ``−d cos θ``, an error that
turns with the bearing ``θ`` it is heard from. The filter absorbs most of it (it moves the
position and learns the error's mean as the beacon's offset), so that afterwards the
offsets single out the wrong beacon as often as the right one
(:mod:`mavhelm.nav.beacon_watch`: Plaza1, one beacon 5 m off, sixteen draws, mean 1.94 m).

What the filter cannot absorb is the turning. Over a window of ``WINDOWS`` s the track made
good (the filter's own velocity, integrated) is right up to a shift, a turn and a speed scale;
the ranges heard along it fix those, with a range scale and an offset shared by every beacon.
Fitted with every beacon, a displaced beacon's turning error stays in the residuals; fitted
without it, the others agree. So every ``REVIEW`` s :class:`SurveyCheck` fits each window
once with every beacon and once without each, and singles out the beacon whose absence
explains the misfit: the fit without it is ``RATIO_ALL`` times better (robust χ² per degree of
freedom) than the fit with every beacon, and ``RATIO_NEXT`` times better than leaving out any
other. Ratios of χ², so the ranges' declared σ need not be right (Plaza: declared 1 m, 0.53 m
about the range scale). ``CONFIRM`` of the last ``VOTES`` reviews of a window must name the
same beacon. A short window tells early; a long one where the bearings turn slowly (beacons
far from the track): the two are reviewed in turn, every ``REVIEW`` / 2 s.

It needs ``MIN_BEACONS`` beacons heard in the window, each ``MIN_RANGES`` times: leaving one
of three out leaves two, which with a free shift, turn and scale fit nearly anything; and a
track made good reaching ``MIN_TRACK`` m from the window's first point.

Measured on Plaza1 with one beacon 5 m off its survey, sixteen draws: the displaced beacon
singled out every time, 128-197 s into the run (the robot stands still for its first 80 s,
where nothing turns), NAV 0.52-1.06 m RMS, mean 0.78 (1.94 with the offsets the only
evidence; the 60 s window alone 0.77, the 120 s alone 0.80). The clean recording and seeds
1-3 of every other fault: no window names a beacon (clean, the largest ratios 1.46 and 1.54
in the 60 s window, 1.32 and 1.40 in the 120 s one). The five fits of a review are solved
together: 2-3 ms a review, 0.6 s of a 32-minute replay, in an hour when this machine ran
the EKF at 106 µs a cycle (45 µs when quiet); the five fits one after another took twice
that, the window's rows built at each review a fifth more. Each window's fits start from
its last review's turn, scales and offset: a fifth less again, the Plaza1 figures above the
same to the centimetre. Still a sixth to a fifth of a replay's time.

Some geometries hardly tell: the simulator's box patrol among four beacons 60-200 m off,
one moved 5 m, fits in a 60 s window as well without its neighbour as without it (second
best over best about 1.0); the 120 s window singles it out in three draws of six, at
160-220 s of a 400 s run (NAV 1.13-1.38 m; the other three 2.2-2.7 m, 1.3-2.7 m with the
60 s window alone). With a GPS the owner also lets the filter's offsets, anchored by it,
judge (:class:`mavhelm.nav.fusion.Fusion`).

Written by hand rather than with ``scipy.optimize.least_squares``: six parameters, a few
hundred ranges, five fits every ``REVIEW`` / 2 s of every replay; a few Gauss-Newton steps
from the filter's position and the window's last fits, the five fits stacked, cost a
fraction of the library's per-call overhead.

Pure logic: the owner calls ``move`` once a slice with the filter's position and velocity,
``hear`` with each range, and ``review``, which returns the beacon singled out or None.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Final

import numpy as np

from mavhelm.nav.ekf import Beacon

WINDOWS: Final = (60.0, 120.0)
"""s of ranges fitted at once, each window reviewed in turn: long enough for the bearings to
turn, short enough that the track made good is right to a shift, a turn and a scale."""
REVIEW: Final = 10.0
"""s between two reviews of one window (the windows' reviews interleaved)."""
RATIO_ALL: Final = 2.0
"""How many times better the fit without a beacon must be than the fit with every beacon
(Plaza1 clean: at most 1.46 in the 60 s window's reviews, 1.32 in the 120 s one's)."""
RATIO_NEXT: Final = 1.5
"""How many times better it must be than the fit without any other beacon (Plaza1 clean: at
most 1.54 in the 60 s window's reviews, 1.40 in the 120 s one's; never in a review where
the first ratio passed)."""
CONFIRM: Final = 2
"""Reviews, of the last ``VOTES``, that must name the same beacon before it is singled out:
one window's misfit can be a bad stretch of ranges; in the next the beacon's bearing may not
have turned enough to tell it (Plaza1, seed 10: named at 147, 157 and 190 s, not between)."""
VOTES: Final = 5
RATIO_KEEP: Final = 1.3
"""A beacon singled out keeps the blame while the fit without it is this many times better
than the fit with every beacon: another beacon that fits worse in a window cannot take it.
Plaza1 with half its ranges and beacon 0 5 m off (seed 1): for 750 s from 1101 s the blame
sat on beacon 5, whose ranges misfit a little on the clean recording too (the fit without it
the best of every review there), while the fit without beacon 0 was still 1.4-2.7 times
better than with it (1.68 m RMS); without beacon 0 on the clean recording, 0.8-1.0 times."""
RATIO_SWITCH: Final = 2.5
"""... unless the fit without the other is this many times better than the fit without the
beacon blamed (``CONFIRM`` times, as any blame): the first blame may come while the bearings
have hardly turned. Plaza1, beacon 6 5 m off (seed 2): beacon 5 blamed at 123 s, 43 s after
the robot first moves; from 150 s the fits without beacon 6 were 1.6-5 times better than
without beacon 5, but leaving beacon 5 out still helped 1.2-1.9 times (leaving out any good
beacon of four eases a displaced one's misfit): the blame stayed, 3.43 m RMS. With half the
ranges and beacon 0 blamed rightly, a stretch where another fits better: at most 2.0."""
MISFIT_CONFIRM: Final = 4
"""Reviews, of the last ``VOTES``, that must find the ranges misfitting the track (the fit
with every beacon ``RATIO_ALL`` times worse than the best without one) with no one beacon to
blame before the operator is told. Plaza1 replayed from a start under way, one beacon 5 m
off: most reviews find the misfit, but leaving out beacon 0, 1 or 5 fits as well (three
beacons left, a free shift, range scale and offset absorb the displaced one); clean, and
with every other fault, no review finds it."""
MISFIT_EVERY: Final = 300.0
"""s: the operator is told again at most this often while the misfit stays unexplained."""
MIN_BEACONS: Final = 4
MIN_RANGES: Final = 5
MIN_TRACK: Final = 20.0
"""m: a window whose track made good stays within this of its first point is not fitted: its
review names no beacon. Along so short a track the bearings hardly turn, and leaving out any
one of four beacons leaves three ranges to a near point for its shift and the shared range
scale and offset: each fit is near perfect and which is best is chance. Plaza1 with half its
ranges and the defaults' mission, clean: beacon 1 singled out at 59-69 s from windows the
robot had moved 3-9 m in (standing still, then setting off; 0.48 m RMS, 0.42 m without the
blame). Started 300 s in with beacon 0 5 m off (seeds 1 and 6): beacon 5 singled out at
52 s from windows of 11-24 m, the robot all but still for 40 s, and kept the blame
(2.47 and 2.41 m, NEES 39 and 36; now 1.77 and 1.57 m, NEES 22 and 15). 30 m gave the
same within 0.12 m; at 45 m the right blame came too late on starts under way (from 300 s,
seed 4: 1.15 → 2.47 m)."""
HUBER: Final = 2.0
"""Residuals beyond this many of their σ pull the fit linearly, not as their square."""
TRUNCATE: Final = 3.0
"""A residual beyond this many of its σ counts in the χ² as if it were this many: one bad
range the filter let in (a still vehicle's boot, 13 m short at σ 0.3 m) is not a misfit."""
ITERATIONS: Final = 10
NO_SHAPE: Final = np.zeros(4)
"""Turn, speed scale, range scale and offset a window's first fit starts from."""
CONVERGED: Final = 1e-2
"""Gauss-Newton stops once no parameter moves more than this (m, rad, scale) in a step
(Plaza1: the ratios the same to four figures as at 1e-3, a sixth less work)."""
PRIOR_SIGMA: Final = (math.inf, math.inf, 1.0, 0.05, 0.1, 5.0)
"""1-σ of each parameter's prior (shift x, y in m, turn in rad, speed scale, range scale,
shared offset in m): the turn and scales are small, and an offset shared by every beacon is
hard to tell from the range scale in a short window."""


@dataclass(frozen=True)
class Fit:
    """One fit of a window: robust χ² per degree of freedom, and where it puts the vehicle
    at ``t``, the review's time (m), with the 1-σ of that (m, the larger axis)."""

    chi2: float
    t: float
    x: float
    y: float
    sigma: float


@dataclass(frozen=True)
class Heard:
    """A range heard, kept while a window may fit it."""

    t: float
    beacon: str
    track: tuple[float, float]
    """The track made good (the filter's velocity integrated) at ``t``."""
    position: tuple[float, float]
    """The filter's position at ``t``: where a fit starts."""
    row: tuple[float, ...]
    """What a fit reads: the range less the beacon's offset prior, its σ, the beacon's x, y
    and its height above the transducer squared, the track made good."""


class SurveyCheck:
    """Every ``REVIEW`` s, ``review(t)`` names the beacon the window's leave-one-out fits
    single out ``CONFIRM`` times in ``VOTES`` reviews, else None."""

    def __init__(self, beacons: dict[str, Beacon]) -> None:
        self.beacons = beacons
        self.heard: deque[Heard] = deque()
        self.fits: dict[str | None, Fit] = {}
        """The last review's fits: None with every beacon, else without the beacon named.
        The fit without the beacon singled out is where the other beacons put the vehicle."""
        self._track = (0.0, 0.0)
        self._position = (0.0, 0.0)
        self._t: float | None = None
        self._next_review = -math.inf
        self._turn = 0
        """The window reviewed next (its index in ``WINDOWS``)."""
        self._named = [deque[str | None](maxlen=VOTES) for _ in WINDOWS]
        self.singled_out: str | None = None
        """The beacon last singled out."""
        self._misfits = deque[tuple[str, ...] | None](maxlen=VOTES)
        self._misfit_told = -math.inf
        self._shapes: list[dict[str | None, np.ndarray]] = [{} for _ in WINDOWS]
        """Each window's last fits' turn, scales and offset: where its next fits start (the
        window moves on by ``REVIEW`` s, they little)."""

    @property
    def blind(self) -> bool:
        """Too few beacons to tell one off its survey."""
        return len(self.beacons) < MIN_BEACONS

    def clear(self) -> None:
        """Forget the window: the track made good is broken (the filter restarted)."""
        self.heard.clear()
        for named, shapes in zip(self._named, self._shapes, strict=True):
            named.clear()
            shapes.clear()
        self.singled_out = None
        self._misfits.clear()
        self._t = None

    def move(self, t: float, x: float, y: float, x_vel: float, y_vel: float) -> None:
        if self._t is not None and t > self._t:
            dt = t - self._t
            self._track = (self._track[0] + x_vel * dt, self._track[1] + y_vel * dt)
        self._t = t
        self._position = (x, y)

    def hear(self, t: float, beacon: str, z: float, sigma: float, height: float = 0.0) -> None:
        """A range ``z`` (m, its σ) to ``beacon``, heard from a transducer ``height`` m up
        (the filter's Z and the lever's: a vehicle at depth hears seabed beacons nearer)."""
        if beacon in self.beacons and math.isfinite(z) and self._t is not None:
            b = self.beacons[beacon]
            self.heard.append(Heard(t, beacon, self._track, self._position,
                                    (z - b.offset, sigma, b.x, b.y, (b.z - height)**2,
                                     *self._track)))

    def review(self, t: float) -> str | None:
        while self.heard and self.heard[0].t < t - max(WINDOWS):
            self.heard.popleft()
        if t < self._next_review:
            return None
        self._next_review = t + REVIEW / len(WINDOWS)
        turn, self._turn = self._turn, (self._turn + 1) % len(WINDOWS)
        named = self._single_out(t - WINDOWS[turn], self._shapes[turn])
        held = (self.fits.get(self.singled_out)
                if named is not None and self.singled_out not in (None, named) else None)
        if (held is not None and self.fits[None].chi2 > RATIO_KEEP * held.chi2
                and held.chi2 < RATIO_SWITCH * self.fits[named].chi2):
            named = None  # the beacon blamed still misfits: no other takes the blame
        votes = self._named[turn]
        votes.append(named)
        self._misfits.append(_suspects(self.fits) if named is None else None)
        if named is not None and votes.count(named) >= CONFIRM:
            self.singled_out = named
            return named
        return None

    def misfit_warning(self, t: float) -> str | None:
        """What to tell the operator where the ranges keep misfitting the track and no one
        beacon explains it (``MISFIT_CONFIRM`` of the last ``VOTES`` reviews), at most every
        ``MISFIT_EVERY`` s; None otherwise. Nothing is down-weighted for it."""
        found = [s for s in self._misfits if s is not None]
        if (len(found) < MISFIT_CONFIRM or self.singled_out is not None
                or t - self._misfit_told < MISFIT_EVERY):
            return None
        self._misfit_told = t
        suspects = sorted(set.union(*(set(s) for s in found)))
        return (f"the ranges misfit the track made good in {len(found)} of the last "
                f"{len(self._misfits)} reviews, and leaving out any one of beacons "
                f"{', '.join(suspects)} fits as well: a beacon may be off its surveyed "
                f"position (not told which); check the survey")

    def _single_out(self, since: float, shapes: dict[str | None, np.ndarray]) -> str | None:
        heard = [h for h in self.heard if h.t >= since]
        counts: dict[str, int] = {}
        for h in heard:
            counts[h.beacon] = counts.get(h.beacon, 0) + 1
        names = [name for name, n in counts.items() if n >= MIN_RANGES]
        self.fits = {}
        if len(names) < MIN_BEACONS:
            return None
        window = [h for h in heard if h.beacon in names]
        first = window[0]
        columns = np.array([h.row for h in window])
        columns[:, 5:] -= first.track
        if float(np.max(np.hypot(columns[:, 5], columns[:, 6]))) < MIN_TRACK:
            return None  # the bearings hardly turned: nothing to tell
        now = (self._track[0] - first.track[0], self._track[1] - first.track[1])
        heard_from = np.array([h.beacon for h in window])
        fits = self.fits
        t = self._t if self._t is not None else first.t
        try:
            kept = np.array([np.ones(len(window), dtype=bool)]
                            + [heard_from != name for name in names])
            keys = [None, *names]
            found, solved, _ = fit_tracks(columns, kept, first.position, now, t,
                                  np.array([shapes.get(key, NO_SHAPE) for key in keys]))
            fits.update(zip(keys, found, strict=True))
            shapes.clear()
            shapes.update(zip(keys, solved[:, 2:], strict=True))
        except np.linalg.LinAlgError:  # beacons on top of each other: nothing to tell
            fits.clear()
            return None
        if not all(math.isfinite(v) for f in fits.values() for v in (f.chi2, f.x, f.y, f.sigma)):
            fits.clear()
            return None
        suspects = _suspects(fits)
        return suspects[0] if suspects is not None and len(suspects) == 1 else None


def _suspects(fits: dict[str | None, Fit]) -> tuple[str, ...] | None:
    """Where the fit with every beacon is ``RATIO_ALL`` times worse than the best without
    one, the beacons whose absence fits within ``RATIO_NEXT`` of that best, best first (one
    alone is singled out); None where the ranges fit, or nothing was fitted."""
    without = {name: fit.chi2 for name, fit in fits.items() if name is not None}
    if not without:
        return None
    best = min(without.values())
    if not fits[None].chi2 > RATIO_ALL * best:
        return None
    return tuple(sorted((name for name, chi2 in without.items() if chi2 <= RATIO_NEXT * best),
                        key=without.__getitem__))


def fit_tracks(columns: np.ndarray, kept: np.ndarray, start: tuple[float, float],
          now: tuple[float, float], t: float, shape: np.ndarray
          ) -> tuple[list[Fit], np.ndarray, np.ndarray]:
    """The ranges (rows of ``columns``: range less the beacon's offset prior, its σ, the
    beacon's x, y and height above the transducer squared, the track made good since the
    window's first range)
    against the best shift, turn and speed scale of the track and range scale and offset
    shared by every beacon, from the filter's position ``start`` at the first range and the
    turn, scales and offset of ``shape``: one fit for each row of ``kept`` (which ranges it
    keeps, and its row of ``shape``), all solved together; where each puts the vehicle at
    the track's point ``now``, time ``t``, the parameters found, and each fit's residuals
    in σ (fit, range)."""
    z, sd, bx, by, bz2, ex, ey = columns.T
    kept = kept.astype(float)
    p = np.zeros((len(kept), 6))
    p[:, 0], p[:, 1] = start
    p[:, 2:] = shape
    prior = np.array([0.0 if math.isinf(v) else 1.0 / v**2 for v in PRIOR_SIGMA])
    offset_column = np.broadcast_to(1.0 / sd, kept.shape)  # the offset's: the same each step

    def residuals(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Normalised residuals (fit, range) and their Jacobian (fit, range, parameter)."""
        c, s = np.cos(p[:, 2:3]), np.sin(p[:, 2:3])
        rx, ry = c * ex - s * ey, s * ex + c * ey
        stretch, scale = 1 + p[:, 3:4], 1 + p[:, 4:5]
        dx = p[:, 0:1] + stretch * rx - bx
        dy = p[:, 1:2] + stretch * ry - by
        distance = np.sqrt(dx**2 + dy**2 + bz2) + 1e-9
        ux, uy = scale * dx / distance / sd, scale * dy / distance / sd
        jacobian = np.stack([ux, uy, stretch * (uy * rx - ux * ry), ux * rx + uy * ry,
                             distance / sd, offset_column], axis=2)
        return (z - scale * distance - p[:, 5:6]) / sd, jacobian

    normal = np.zeros((len(kept), 6, 6))
    for _ in range(ITERATIONS):
        residual, jacobian = residuals(p)
        a = np.abs(residual)
        weights = kept * np.where(a < HUBER, 1.0, HUBER / np.maximum(a, 1e-12))
        weighted = jacobian * weights[:, :, None]
        normal = weighted.transpose(0, 2, 1) @ jacobian + np.diag(prior)
        gradient = np.einsum("fri,fr->fi", weighted, residual) - prior * p  # x, y: no prior
        step = np.linalg.solve(normal, gradient[:, :, None])[:, :, 0]
        p += step
        if float(np.max(np.abs(step))) < CONVERGED:
            break
    residual, _ = residuals(p)
    dof = np.maximum(kept.sum(axis=1) - p.shape[1], 1)
    chi2 = (kept * np.minimum(np.abs(residual), TRUNCATE) ** 2).sum(axis=1) / dof
    c, s = np.cos(p[:, 2]), np.sin(p[:, 2])
    rx, ry = c * now[0] - s * now[1], s * now[0] + c * now[1]
    stretch = 1 + p[:, 3]
    moved = np.zeros((len(p), 2, 6))
    moved[:, 0, 0] = moved[:, 1, 1] = 1.0
    moved[:, 0, 2], moved[:, 0, 3] = -stretch * ry, rx
    moved[:, 1, 2], moved[:, 1, 3] = stretch * rx, ry
    covariance = (moved @ np.linalg.inv(normal) @ moved.transpose(0, 2, 1)
                  * np.maximum(chi2, 1.0)[:, None, None])
    axis = np.sqrt(np.maximum(np.linalg.eigvalsh(covariance)[:, -1], 0.0))
    return [Fit(float(chi2[k]), t, float(p[k, 0] + stretch[k] * rx[k]),
                float(p[k, 1] + stretch[k] * ry[k]), float(axis[k]))
            for k in range(len(p))], p, residual
