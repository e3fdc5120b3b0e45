"""A heading sensor that jumps: its reading steps further between two readings than the
vehicle can turn in the time (a compass near a motor switched on, a magnetic load moved).

Without a yaw-rate sensor the filter holds the heading only by that sensor: refused, the
jumped readings leave the heading's uncertainty to grow with the yaw dynamics, and a second
later they fit and are taken, the heading turned with them. On a 5 Hz GPS the fixes then
tell the filter it is off and the doubt lets the bias take the jump; when the sensor jumps
back the bias is stale by as much, and the heading is wrong again (the real ArduPilot SITL's
boat, compass jumping 30-90° for 5-20 s every minute: 5.06 m RMS against its GPS's 2.72 m).

A step between two readings a fraction of a second apart, beyond the turn the filter's yaw
rate makes in that time by more than ``KICK_SIGMAS`` of what the rate and the readings are
uncertain by (and at least ``KICK_MIN``), is the sensor's bias stepping, not the vehicle
turning: the owner moves the bias state by the step, the heading kept. When the sensor jumps
back, the bias steps back. Only after a reading the filter took (a stuck sensor released, or
readings refused for contradicting the motion, are the filter's to take again, not a step),
and only between readings ``KICK_GAP`` or less apart (over a longer silence the vehicle may
have turned anyhow).

Pure logic: the owner calls :meth:`HeadingKick.step` with each heading reading before the
update and :meth:`HeadingKick.taken` with its fate.
"""

from __future__ import annotations

import math
from typing import Final

KICK_SIGMAS: Final = 6.0
"""How many σ of the expected step (the yaw rate's uncertainty times the interval, and two
readings' noise) a step must exceed: a boat starting a turn at 2.7 rad/s² departs from the
filter's rate by under a degree in a tenth of a second."""
KICK_MIN: Final = math.radians(15.0)
"""rad: no smaller step is taken as a kick; the bias state follows smaller ones."""
KICK_GAP: Final = 0.5
"""s: two readings further apart are not compared."""


class HeadingKick:
    """Per heading sensor, its last reading and whether the filter took it."""

    def __init__(self) -> None:
        self._last: dict[str, tuple[float, float, bool]] = {}

    def step(self, sensor: str, t: float, z: float, sigma: float, yaw_rate: float,
             yaw_rate_sigma: float) -> float | None:
        """The bias step (rad) that reading ``z`` (yaw, rad, 1-σ ``sigma``) at ``t`` makes
        against the last one, where it is a kick; None where it is not."""
        last = self._last.get(sensor)
        if last is None:
            return None
        t0, z0, taken = last
        dt = t - t0
        if not taken or not 0.0 < dt <= KICK_GAP:
            return None
        excess = math.remainder(z - z0 - yaw_rate * dt, 2.0 * math.pi)
        expected = math.sqrt((yaw_rate_sigma * dt) ** 2 + 2.0 * sigma**2)
        if abs(excess) <= max(KICK_MIN, KICK_SIGMAS * expected):
            return None
        return excess

    def taken(self, sensor: str, t: float, z: float, accepted: bool) -> None:
        """The fate of the reading at ``t``."""
        self._last[sensor] = (t, z, accepted)

    @property
    def sensors(self) -> int:
        """How many heading sensors have been heard."""
        return len(self._last)
