"""Which beacon is off its survey, told from the track (spec 2.2.6): leave-one-out fits.

A beacon ``d`` metres from its surveyed position is wrong by about ``−d cos θ``, an error that
turns with the bearing ``θ`` it is heard from. The filter absorbs most of it (it moves the
position and learns the error's mean as the beacon's offset), so that afterwards the
offsets single out the wrong beacon as often as the right one
(:mod:`mavhelm.nav.beacon_watch`: Plaza1, one beacon 5 m off, sixteen draws, mean 1.94 m).

What the filter cannot absorb is the turning. Over a window of ``WINDOW`` s the track made
good (the filter's own velocity, integrated) is right up to a shift, a turn and a speed scale;
the ranges heard along it fix those, with a range scale and an offset shared by every beacon.
Fitted with every beacon, a displaced beacon's turning error stays in the residuals; fitted
without it, the others agree. So every ``REVIEW`` s :class:`SurveyCheck` fits the window
once with every beacon and once without each, and singles out the beacon whose absence
explains the misfit: the fit without it is ``RATIO_ALL`` times better (robust χ² per degree of
freedom) than the fit with every beacon, and ``RATIO_NEXT`` times better than leaving out any
other. Ratios of χ², so the ranges' declared σ need not be right (Plaza: declared 1 m, 0.53 m
about the range scale). ``CONFIRM`` of the last ``VOTES`` reviews must name the same beacon.

It needs ``MIN_BEACONS`` beacons heard in the window, each ``MIN_RANGES`` times: leaving one
of three out leaves two, which with a free shift, turn and scale fit nearly anything.

Measured on Plaza1 with one beacon 5 m off its survey, sixteen draws: the displaced beacon
singled out every time, 130-200 s into the run (the robot stands still for its first 80 s,
where nothing turns), NAV 0.53-1.06 m RMS, mean 0.77 (1.94 with the offsets the only
evidence). The clean recording and seeds 1-3 of every other fault: no window names a
beacon. About 3 ms a review (five fits), 0.5 s of a 32-minute replay.

Some geometries cannot tell: the simulator's box patrol among four beacons, one moved 5 m,
fits as well without its neighbour as without it (second best over best about 1.0), so
nothing is singled out; the owner then lets a GPS-anchored filter's offsets judge
(:class:`mavhelm.nav.fusion.Fusion`), and without a GPS the run stays 1.3-2.7 m out.

Written by hand rather than with ``scipy.optimize.least_squares``: six parameters, a few
hundred ranges, five fits every ``REVIEW`` s of every replay; a few Gauss-Newton steps from
the filter's position cost a fraction of the library's per-call overhead.

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

WINDOW: Final = 60.0
"""s of ranges fitted at once: long enough for the bearings to turn, short enough that the
track made good is right to a shift, a turn and a scale (Plaza1: 60 and 120 s both tell)."""
REVIEW: Final = 10.0
"""s between fits."""
RATIO_ALL: Final = 2.0
"""How many times better the fit without a beacon must be than the fit with every beacon
(Plaza1 clean: at most 1.44 in its 168 reviews)."""
RATIO_NEXT: Final = 1.5
"""How many times better it must be than the fit without any other beacon (Plaza1 clean: at
most 1.53, 1.48 in 99 % of its reviews)."""
CONFIRM: Final = 2
"""Reviews, of the last ``VOTES``, that must name the same beacon before it is singled out:
one window's misfit can be a bad stretch of ranges; in the next the beacon's bearing may not
have turned enough to tell it (Plaza1, seed 10: named at 147, 157 and 190 s, not between)."""
VOTES: Final = 5
MIN_BEACONS: Final = 4
MIN_RANGES: Final = 5
HUBER: Final = 2.0
"""Residuals beyond this many of their σ pull the fit linearly, not as their square."""
TRUNCATE: Final = 3.0
"""A residual beyond this many of its σ counts in the χ² as if it were this many: one bad
range the filter let in (a still vehicle's boot, 13 m short at σ 0.3 m) is not a misfit."""
ITERATIONS: Final = 10
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
    t: float
    beacon: str
    z: float
    sigma: float
    track: tuple[float, float]
    """The track made good (the filter's velocity integrated) at ``t``."""
    position: tuple[float, float]
    """The filter's position at ``t``: where a fit starts."""


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
        self._named: deque[str | None] = deque(maxlen=VOTES)

    @property
    def blind(self) -> bool:
        """Too few beacons to tell one off its survey."""
        return len(self.beacons) < MIN_BEACONS

    def clear(self) -> None:
        """Forget the window: the track made good is broken (the filter restarted)."""
        self.heard.clear()
        self._named.clear()
        self._t = None

    def move(self, t: float, x: float, y: float, x_vel: float, y_vel: float) -> None:
        if self._t is not None and t > self._t:
            dt = t - self._t
            self._track = (self._track[0] + x_vel * dt, self._track[1] + y_vel * dt)
        self._t = t
        self._position = (x, y)

    def hear(self, t: float, beacon: str, z: float, sigma: float) -> None:
        if beacon in self.beacons and math.isfinite(z) and self._t is not None:
            self.heard.append(Heard(t, beacon, z, sigma, self._track, self._position))

    def review(self, t: float) -> str | None:
        while self.heard and self.heard[0].t < t - WINDOW:
            self.heard.popleft()
        if t < self._next_review:
            return None
        self._next_review = t + REVIEW
        named = self._single_out()
        self._named.append(named)
        if named is not None and self._named.count(named) >= CONFIRM:
            return named
        return None

    def _single_out(self) -> str | None:
        counts: dict[str, int] = {}
        for h in self.heard:
            counts[h.beacon] = counts.get(h.beacon, 0) + 1
        names = [name for name, n in counts.items() if n >= MIN_RANGES]
        self.fits = {}
        if len(names) < MIN_BEACONS:
            return None
        window = [h for h in self.heard if h.beacon in names]
        beacons = [self.beacons[h.beacon] for h in window]
        first = window[0]
        columns = np.array([[h.z - b.offset, h.sigma, b.x, b.y, b.z**2,
                             h.track[0] - first.track[0], h.track[1] - first.track[1]]
                            for h, b in zip(window, beacons, strict=True)])
        now = (self._track[0] - first.track[0], self._track[1] - first.track[1])
        heard_from = np.array([h.beacon for h in window])
        fits = self.fits
        t = self._t if self._t is not None else first.t
        try:
            fits[None] = _fit(columns, first.position, now, t)
            for name in names:
                fits[name] = _fit(columns[heard_from != name], first.position, now, t)
        except np.linalg.LinAlgError:  # beacons on top of each other: nothing to tell
            fits.clear()
            return None
        if not all(math.isfinite(v) for f in fits.values() for v in (f.chi2, f.x, f.y, f.sigma)):
            fits.clear()
            return None
        ranked = sorted(names, key=lambda name: fits[name].chi2)
        best, second = fits[ranked[0]].chi2, fits[ranked[1]].chi2
        if fits[None].chi2 > RATIO_ALL * best and second > RATIO_NEXT * best:
            return ranked[0]
        return None


def _fit(columns: np.ndarray, start: tuple[float, float], now: tuple[float, float],
         t: float) -> Fit:
    """The ranges (rows of ``columns``: range less the beacon's offset prior, its σ, the
    beacon's x, y and height squared, the track made good since the window's first range)
    against the best shift, turn and speed scale of the track and range scale and offset
    shared by every beacon, from the filter's position ``start`` at the first range; where
    that puts the vehicle at the track's point ``now``, time ``t``."""
    z, sd, bx, by, bz2, ex, ey = columns.T
    p = np.array([start[0], start[1], 0.0, 0.0, 0.0, 0.0])
    prior = np.array([0.0 if math.isinf(v) else 1.0 / v**2 for v in PRIOR_SIGMA])

    def residuals(p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Normalised residuals and their Jacobian in ``p``."""
        c, s = math.cos(p[2]), math.sin(p[2])
        rx, ry = c * ex - s * ey, s * ex + c * ey
        dx = p[0] + (1 + p[3]) * rx - bx
        dy = p[1] + (1 + p[3]) * ry - by
        distance = np.sqrt(dx**2 + dy**2 + bz2) + 1e-9
        ux, uy = (1 + p[4]) * dx / distance / sd, (1 + p[4]) * dy / distance / sd
        jacobian = np.column_stack([ux, uy, (1 + p[3]) * (uy * rx - ux * ry),
                                    ux * rx + uy * ry, distance / sd, 1.0 / sd])
        return (z - (1 + p[4]) * distance - p[5]) / sd, jacobian

    for _ in range(ITERATIONS):
        residual, jacobian = residuals(p)
        a = np.abs(residual)
        weights = np.where(a < HUBER, 1.0, HUBER / np.maximum(a, 1e-12))
        normal = jacobian.T @ (weights[:, None] * jacobian) + np.diag(prior)
        gradient = jacobian.T @ (weights * residual) - prior * np.r_[0.0, 0.0, p[2:]]
        step = np.linalg.solve(normal, gradient)
        p += step
        if float(np.max(np.abs(step))) < 1e-3:
            break
    residual, jacobian = residuals(p)
    a = np.abs(residual)
    dof = max(len(z) - len(p), 1)
    chi2 = float(np.sum(np.minimum(a, TRUNCATE) ** 2)) / dof
    c, s = math.cos(p[2]), math.sin(p[2])
    rx, ry = c * now[0] - s * now[1], s * now[0] + c * now[1]
    moved = np.array([[1.0, 0.0, -(1 + p[3]) * ry, rx, 0.0, 0.0],
                      [0.0, 1.0, (1 + p[3]) * rx, ry, 0.0, 0.0]])
    covariance = moved @ np.linalg.inv(normal) @ moved.T * max(chi2, 1.0)
    axis = math.sqrt(max(float(np.linalg.eigvalsh(covariance)[-1]), 0.0))
    return Fit(chi2, t, float(p[0] + (1 + p[3]) * rx), float(p[1] + (1 + p[3]) * ry), axis)
