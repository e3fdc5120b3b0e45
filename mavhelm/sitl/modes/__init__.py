"""Rover's modes, one module a family, each class naming its upstream file; ``MODE_CLASSES``
is the mode table by ArduPilot's mode number (Rover::mode_from_mode_num)."""

from __future__ import annotations

from mavhelm.sitl.modes.acro import ModeAcro, ModeSimple, ModeSteering
from mavhelm.sitl.modes.auto import ModeAuto, ModeFollow
from mavhelm.sitl.modes.base import (
    ACRO,
    AUTO,
    FOLLOW,
    GUIDED,
    HOLD,
    INITIALISING,
    LOITER,
    MANUAL,
    RTL,
    SIMPLE,
    SMART_RTL,
    STEERING,
    Mode,
)
from mavhelm.sitl.modes.guided import GuidedSubMode, ModeGuided
from mavhelm.sitl.modes.hold import ModeHold, ModeInitialising
from mavhelm.sitl.modes.loiter import ModeLoiter
from mavhelm.sitl.modes.manual import ModeManual
from mavhelm.sitl.modes.rtl import ModeRTL, ModeSmartRTL

MODE_CLASSES: dict[int, type[Mode]] = {
    cls.number: cls for cls in (
        ModeManual, ModeAcro, ModeSteering, ModeHold, ModeLoiter, ModeFollow, ModeSimple,
        ModeAuto, ModeRTL, ModeSmartRTL, ModeGuided, ModeInitialising)
}

__all__ = [
    "ACRO", "AUTO", "FOLLOW", "GUIDED", "HOLD", "INITIALISING", "LOITER", "MANUAL", "MODE_CLASSES",
    "RTL", "SIMPLE", "SMART_RTL", "STEERING", "GuidedSubMode", "Mode", "ModeAcro", "ModeAuto",
    "ModeFollow", "ModeGuided", "ModeHold", "ModeInitialising", "ModeLoiter", "ModeManual",
    "ModeRTL", "ModeSimple", "ModeSmartRTL", "ModeSteering",
]
