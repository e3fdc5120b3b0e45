"""MANUAL (Rover/mode_manual.cpp): the sticks go straight to the outputs."""

from __future__ import annotations

from mavhelm.sitl.modes.base import MANUAL, Mode


class ModeManual(Mode):
    """Rover/mode_manual.cpp. A skid vehicle scales steering and throttle together when they
    ask for more than the motors have (Mode::get_pilot_desired_steering_and_throttle)."""

    number = MANUAL
    name = "MANUAL"

    def has_manual_input(self) -> bool:
        return True

    def update(self, now: float, dt: float) -> None:
        a = self.ap
        steer, thr = a.pilot_input(now)
        sat = abs(steer) + abs(thr)
        if a.skid and sat > 1.0:
            steer, thr = steer / sat, thr / sat
        a.steering, a.throttle = steer, thr
