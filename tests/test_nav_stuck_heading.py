"""A heading sensor that sticks (:mod:`mavhelm.nav.stuck_heading`): its value standing to the
bit while the vehicle turns is refused until it moves; a still, coarse or slow sensor is not."""

from __future__ import annotations

import math

from mavhelm.nav.filter_safety import HEADING
from mavhelm.nav.stuck_heading import STUCK_TIME, STUCK_TURN, StuckHeading


def _feed(watch: StuckHeading, seconds: float, value, yaw_rate: float, start: float = 0.0,
          rate_hz: float = 10.0):
    """Readings at ``rate_hz`` for ``seconds``: ``value(t)`` as read, the filter turning at
    ``yaw_rate``; each one's (t, used, decision)."""
    out = []
    for k in range(int(seconds * rate_hz)):
        t = start + k / rate_hz
        used, decision = watch.reading(t, "compass", value(t), yaw_rate)
        out.append((t, used, decision))
    return out


def test_a_value_standing_while_the_vehicle_turns_is_refused_until_it_moves() -> None:
    watch = StuckHeading()
    turning = math.radians(10.0)  # 10°/s: 15° in 1.5 s, but stuck only after STUCK_TIME
    said = _feed(watch, 6.0, lambda t: 1.25, turning)
    found = [(t, d) for t, _, d in said if d is not None]
    assert len(found) == 1
    t_found, decision = found[0]
    assert t_found == STUCK_TIME and decision.kind == HEADING
    assert "has read 1.2500 rad for 2 s while the vehicle turned 20°: stuck" in decision.why
    assert all(used for t, used, _ in said if t < t_found)
    assert not any(used for t, used, _ in said if t >= t_found)
    used, back = watch.reading(6.0, "compass", 1.3, turning)
    assert used and back is not None and "reads a new value: used again" in back.why
    assert watch.reading(6.1, "compass", 1.3, turning) == (True, None)


def test_a_still_sensor_a_slow_phantom_turn_or_a_slow_compass_is_not_stuck() -> None:
    still = StuckHeading()  # at rest, the filter's rate zero: a standing value is right
    assert all(used and d is None for _, used, d in _feed(still, 120.0, lambda t: 0.5, 0.0))
    biased = StuckHeading()  # a gyro's 0.5°/s bias read as a slow turn: 5° in the window
    assert all(used and d is None for _, used, d in _feed(biased, 120.0, lambda t: 0.5,
                                                          math.radians(0.5)))
    slow = StuckHeading()  # a 1 Hz compass repeated at 10 Hz, the boat turning 12°/s
    rate = math.radians(12.0)
    said = _feed(slow, 60.0, lambda t: round(rate * math.floor(t), 6), rate)
    assert all(used and d is None for _, used, d in said)
    assert STUCK_TURN == math.radians(15.0)
