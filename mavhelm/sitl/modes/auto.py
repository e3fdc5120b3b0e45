"""AUTO and FOLLOW (Rover/mode_auto.cpp, mode_follow.cpp): modes the simulator names but cannot
run, since it stores no mission and follows no target."""

from __future__ import annotations

from mavhelm.sitl.mavlink_defs import SEVERITY_NOTICE, SEVERITY_WARNING
from mavhelm.sitl.modes.base import AUTO, FOLLOW, Mode


class ModeAuto(Mode):
    """Rover/mode_auto.cpp: ModeAuto::_enter refuses without a mission, and there is none."""

    number = AUTO
    name = "AUTO"

    def requires_position(self) -> bool:
        return True

    def is_autopilot_mode(self) -> bool:
        return True

    def _enter(self) -> bool:
        self.ap.text(SEVERITY_NOTICE, "No Mission. Can't set AUTO.")
        self.ap.text(SEVERITY_WARNING, "Flight mode change failed")
        return False


class ModeFollow(Mode):
    """Rover/mode_follow.cpp with no target to follow: it stops (the base update)."""

    number = FOLLOW
    name = "FOLLOW"

    def requires_position(self) -> bool:
        return True

    def is_autopilot_mode(self) -> bool:
        return True
