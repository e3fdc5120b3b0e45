"""HOLD and INITIALISING (Rover/mode_hold.cpp; ModeInitializing in Rover/mode.h): outputs at
rest."""

from __future__ import annotations

from mavhelm.sitl.modes.base import HOLD, INITIALISING, Mode


class ModeHold(Mode):
    """Rover/mode_hold.cpp: steering and throttle zero (a boat drifts)."""

    number = HOLD
    name = "HOLD"

    def update(self, now: float, dt: float) -> None:
        self.ap.steering = 0.0
        self.ap.throttle = 0.0


class ModeInitialising(ModeHold):
    """ModeInitializing (Rover/mode.h): the mode until start-up ends; counts as manual input
    in the HEARTBEAT, as upstream."""

    number = INITIALISING
    name = "INITIALISING"

    def has_manual_input(self) -> bool:
        return True
