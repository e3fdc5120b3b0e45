"""LOITER (Rover/mode_loiter.cpp): hold the spot the vehicle can stop at.

Its state is also what GUIDED (a boat with no target, or whose target timed out) and RTL (a
boat at home) loiter on: upstream they call ``rover.mode_loiter.enter()`` / ``update()``, so
here they call this instance's ``enter_loiter()`` / ``update_loiter()`` (through
``Mode.start_loiter`` / ``Mode.loiter``).
"""

from __future__ import annotations

import math

from mavhelm.sitl.attitude_control import clamp, wrap180
from mavhelm.sitl.modes.base import LOITER, Mode


class ModeLoiter(Mode):
    """Rover/mode_loiter.cpp. The destination is the stopping point (the present position plus
    the braking distance 0.5 v²/decel along the ground velocity). Inside LOIT_RADIUS the desired
    speed slews to zero (then the controlled stop) on the heading held; outside, the boat drives
    back at LOIT_SPEED_GAIN × (distance − radius), at most WP_SPEED, reversing to a point behind
    it (LOIT_TYPE 0), slower the larger its heading error."""

    number = LOITER
    name = "LOITER"

    def __init__(self, autopilot) -> None:
        super().__init__(autopilot)
        self.desired_heading = 0.0  # degrees (_desired_yaw_cd)
        self.desired_speed = 0.0  # m/s, for reporting (_desired_speed)

    def requires_position(self) -> bool:
        return True

    def is_autopilot_mode(self) -> bool:
        return True

    def _start(self) -> None:
        self.enter_loiter()

    def enter_loiter(self) -> None:
        """ModeLoiter::_enter: destination = AR_WPNav::get_stopping_location, desired speed the
        present forward speed, desired heading the present heading."""
        a = self.ap
        est = a.est
        ground = math.hypot(est.vx, est.vy)
        x, y = est.x, est.y
        if ground > 0:
            d = a.atc.stopping_distance(ground)
            x += est.vx / ground * d
            y += est.vy / ground * d
        a.loiter_point = (x, y)
        self.desired_speed = est.forward_speed
        self.desired_heading = est.heading

    def update_loiter(self, now: float, dt: float) -> None:
        """ModeLoiter::update."""
        a = self.ap
        est = a.est
        p = a.params
        if a.loiter_point is None:
            self.enter_loiter()
        assert a.loiter_point is not None
        lx, ly = a.loiter_point
        dist = math.hypot(lx - est.x, ly - est.y)
        radius = p["LOIT_RADIUS"]
        if dist <= radius:
            speed = a.atc.desired_speed_limited(0.0, dt, now)
        else:
            speed = min((dist - radius) * p["LOIT_SPEED_GAIN"], p["WP_SPEED"])
            heading = math.degrees(math.atan2(lx - est.x, ly - est.y))
            err = wrap180(heading - est.heading)
            loit_type = int(p.get("LOIT_TYPE", 0))
            if (abs(err) > 90.0 and loit_type == 0) or loit_type == 2:
                heading = wrap180(heading + 180.0)  # behind: reverse towards it
                err = wrap180(heading - est.heading)
                speed = -speed
            # 45° of error → 75 % of the speed, 90° → 50 %
            speed *= 1.0 - clamp(abs(err) / 90.0, 0.0, 1.0) * 0.5
            self.desired_heading = heading % 360.0
        self.desired_speed = speed
        a.steering = a.atc.heading_control(self.desired_heading, est.heading, est.yaw_rate, dt,
                                           now)
        self.calc_throttle(speed, now, dt)

    def update(self, now: float, dt: float) -> None:
        self.update_loiter(now, dt)
