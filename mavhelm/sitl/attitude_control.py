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


_DEG = math.radians(1.0)  # rad per degree


@dataclass
class Pid:
    """The integrator of one PI loop (the P and FF terms hold no state)."""

    integ: float = 0.0

    def reset(self) -> None:
        self.integ = 0.0


# AR_AttitudeControl.cpp: a controller not called for AR_ATTCONTROL_TIMEOUT_MS starts afresh
# (I-term reset, desired value taken from the vehicle); get_throttle_out_stop keeps saying
# "stopped" for 300 ms after it last did.
CONTROL_TIMEOUT_S = 0.2
STOPPED_HOLD_S = 0.3


class AttitudeControl:
    """AR_AttitudeControl: steering rate FF + PI with an acceleration-limited target, heading
    as P onto the rate, speed FF + PI with an acceleration-limited target, and the controlled
    stop (get_throttle_out_stop).

    ``now`` (seconds, optional on each call) gives the controllers upstream's memory of when
    they last ran: a speed or rate controller idle for more than 0.2 s restarts from the
    vehicle's present speed or turn rate with its integrator cleared, as upstream's
    ``speed_control_active()`` / ``_steer_turn_last_ms`` checks do. Without ``now`` a call
    never restarts the controller."""

    def __init__(self, params: Mapping[str, float]) -> None:
        self.params = params
        self.rate_pid = Pid()
        self.speed_pid = Pid()
        self.speed_target = 0.0  # acceleration-limited desired speed, m/s (_desired_speed)
        self.rate_target = 0.0  # acceleration-limited desired turn rate, deg/s
        self._speed_last: float | None = None  # _speed_last_ms
        self._rate_last: float | None = None  # _steer_turn_last_ms
        self._stop_last: float | None = None  # _stop_last_ms (None: not stopped)
        # AP_MotorsUGV limit.throttle_lower || throttle_upper from the last output (the slew
        # held the throttle back, it is at MOT_THR_MAX, or disarmed): the speed integrator may
        # then only shrink (AC_PID::update_i), as get_throttle_out_speed passes it
        self.motor_limit = False
        # AP_MotorsUGV limit.steer_left || steer_right from the last output (too slow to steer,
        # or full deflection): the steering integrator may then only shrink
        self.steer_limit = False

    def reset_pids(self) -> None:
        self.rate_pid.reset()
        self.speed_pid.reset()

    def heading_control(self, heading: float, est_heading: float, est_rate: float,
                        dt: float, now: float | None = None) -> float:
        """Steering for a heading (degrees): a rate ∝ the error, capped at ATC_STR_RAT_MAX."""
        p = self.params
        err = wrap180(heading - est_heading)
        rmax = p["ATC_STR_RAT_MAX"]
        rate = err * p["ATC_STR_ANG_P"]
        # clamp() inlined (here and below): these run every control-loop pass
        rate = -rmax if rate < -rmax else rmax if rate > rmax else rate
        return self.rate_control(rate, est_rate, dt, now)

    def rate_control(self, rate: float, est_rate: float, dt: float,
                     now: float | None = None) -> float:
        """AR_AttitudeControl::get_steering_out_rate, in deg/s: FF + PI on the rate error."""
        p = self.params
        if now is not None:
            if self._rate_last is None or now - self._rate_last > CONTROL_TIMEOUT_S:
                self.rate_pid.reset()
                self.rate_target = est_rate
            self._rate_last = now
        rmax = p["ATC_STR_RAT_MAX"]
        rate = -rmax if rate < -rmax else rmax if rate > rmax else rate
        acc = p["ATC_STR_ACC_MAX"] * dt
        if acc > 0:
            lo, hi = self.rate_target - acc, self.rate_target + acc
            rate = lo if rate < lo else hi if rate > hi else rate
        self.rate_target = rate
        err = (rate - est_rate) * _DEG
        pid = self.rate_pid
        integ = pid.integ
        if not self.steer_limit or (integ > 0.0 > err) or (integ < 0.0 < err):
            imax = p["ATC_STR_RAT_IMAX"]
            integ += err * p["ATC_STR_RAT_I"] * dt
            pid.integ = integ = -imax if integ < -imax else imax if integ > imax else integ
        out = rate * _DEG * p["ATC_STR_RAT_FF"] + err * p["ATC_STR_RAT_P"] + integ
        return -1.0 if out < -1.0 else 1.0 if out > 1.0 else out

    # ------------------------------------------------------------------ speed
    def speed_active(self, now: float | None) -> bool:
        """AR_AttitudeControl::speed_control_active: run within the last 0.2 s."""
        return now is None or (self._speed_last is not None
                               and now - self._speed_last <= CONTROL_TIMEOUT_S)

    def decel_max(self) -> float:
        """AR_AttitudeControl::get_decel_max: ATC_DECEL_MAX, or ATC_ACCEL_MAX when it is 0."""
        p = self.params
        return p["ATC_DECEL_MAX"] if p["ATC_DECEL_MAX"] > 0 else p["ATC_ACCEL_MAX"]

    def stopping_distance(self, speed: float) -> float:
        """AR_AttitudeControl::get_stopping_distance: 0.5 v² / decel_max (linear braking)."""
        d = self.decel_max()
        return 0.0 if d <= 0 or speed == 0 else 0.5 * speed * speed / d

    def desired_speed_limited(self, speed: float, dt: float,
                              now: float | None = None) -> float:
        """AR_AttitudeControl::get_desired_speed_accel_limited: ``speed`` moved no further from
        the last desired speed than ATC_ACCEL_MAX (ATC_DECEL_MAX when slowing) allows in dt;
        unlimited when the speed controller is idle or ATC_ACCEL_MAX is 0. Stores nothing."""
        p = self.params
        amax = p["ATC_ACCEL_MAX"]
        if not self.speed_active(now) or amax <= 0:
            return speed
        dt = 0.0 if dt < 0.0 else 1.0 if dt > 1.0 else dt
        prev = self.speed_target
        if abs(speed) < abs(prev) and p["ATC_DECEL_MAX"] > 0:
            lim = p["ATC_DECEL_MAX"] * dt
        else:
            lim = amax * dt
        lo, hi = prev - lim, prev + lim
        return lo if speed < lo else hi if speed > hi else speed

    def speed_control(self, speed: float, est_speed: float, dt: float,
                      now: float | None = None) -> float:
        """AR_AttitudeControl::get_throttle_out_speed: accel-limited target, FF + PI; reverse
        output only with ATC_BRAKE (default 1)."""
        p = self.params
        if now is not None:
            if not self.speed_active(now):
                self.speed_pid.reset()
                self.speed_target = est_speed
            self._speed_last = now
        speed = self.desired_speed_limited(speed, dt)
        self.speed_target = speed
        err = speed - est_speed
        pid = self.speed_pid
        integ = pid.integ
        if not self.motor_limit or (integ > 0.0 > err) or (integ < 0.0 < err):
            imax = p["ATC_SPEED_IMAX"]
            integ += err * p["ATC_SPEED_I"] * dt
            pid.integ = integ = -imax if integ < -imax else imax if integ > imax else integ
        cs = max(p["CRUISE_SPEED"], 0.1)
        ff = speed / cs * p["CRUISE_THROTTLE"] * 0.01
        thr = ff + err * p["ATC_SPEED_P"] + integ
        if not p.get("ATC_BRAKE", 1):
            # no reverse thrust to slow down: never against the desired direction
            if speed >= 0 and thr <= 0 or speed <= 0 and thr >= 0:
                thr = 0.0
        tmax = p["MOT_THR_MAX"] * 0.01
        return -tmax if thr < -tmax else tmax if thr > tmax else thr

    def stop_control(self, est_speed: float, dt: float,
                     now: float | None = None) -> tuple[float, bool]:
        """AR_AttitudeControl::get_throttle_out_stop: (throttle, stopped). The desired speed is
        slewed to zero at the deceleration limit and the speed controller follows it (reverse
        thrust on a boat); "stopped" once that desired speed is zero and the vehicle is within
        ATC_STOP_SPEED, and then for 300 ms after: the throttle is released and the integrator
        cleared."""
        stopped = (now is not None and self._stop_last is not None
                   and now - self._stop_last < STOPPED_HOLD_S)
        limited = self.desired_speed_limited(0.0, dt, now)
        if limited == 0.0 and abs(est_speed) <= abs(self.params["ATC_STOP_SPEED"]):
            stopped = True
        if stopped:
            self._stop_last = now
            if now is not None:
                self._speed_last = now
            self.speed_pid.reset()
            self.speed_target = 0.0
            return 0.0, True
        self._stop_last = None
        return self.speed_control(limited, est_speed, dt, now), False
