"""A U-turn whose next leg never leaves 0.1 m is predicted to settle at once (0 s), not at
minus the time the leg started: a negative figure made the comparison with the defaults
(each figure at most 2 % worse) refuse a candidate as good as they are, and the score favour
a leg started late."""

from __future__ import annotations

from mavhelm.tuning.gains import Course, Gains, predict_all
from mavhelm.tuning.model import YawModel

MOTORBOAT_2 = YawModel(gain=0.93, time_constant=0.21, delay=0.0, rate_limit=84.1, rms=6.0,
                       accel_limit=109.0, latency=0.04)
"""The real SITL motorboat's fit at WP_SPEED 2."""


def test_a_leg_never_left_settles_at_once() -> None:
    gains = Gains(yaw_kp=0.621, yaw_kd=0.124, max_turn_rate=90.0, lead_time=1.25,
                  line_kp=0.621, line_kd=0.124)
    p, = predict_all([gains], MOTORBOAT_2, Course(2.01, 0.5, 0.1), max_rudder=20.0,
                     app_tick=10.0)
    assert p.turn_swing is not None and p.turn_swing < 0.1
    assert p.line_settle == 0.0
