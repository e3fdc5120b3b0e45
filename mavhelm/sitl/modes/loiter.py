"""LOITER (Rover/mode_loiter.cpp): hold the spot where the mode was entered."""

from __future__ import annotations

from mavhelm.sitl.modes.base import LOITER, Mode


class ModeLoiter(Mode):
    """Rover/mode_loiter.cpp: inside LOIT_RADIUS stop, outside drive back (Mode.loiter)."""

    number = LOITER
    name = "LOITER"

    def requires_position(self) -> bool:
        return True

    def is_autopilot_mode(self) -> bool:
        return True

    def _start(self) -> None:
        est = self.ap.est
        self.ap.loiter_point = (est.x, est.y)

    def update(self, now: float, dt: float) -> None:
        self.loiter(dt)
