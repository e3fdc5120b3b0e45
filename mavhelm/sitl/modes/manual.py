"""MANUAL (Rover/mode_manual.cpp): the sticks go straight to the outputs."""

from __future__ import annotations

from mavhelm.sitl.modes.base import MANUAL, Mode


class ModeManual(Mode):
    """Rover/mode_manual.cpp. A skid vehicle scales steering and throttle together when they
    ask for more than the motors have, and the throttle comes slew-limited
    (Mode::get_pilot_desired_steering_and_throttle)."""

    number = MANUAL
    name = "MANUAL"
    scales_steering = False

    def has_manual_input(self) -> bool:
        return True

    def update(self, now: float, dt: float) -> None:
        a = self.ap
        steer, thr = a.pilot_input(now)
        sat = abs(steer) + abs(thr)
        if a.skid and sat > 1.0:
            steer, thr = steer / sat, thr / sat
        # the outputs slew the throttle (MOT_SLEWRATE): while the stick has crossed to the other
        # side of zero and the output has not yet, steer as for the output's direction
        limited = a.motors.slew_limited(thr, dt)
        if (thr < 0.0) != (limited < 0.0) and a.params.get("PILOT_STEER_TYPE", 0) in (0, 1):
            steer = -steer
        a.steering, a.throttle = steer, limited
