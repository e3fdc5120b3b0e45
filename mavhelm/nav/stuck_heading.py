"""A heading sensor that sticks: its readings repeat one value, to the bit, while the vehicle
turns (a frozen AHRS, a serial line replaying its last sentence).

The χ² gate alone does not hold such a sensor out. While the heading's bias is a state, its
drift rate sweeps the reading the filter expects through the frozen value, and a reading that
happens to fit there is taken as the sensor agreeing again: Plaza1 with the heading drifting
180° within two minutes and stuck for five of them, 2.18 m RMS, 30 m off, re-initialised from
the LSQ. A real sensor's value moves when the vehicle turns; one that has not moved for
``STUCK_TIME`` while the vehicle turned ``STUCK_TURN`` is refused until its value changes.
The turn is the filter's yaw rate integrated between readings (not its heading's
change, which a realignment would jump), over the last ``STUCK_WINDOW`` s: a gyro's bias read
as a slow turn at rest (0.5°/s: 5° in the window) does not make a still sensor look stuck.
Going straight, a frozen sensor is not told from a steady one, and does no harm.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Final

from mavhelm.nav.filter_safety import HEADING, Decision

STUCK_TURN: Final = math.radians(15.0)
"""rad: the vehicle turned this far (the filter's yaw rate) while a sensor read one value."""
STUCK_TIME: Final = 2.0
"""s: ... for at least this long (a 1 Hz compass repeated at 10 Hz, the vehicle turning
fast, is not stuck)."""
STUCK_WINDOW: Final = 10.0
"""s: ... the turn counted over at most this long."""


@dataclass
class _Held:
    value: float
    since: float
    turns: deque[tuple[float, float]]
    """(time, turn since ``since``) at each reading over the window, the newest last."""
    stuck: bool = False


class StuckHeading:
    """Per heading reading, :meth:`reading` says whether to use it, and a decision to report
    when a sensor is found stuck or moves again."""

    def __init__(self) -> None:
        self._held: dict[str, _Held] = {}

    def reading(self, t: float, sensor: str, value: float, yaw_rate: float
                ) -> tuple[bool, Decision | None]:
        """``value``: the reading as the sensor gave it; ``yaw_rate``: the filter's (rad/s)."""
        held = self._held.get(sensor)
        if held is None or value != held.value:
            self._held[sensor] = _Held(value, t, deque([(t, 0.0)]))
            if held is not None and held.stuck:
                return True, Decision(t, HEADING, f"heading sensor {sensor} reads a new "
                                      "value: used again")
            return True, None
        if held.stuck:
            return False, None
        turns = held.turns
        last, turned_since = turns[-1]
        turns.append((t, turned_since + yaw_rate * max(t - last, 0.0)))
        while turns[0][0] < t - STUCK_WINDOW:
            turns.popleft()
        turned = turns[-1][1] - turns[0][1]
        if abs(turned) >= STUCK_TURN and t - held.since >= STUCK_TIME:
            held.stuck = True
            return False, Decision(t, HEADING, (
                f"heading sensor {sensor} has read {value:.4f} rad for {t - held.since:.0f} s "
                f"while the vehicle turned {math.degrees(abs(turned)):.0f}°: stuck, not used "
                "until its value changes"))
        return True, None
