"""Watching the orientation sensors against the motion (spec 2.2.10): heading faults.

A heading sensor can be wrong in three ways the χ² gate alone does not see: its bias wanders
(an odometry-integrated heading, a compass by a moving load), it jumps (a compass near a
motor), it sticks (a frozen AHRS). The EKF's heading-bias state follows a slow bias; the rest
shows in the data:

- **The position data disagree** (the mean χ² distance of the last ``DOUBT_WINDOW`` beacon
  ranges or fixes beyond ``DOUBT_NIS``, or of the last ``DOUBT_LONG_WINDOW`` beyond
  ``DOUBT_LONG_NIS``): a wrong heading dead-reckons the vehicle away from where the ranges
  put it. They are heard only once the vehicle has moved for ``STILL_TIME``: before, the
  motion defines no course to hold a heading to, and a filter starting from rest trails the
  vehicle along its track whatever the heading. The heading is then doubted: its
  uncertainty (the bias state's, when estimated) is raised to ``DOUBT_SIGMA``, so the
  position and body-velocity data decide it again, and the bias is let wander
  (``WANDER_NOISE``) for ``BIAS_WANDER_TIME``. A filter without a bias state is given one
  (``EKF.with_yaw_bias``) where the heading moves the position (a sideslip constraint, a
  body speed): down-weighted readings of a wandering sensor, however far, still hold a
  share of the heading, and the heading's error grows with the bias (simulator, compass
  wandering to 180°: a few per cent, 6–12° at the end, 0.64 m RMS against 0.35 m with the
  state). Where nothing tells a bias from a heading, the heading readings' σ is scaled up
  instead (``HEADING_DOUBT_SCALE`` a doubt) for ``WANDER_TIME``.
- **The heading contradicts the motion** (its readings rejected for ``CONTRADICTION_TIME``):
  it is down-weighted to nothing (rejected) and reported, and reported again when it agrees.
- **Unobservable**: the bias is seen only through motion (body velocity against position);
  a vehicle still for ``STILL_TIME`` cannot tell a bias from a heading, and the watch says so
  rather than let the filter trust it.

Pure logic: :class:`HeadingWatch` returns :class:`~mavhelm.nav.filter_safety.Decision` lines
for the owner to publish.
"""

from __future__ import annotations

import itertools
import math
from collections import deque
from typing import Final

from mavhelm.nav.filter_safety import HEADING, Decision

DOUBT_WINDOW: Final = 20
"""Position readings (ranges, fixes) the doubt looks back over."""
DOUBT_NIS: Final = 2.0
"""Their mean χ² distance per degree of freedom that makes the heading suspect: 1 when they
agree with the estimate as their noise says (20 such in a row average over 2 one time in
200), and a wrong heading grows it long before the gate refuses them. Only accepted readings
count: a rejected one is an outlier (a GPS jump), the gate's business, not the heading's."""
DOUBT_LONG_WINDOW: Final = 60
"""... and a longer look back, for a heading that goes wrong slowly (a bias wandering by a
degree in ten seconds): the mean over this many readings ..."""
DOUBT_LONG_NIS: Final = 1.5
"""... beyond this. Measured on the simulator's box patrol (ranges and GPS, 11 readings a
second): clean, 0.98 at most over 400 s (GPS glitches 1.43); the compass wandering (fault
seed 1), beyond 1.5 at a 6° error (104 s), 30 s before the short window saw it at 11°. Not
a cure: a bias that sits at 4° for a minute (seeds 3, 4) leaves the mean NIS where a clean
run has it while the position is 0.6-1 m off; both windows see it only at 9-14° (79 s)."""
DOUBT_SIGMA: Final = math.radians(30.0)
"""rad: the heading 1-σ a doubt raises it to (enough to take a wandering bias back)."""
WANDER_NOISE: Final = 2e-2
"""rad/√s: the bias random walk after a doubt (1.1° in a second, 10° in a minute and a half):
a bias that wandered once may wander on. Measured on Plaza1 with the bias wandering to 180°
(a random walk of its rate): 17.3 m RMS before the watch, 1.96 m with doubts and the steady
1e-3 alone, 0.84 m with this; the recording without the fault stays at 0.47 m. 0.1 took a
heading drifting 180° within five minutes on a mission without the drift-rate state from 15.1
to 2.5 m, but a compass's bias added under way wanders so for half an hour, and a 20 s GPS
gap across a corner then went 3.7 → 6.5 m: the drift rate (``EKF_YAW_DRIFT``) is what an
integrated heading needs (0.55 m there, with no doubt at all)."""
WANDER_TIME: Final = 300.0
"""s: how long after the last doubt a heading without a bias state is down-weighted."""
BIAS_WANDER_TIME: Final = 1800.0
"""s: how long after the last doubt the bias is let wander so. A bias that wandered once is
not trusted to be steady again for half an hour: measured on Plaza1 with the bias wandering
to 180° (seeds 1, 2, 3), 300 s scores 0.84, 0.86, 0.93 m with NEES 3.9–4.2 (over-confident
between doubts), 1800 s 0.68, 0.68, 0.75 m with NEES 1.4–2.1; runs without a doubt are not
touched."""
ADDED_WANDER_TIME: Final = 300.0
"""s: how long a bias state added under way (the mission declared none) is let wander so: a
sensor nobody described may be off by anything, but half an hour of that walk drowns the
drift rate the state carries (``EKF_YAW_DRIFT``). Measured on Plaza1 with the heading
drifting 180° within five minutes, the mission declaring no bias (a start given): 10.09 m
RMS with the bias a random walk alone, 0.91 m with its drift rate and 1800 s of wander (the
rate learned at 30°/min of the true 36, 7.8 m out across a stretch of few ranges), 0.42 m
with 300 s (0.42 with none; the wandering heading 0.35, 0.34); with no start either,
10.18 → 0.43 m; the simulator's compass patrol with
its fault library the same to 0.01 m at 0, 300 and 1800 s, its NEES higher at 0."""
HEADING_DOUBT_SCALE: Final = 3.0
"""Without a bias state (and none observable to add), each doubt scales the heading
readings' σ by this (for ``WANDER_TIME``): the motion then decides the heading, as a bias
state would let it."""
HEADING_MAX_SCALE: Final = 100.0
"""... up to this (a 0.5° compass counted as 50°: still a tie-break, never silenced)."""
DOUBT_REPORT_GAP: Final = 30.0
"""s: doubts closer than this are one episode, reported once."""
CONTRADICTION_TIME: Final = 3.0
"""s: a heading sensor rejected this long contradicts the motion."""
STILL_SPEED: Final = 0.1
"""m/s: slower than this the vehicle is still."""
STILL_TIME: Final = 5.0
"""s: still (or moving) this long before the bias's observability is said to change."""
MOVING_NOTE: Final = "the vehicle moves:"
STILL_NOTE: Final = "the vehicle is still:"
"""How :meth:`HeadingWatch.motion`'s notes begin: a vehicle's stops and starts, which a
summary may leave out."""


