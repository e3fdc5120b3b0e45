"""The ``Mode`` base class (Rover/mode.h, Rover/mode.cpp): what every Rover mode answers and
the navigation helpers modes share.

A mode is entered with ``_enter()`` (which may refuse, saying why, as upstream's ``_enter``
does) and left with ``_exit()``; while armed, ``update()`` runs once per control-loop pass and
sets the autopilot's steering and throttle. The yes/no questions are the ones Rover::set_mode,
the arming checks and the HEARTBEAT ask.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, ClassVar

from mavhelm.sitl.attitude_control import clamp, wrap180

if TYPE_CHECKING:
    from mavhelm.sitl.autopilot import Autopilot

# Rover custom modes (Rover/mode.h, enum Mode::Number)
MANUAL, ACRO, STEERING, HOLD, LOITER, FOLLOW, SIMPLE = 0, 1, 3, 4, 5, 6, 7
AUTO, RTL, SMART_RTL, GUIDED, INITIALISING = 10, 11, 12, 15, 16


class Mode:
    """Rover/mode.h ``class Mode``: one instance per mode, holding the autopilot it drives."""

    number: ClassVar[int]
    name: ClassVar[str]

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
        self.stop_vehicle(dt)

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

    def stop_vehicle(self, dt: float) -> None:
        """Mode::stop_vehicle: straight rudder, brake to a stop, then release the throttle."""
        a = self.ap
        a.steering = 0.0
        if abs(a.est.forward_speed) < a.params["ATC_STOP_SPEED"]:
            a.atc.speed_pid.reset()
            a.atc.speed_target = 0.0
            a.throttle = 0.0
        else:
            a.throttle = a.atc.speed_control(0.0, a.est.forward_speed, dt)

    def loiter(self, dt: float) -> None:
        """Hold near ``loiter_point`` (ModeLoiter's rule, also used by boats in GUIDED and at
        the end of RTL): inside LOIT_RADIUS stop, outside drive back at a speed ∝ distance."""
        a = self.ap
        est = a.est
        if a.loiter_point is None:
            a.loiter_point = (est.x, est.y)
        lx, ly = a.loiter_point
        dist = math.hypot(lx - est.x, ly - est.y)
        radius = a.params["LOIT_RADIUS"]
        if dist <= radius:
            self.stop_vehicle(dt)
            return
        speed = min(a.params["LOIT_SPEED_GAIN"] * (dist - radius) + 0.3, a.params["WP_SPEED"])
        bearing = math.degrees(math.atan2(lx - est.x, ly - est.y))
        err = abs(wrap180(bearing - est.heading))
        a.steering = a.atc.heading_control(bearing, est.heading, est.yaw_rate, dt)
        a.throttle = a.atc.speed_control(speed * max(0.0, math.cos(math.radians(err))),
                                         est.forward_speed, dt)

    def navigate_to_waypoint(self, target: tuple[float, float], speed: float,
                             dt: float) -> bool:
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
        a.steering = a.atc.heading_control(bearing, est.heading, est.yaw_rate, dt)
        a.throttle = a.atc.speed_control(v, est.forward_speed, dt)
        return False
