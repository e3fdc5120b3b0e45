"""ACRO, STEERING and SIMPLE (Rover/mode_acro.cpp, mode_steering.cpp, mode_simple.cpp): the
sticks ask for a turn rate and a speed that the controllers then hold.

One family: the simulator drives them alike (steering stick × ACRO_TURN_RATE, throttle stick ×
the cruise-derived top speed); they differ in what they need to be entered.
"""

from __future__ import annotations

from mavhelm.sitl.modes.base import ACRO, SIMPLE, STEERING, Mode


class ModeAcro(Mode):
    """Rover/mode_acro.cpp: turn rate and speed from the sticks; needs a velocity estimate."""

    number = ACRO
    name = "ACRO"

    def requires_velocity(self) -> bool:
        return True

    def has_manual_input(self) -> bool:
        return True

    def update(self, now: float, dt: float) -> None:
        a = self.ap
        steer, thr = a.pilot_input(now)
        rate = steer * a.params["ACRO_TURN_RATE"]
        a.steering = a.atc.rate_control(rate, a.est.yaw_rate, dt, now)
        self.calc_throttle(thr * self.speed_max(), now, dt)


class ModeSteering(ModeAcro):
    """Rover/mode_steering.cpp (driven here as ACRO is)."""

    number = STEERING
    name = "STEERING"


class ModeSimple(ModeAcro):
    """Rover/mode_simple.cpp (driven here as ACRO is); needs a position for its earth frame."""

    number = SIMPLE
    name = "SIMPLE"

    def requires_position(self) -> bool:
        return True

    def requires_velocity(self) -> bool:
        return False
