"""Rover's low-level controllers (libraries/APM_Control/AR_AttitudeControl.cpp): a turn rate,
a heading or a speed becomes a steering or throttle demand in -1..1.

Kept apart from the modes because every mode that steers itself shares one controller and its
integrators, as upstream's modes share ``g2.attitude_control``. Pure: the estimate is passed in,
the parameters are read from the autopilot's table at each call (a PARAM_SET applies at once).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass


def wrap180(a: float) -> float:
    return (a + 180.0) % 360.0 - 180.0


def clamp(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else hi if v > hi else v


@dataclass
class Pid:
    """The integrator of one PI loop (the P and FF terms hold no state)."""

    integ: float = 0.0

    def reset(self) -> None:
        self.integ = 0.0


class AttitudeControl:
    """AR_AttitudeControl: steering rate FF + PI with an acceleration-limited target, heading
    as P onto the rate, speed FF + PI with an acceleration-limited target."""

    def __init__(self, params: Mapping[str, float]) -> None:
        self.params = params
        self.rate_pid = Pid()
        self.speed_pid = Pid()
        self.speed_target = 0.0  # acceleration-limited desired speed, m/s
        self.rate_target = 0.0  # acceleration-limited desired turn rate, deg/s

    def reset_pids(self) -> None:
        self.rate_pid.reset()
        self.speed_pid.reset()

    def heading_control(self, heading: float, est_heading: float, est_rate: float,
                        dt: float) -> float:
        """Steering for a heading (degrees): a rate ∝ the error, capped at ATC_STR_RAT_MAX."""
        p = self.params
        err = wrap180(heading - est_heading)
        rate = clamp(err * p["ATC_STR_ANG_P"], -p["ATC_STR_RAT_MAX"], p["ATC_STR_RAT_MAX"])
        return self.rate_control(rate, est_rate, dt)

    def rate_control(self, rate: float, est_rate: float, dt: float) -> float:
        """AR_AttitudeControl::get_steering_out_rate, in deg/s: FF + PI on the rate error."""
        p = self.params
        rmax = p["ATC_STR_RAT_MAX"]
        rate = clamp(rate, -rmax, rmax)
        acc = p["ATC_STR_ACC_MAX"] * dt
        if acc > 0:
            rate = clamp(rate, self.rate_target - acc, self.rate_target + acc)
        self.rate_target = rate
        scale = math.radians(1.0)
        err = (rate - est_rate) * scale
        pid = self.rate_pid
        imax = p["ATC_STR_RAT_IMAX"]
        pid.integ = clamp(pid.integ + err * p["ATC_STR_RAT_I"] * dt, -imax, imax)
        ff = rate * scale * p["ATC_STR_RAT_FF"]
        return clamp(ff + err * p["ATC_STR_RAT_P"] + pid.integ, -1.0, 1.0)

    def speed_control(self, speed: float, est_speed: float, dt: float) -> float:
        """AR_AttitudeControl::get_throttle_out_speed: accel-limited target, FF + PI."""
        p = self.params
        amax = p["ATC_ACCEL_MAX"]
        dmax = p["ATC_DECEL_MAX"] or amax
        cur = self.speed_target
        if amax > 0:
            lim = (amax if abs(speed) > abs(cur) else dmax) * dt
            speed = clamp(speed, cur - lim, cur + lim)
        self.speed_target = speed
        err = speed - est_speed
        pid = self.speed_pid
        imax = p["ATC_SPEED_IMAX"]
        pid.integ = clamp(pid.integ + err * p["ATC_SPEED_I"] * dt, -imax, imax)
        cs = max(p["CRUISE_SPEED"], 0.1)
        ff = speed / cs * p["CRUISE_THROTTLE"] * 0.01
        thr = ff + err * p["ATC_SPEED_P"] + pid.integ
        tmax = p["MOT_THR_MAX"] * 0.01
        return clamp(thr, -tmax, tmax)
