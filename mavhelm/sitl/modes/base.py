"""The ``Mode`` base class (Rover/mode.h, Rover/mode.cpp): what every Rover mode answers and
the navigation helpers modes share.

A mode is entered with ``_enter()`` (which may refuse, saying why, as upstream's ``_enter``
does) and left with ``_exit()``; while armed, ``update()`` runs once per control-loop pass and
sets the autopilot's steering and throttle. The yes/no questions are the ones Rover::set_mode,
the arming checks and the HEARTBEAT ask.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar, cast

from mavhelm.sitl.attitude_control import clamp, wrap180

if TYPE_CHECKING:
    from mavhelm.sitl.autopilot import Autopilot
    from mavhelm.sitl.modes.loiter import ModeLoiter

# Rover custom modes (Rover/mode.h, enum Mode::Number)
MANUAL, ACRO, STEERING, HOLD, LOITER, FOLLOW, SIMPLE = 0, 1, 3, 4, 5, 6, 7
AUTO, RTL, SMART_RTL, GUIDED, INITIALISING = 10, 11, 12, 15, 16


class Mode:
    """Rover/mode.h ``class Mode``: one instance per mode, holding the autopilot it drives."""

    number: ClassVar[int]
    name: ClassVar[str]
    # the steering goes out scaled by speed (AP_MotorsUGV::set_steering's apply_scaling): every
    # mode but MANUAL (without MANUAL_OPTIONS' speed-scaling bit, which is not modelled)
    scales_steering: ClassVar[bool] = True

    def __init__(self, autopilot: Autopilot) -> None:
        self.ap = autopilot

    # ------------------------------------------------------------------ questions
    def requires_position(self) -> bool:
        """Needs the EKF's absolute position: refused while armed without it."""
        return False

    def requires_velocity(self) -> bool:
        """Needs the EKF's velocity (here: its position, which brings the velocity)."""
        return False

    def has_manual_input(self) -> bool:
        """Driven by the pilot's sticks: HEARTBEAT MANUAL_INPUT flag."""
        return False

    def is_autopilot_mode(self) -> bool:
        """Steers itself: HEARTBEAT GUIDED flag."""
        return False

    def allows_arming(self) -> bool:
        return True

    # ------------------------------------------------------------------ life
    def _enter(self) -> bool:
        """Prepare to run; False (after saying why) refuses the mode change."""
        self._start()
        return True

    def _start(self) -> None:
        """What entering does once allowed (also run for INITIAL_MODE, which is not checked)."""

    def _exit(self) -> None:
        """Leaving this mode for another."""

    def update(self, now: float, dt: float) -> None:
        """One control-loop pass while armed: set the autopilot's steering and throttle."""
        self.stop_vehicle(now, dt)

    # ------------------------------------------------------------------ shared helpers
    def speed_max(self) -> float:
        """Mode::calc_speed_max: the speed full throttle means (CRUISE_SPEED/THROTTLE)."""
        p = self.ap.params
        cs, ct = p["CRUISE_SPEED"], p["CRUISE_THROTTLE"] * 0.01
        if ct > 1.0 or ct < 0.05:
            vmax = cs
        elif p.get("SPEED_MAX", 0) > 0:
            vmax = p["SPEED_MAX"]
        else:
            vmax = cs / ct
        return clamp(vmax, 0.0, 30.0)

    def speed_nudge(self, target: float, now: float) -> float:
        """Mode::calc_speed_nudge: pilot throttle can raise the speed (even from an override)."""
        ct = self.ap.params["CRUISE_THROTTLE"]
        if ct > 100 or ct < 5:
            return target
        _, thr = self.ap.pilot_input(now)
        pilot = thr * self.speed_max()
        reversed_ = target < 0
        if (pilot > 0 and reversed_) or (pilot < 0 and not reversed_):
            return target
        return min(target, pilot) if reversed_ else max(target, pilot)

    def calc_throttle(self, speed: float, now: float, dt: float) -> None:
        """Mode::calc_throttle: the speed controller for a (accel-limited) target speed; a
        target of zero runs the controlled stop instead (get_throttle_out_stop)."""
        a = self.ap
        speed = a.atc.desired_speed_limited(speed, dt, now)
        if speed == 0.0:
            a.throttle, _ = a.atc.stop_control(a.est.forward_speed, dt, now)
        else:
            a.throttle = a.atc.speed_control(speed, a.est.forward_speed, dt, now)

    def stop_vehicle(self, now: float, dt: float) -> bool:
        """Mode::stop_vehicle: straight rudder and a controlled stop: the desired speed slews
        to zero at ATC_DECEL_MAX (else ATC_ACCEL_MAX) and the speed controller follows it, with
        reverse thrust if it must; the throttle is released once that desired speed is zero and
        the vehicle is within ATC_STOP_SPEED. True once stopped."""
        a = self.ap
        a.steering = 0.0
        a.throttle, stopped = a.atc.stop_control(a.est.forward_speed, dt, now)
        return stopped

    def start_loiter(self) -> None:
        """ModeLoiter::_enter (what GUIDED and RTL call for a boat with nothing to do): hold
        the stopping point ahead (AR_WPNav::get_stopping_location), keeping the heading."""
        cast("ModeLoiter", self.ap.modes[LOITER]).enter_loiter()

    def loiter(self, now: float, dt: float) -> None:
        """ModeLoiter::update on the shared loiter state (upstream calls
        ``rover.mode_loiter.update()`` from GUIDED and RTL too)."""
        a = self.ap
        if a.loiter_point is None:
            self.start_loiter()
        cast("ModeLoiter", a.modes[LOITER]).update_loiter(now, dt)

    def navigate_to_waypoint(self, target: tuple[float, float], speed: float,
                             now: float, dt: float) -> bool:
        """Mode::navigate_to_waypoint: drive toward target; True once within WP_RADIUS."""
        a = self.ap
        est = a.est
        dx, dy = target[0] - est.x, target[1] - est.y
        dist = math.hypot(dx, dy)
        if dist <= a.params["WP_RADIUS"]:
            return True
        bearing = math.degrees(math.atan2(dx, dy))
        err = abs(wrap180(bearing - est.heading))
        accel = a.params["ATC_ACCEL_MAX"] or 1.0
        v = min(speed, math.sqrt(2.0 * accel * 0.5 * dist))
        v *= max(0.1, math.cos(math.radians(min(err, 90.0))))
        a.steering = a.atc.heading_control(bearing, est.heading, est.yaw_rate, dt, now)
        a.throttle = a.atc.speed_control(v, est.forward_speed, dt, now)
        return False
