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
seconds agreeing within ``MAX_SPREAD`` make an estimate: coarse alignment, as an inertial
system aligns its heading from GPS. Taken against the bias held at each reading, a bias the
filter follows as it drifts (an integrated heading, 0.6°/s) leaves no correction, where the
sensor's raw offset averaged over the window would lag it. A run while any body-velocity
reading says the vehicle goes astern, or crabs beyond ``MAX_TURN``, is not used (its course
is not its heading).

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
SAMPLES: Final = 3
"""Runs (one per new fix) that must agree before the offset is believed."""
MAX_SPREAD: Final = math.radians(15.0)
"""rad: their circular spread at most."""


def wrap(a: float) -> float:
    return math.remainder(a, 2.0 * math.pi)


def course_yaw(dx: float, dy: float) -> float:
    """The course of a run (dx east, dy north) as a yaw (rad, yaw = −heading)."""
    return -math.atan2(dx, dy)


def circular_mean(angles: list[float]) -> tuple[float, float]:
    """(mean, circular standard deviation) of angles in radians."""
    s = sum(math.sin(a) for a in angles) / len(angles)
    c = sum(math.cos(a) for a in angles) / len(angles)
    r = min(math.hypot(s, c), 1.0)
    spread = math.sqrt(-2.0 * math.log(r)) if r > 0.0 else math.inf
    return math.atan2(s, c), spread


@dataclass(frozen=True)
class Alignment:
    """The heading bias the filter held is short of the sensor's offset from the course made
    good by ``correction`` (rad, yaw), to ``spread``, over ``runs`` runs; ``velocity``
    (east, north, m/s) is the latest run's."""

    correction: float
    spread: float
    runs: int
    velocity: tuple[float, float]


class MotionAlignment:
    """``add_fix``, ``add_heading`` and ``add_forward`` as data come (in time order);
    ``estimate(t)`` when asked; ``clear()`` once an estimate has been used."""

    def __init__(self) -> None:
        self._fixes: deque[tuple[float, float, float]] = deque()
        self._headings: deque[tuple[float, float]] = deque()
        self._astern: deque[float] = deque()
        self._runs: deque[tuple[float, float]] = deque()
        self._velocity = (0.0, 0.0)

    def clear(self) -> None:
        self._fixes.clear()
        self._headings.clear()
        self._astern.clear()
        self._runs.clear()

    def add_heading(self, t: float, yaw: float, bias: float = 0.0) -> None:
        """A reading of the orientation sensor (rad, yaw = −heading) and the heading bias
        the filter holds for it then."""
        self._headings.append((t, yaw - bias))

    def add_body_velocity(self, t: float, forward: float, starboard: float | None) -> None:
        """A body-velocity reading (m/s): going astern, or crabbing beyond ``MAX_TURN``, the
        course is not the heading."""
        if forward < 0.0 or (starboard is not None
                             and abs(math.atan2(starboard, forward)) > MAX_TURN):
            self._astern.append(t)

    def add_fix(self, t: float, x: float, y: float) -> None:
        """A position fix; a run ending at it is measured when one long enough exists."""
        fixes = self._fixes
        for queue in (fixes, self._headings, self._astern, self._runs):
            while queue and _time(queue[0]) < t - WINDOW:
                queue.popleft()
        start = next((f for f in reversed(fixes) if math.hypot(x - f[1], y - f[2]) >= RUN), None)
        fixes.append((t, x, y))
        if start is None or start[0] >= t:
            return
        t0, x0, y0 = start
        if any(t0 <= ta <= t for ta in self._astern):
            return
        readings = [yaw for th, yaw in self._headings if t0 <= th <= t]
        if len(readings) < 2:
            return
        mean, _ = circular_mean(readings)
        if max(abs(wrap(a - mean)) for a in readings) > MAX_TURN:
            return
        dx, dy = x - x0, y - y0
        self._runs.append((t, wrap(mean - course_yaw(dx, dy))))
        self._velocity = (dx / (t - t0), dy / (t - t0))

    def estimate(self) -> Alignment | None:
        """The correction, once ``SAMPLES`` runs agree within ``MAX_SPREAD``; else None."""
        if len(self._runs) < SAMPLES:
            return None
        correction, spread = circular_mean([o for _, o in self._runs])
        if spread > MAX_SPREAD:
            return None
        return Alignment(correction, spread, len(self._runs), self._velocity)


def _time(item: tuple[float, ...] | float) -> float:
    return item if isinstance(item, float) else item[0]