class HeadingWatch:
    """Per time slice, ``position(t, nis)`` for each range or fix and ``heading(t,
    sensor, accepted)`` for each heading reading, ``motion(t, speed)`` once; each returns a
    decision to report, or None. ``doubt`` is True after a ``position`` call that asks the
    owner to raise the heading's uncertainty."""

    def __init__(self, estimates_bias: bool) -> None:
        self.estimates_bias = estimates_bias
        self._recent: deque[float] = deque(maxlen=DOUBT_LONG_WINDOW)
        self._last_doubt = -math.inf
        self.doubts = 0
        self._rejected_since: dict[str, float] = {}
        self._contradicting: set[str] = set()
        self._moving: bool | None = None
        self._since: float | None = None

    def position(self, t: float, nis: float) -> Decision | None:
        """A range or fix whose χ² distance per degree of freedom was ``nis``; not counted
        until the vehicle has moved for ``STILL_TIME`` (see :meth:`course_defined`)."""
        if not self.course_defined(t):
            self._recent.clear()
            return None
        recent = self._recent
        recent.append(min(nis, 100.0))  # one wild outlier is not a trend
        short = len(recent) >= DOUBT_WINDOW and (
            sum(itertools.islice(reversed(recent), DOUBT_WINDOW)) >= DOUBT_NIS * DOUBT_WINDOW)
        long = (len(recent) == DOUBT_LONG_WINDOW
                and sum(recent) >= DOUBT_LONG_NIS * DOUBT_LONG_WINDOW)
        if not (short or long):
            return None
        self._recent.clear()
        self.doubts += 1
        first = t - self._last_doubt > DOUBT_REPORT_GAP
        self._last_doubt = t
        if not first:
            return None
        what = "heading bias" if self.estimates_bias else "heading"
        return Decision(t, HEADING, f"position data disagree with the dead reckoning: the "
                        f"{what} is doubted (1-σ raised to {math.degrees(DOUBT_SIGMA):.0f}°) "
                        "and taken from the motion")

    @property
    def doubted_at(self) -> float:
        return self._last_doubt

    def heading(self, t: float, sensor: str, accepted: bool) -> Decision | None:
        if accepted:
            self._rejected_since.pop(sensor, None)
            if sensor in self._contradicting:
                self._contradicting.discard(sensor)
                return Decision(t, HEADING, f"{sensor} agrees with the motion again: used")
            return None
        since = self._rejected_since.setdefault(sensor, t)
        if t - since >= CONTRADICTION_TIME and sensor not in self._contradicting:
            self._contradicting.add(sensor)
            return Decision(t, HEADING, f"{sensor} contradicts the motion (rejected for "
                            f"{t - since:.0f} s): not used while it does")
        return None

    @property
    def contradicting(self) -> bool:
        """Whether a heading sensor is refused for contradicting the motion (kicked, stuck)."""
        return bool(self._contradicting)

    @property
    def rejecting(self) -> bool:
        """Whether a heading sensor's latest reading was rejected (it may be off just now)."""
        return bool(self._rejected_since)

    def course_defined(self, t: float) -> bool:
        """Whether the vehicle has moved for ``STILL_TIME`` (as :meth:`motion` last heard):
        only then does a wrong heading show in the position data. Starting from rest the
        filter's speed lags the vehicle's (the box patrol's first seconds: 1-2.5 m behind
        along the track, the heading within 1°), and the position data disagreeing then
        tell of the speed, not the heading."""
        return self._pending and self._since is not None and t - self._since >= STILL_TIME

    def under_way_for(self, t: float) -> float:
        """How long the vehicle has been moving (as :meth:`motion` last heard; 0 when still)."""
        return t - self._since if self._pending and self._since is not None else 0.0

    def motion(self, t: float, speed: float) -> Decision | None:
        """The bias's observability: said when the vehicle has been still, or moving, for
        ``STILL_TIME`` (nothing to say without a bias state)."""
        moving = speed >= STILL_SPEED
        if self._since is None or moving != self._pending:
            self._pending, self._since = moving, t
            return None
        if not self.estimates_bias or moving == self._moving or t - self._since < STILL_TIME:
            return None
        self._moving = moving
        if moving:
            return Decision(t, HEADING, f"{MOVING_NOTE} the heading bias is observable")
        return Decision(t, HEADING, f"{STILL_NOTE} the heading bias is unobservable, "
                        "the heading sensor is trusted as it reads")

    _pending: bool = False
