"""Sensor messages whose value needs more than a unit change: rangefinder readings that may
mean "nothing seen", wheel distances that become a speed only between two messages, and a GPS
fix's age on arrival."""

from __future__ import annotations

import math
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.nav.sensors import MAX_FIX_AGE

UNKNOWN_U16 = 65535
"""A MAVLink uint16 field's "unknown"."""

DOWNWARD = mavlink.MAV_SENSOR_ROTATION_PITCH_270
"""DISTANCE_SENSOR orientation of a sounder or a ground rangefinder: it gives AP_ALTITUDE."""

WHEEL_MAX_SPEED = 50.0
"""m/s: a wheel-distance speed beyond this is a counter that jumped, not a vehicle moving."""
WHEEL_MAX_DISTANCE = 1e9
"""m: a cumulative wheel distance beyond this is garbage."""
WHEEL_MAX_INTERVAL_S = 5.0
"""A mean over a longer gap is not the vehicle's speed now: the clock starts again instead."""
MAX_CLOCK_STEP = 0.5
"""s: a fix this much newer than the latest time_boot_ms is on another clock (the autopilot
streams a message with its clock several times a second)."""


def distance_reading(msg: mavlink.MAVLink_distance_sensor_message) -> float | None:
    """A DISTANCE_SENSOR's range in metres, or None when it has no reading to give.

    A reading outside the sensor's own [min_distance, max_distance] is the sensor saying it
    sees nothing within its range (too close, or nothing there), and 65535 or a max_distance of
    0 means "no reading": none of these is a distance, and a rangefinder out of range is normal
    (a sounder over deep water), not an error, so they are left out without a word.
    """
    current = int(msg.current_distance)
    if current == UNKNOWN_U16 or msg.max_distance == 0:
        return None
    if not msg.min_distance <= current <= msg.max_distance:
        return None
    return current / 100.0


@dataclass
class WheelOdometry:
    """WHEEL_DISTANCE's cumulative wheel distances turned into a forward speed.

    The speed is the mean over the wheels of their distance change, divided by the time between
    two messages: wheels on either side of a turning vehicle cancel out in the mean. The first
    message only starts the clock; so does a time going backwards (the autopilot rebooted, or
    on a 32-bit board ArduPilot's ``1000UL * millis()`` wrapped, every 71.6 minutes), a
    repeated time, a change in the number of wheels or a gap over WHEEL_MAX_INTERVAL_S.
    """

    last: tuple[int, tuple[float, ...]] | None = None

    def speed(self, time_usec: int, count: int, distance: list[float]) -> float | None:
        """Forward speed (m/s) since the previous message; raises ValueError on a message no
        wheel could produce."""
        if not 0 <= count <= len(distance):
            raise ValueError(f"WHEEL_DISTANCE count {count} (at most {len(distance)} wheels)")
        wheels = tuple(float(d) for d in distance[:count])
        if not all(math.isfinite(d) and abs(d) <= WHEEL_MAX_DISTANCE for d in wheels):
            raise ValueError(f"wheel distances {wheels} are not finite metres")
        previous, self.last = self.last, (time_usec, wheels)
        if previous is None or not wheels or len(previous[1]) != len(wheels):
            return None
        dt = (time_usec - previous[0]) / 1e6
        if not 0.0 < dt <= WHEEL_MAX_INTERVAL_S:
            return None
        moved = sum(d - p for d, p in zip(wheels, previous[1], strict=True)) / len(wheels)
        speed = moved / dt
        if abs(speed) > WHEEL_MAX_SPEED:
            raise ValueError(f"wheel speed {speed:.1f} m/s in {dt:g} s: a counter jumped")
        return speed


def fix_age(boot_s: float | None, time_usec: int) -> float | None:
    """How old a GPS fix is on arrival (s), at least: ``boot_s``, the autopilot's clock when
    the fix was heard (the bridge's ``Lateness`` dates it; else the latest message that
    carried the clock, which the fix was sent no earlier than), less the fix's time_usec, which
    ArduPilot sends as its own boot time of the fix. The stream is not in step with the
    receiver, so a 5 Hz GPS_RAW_INT carries a fix 0-0.2 s old, the same all run long; pNav
    moves the fix on by it. A fix newer than that clock came before the next message that
    would have told the time: 0. None when time_usec is not on that clock (0, UNIX time)."""
    if boot_s is None or time_usec <= 0:
        return None
    age = boot_s - time_usec / 1e6
    if -MAX_CLOCK_STEP <= age < 0.0:
        return 0.0
    return age if 0.0 <= age <= MAX_FIX_AGE else None
