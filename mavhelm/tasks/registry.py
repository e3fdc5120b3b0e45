"""Task keyword → class. A new task type is one module plus one line here."""

from __future__ import annotations

from mavhelm.core.mission import Block
from mavhelm.tasks.actuate import SetActuator
from mavhelm.tasks.base import Task
from mavhelm.tasks.constant_depth import ConstantDepth
from mavhelm.tasks.dive import DiveTask
from mavhelm.tasks.end_mission import EndMission
from mavhelm.tasks.goto_depth import GoToDepth
from mavhelm.tasks.heading import ConstantHeading
from mavhelm.tasks.holding import HoldingPattern
from mavhelm.tasks.limit_altitude import LimitAltitude
from mavhelm.tasks.limit_box import LimitBox
from mavhelm.tasks.limit_depth import LimitDepth
from mavhelm.tasks.orbit import Orbit
from mavhelm.tasks.overall_timeout import OverallTimeOut
from mavhelm.tasks.pid import HelmGains
from mavhelm.tasks.steer_then_drive import SteerThenDriveXYPattern
from mavhelm.tasks.survey import Survey
from mavhelm.tasks.timer import Timer
from mavhelm.tasks.trackline import TrackLine
from mavhelm.tasks.variable_heading import VariableHeading
from mavhelm.tasks.waypoint import GoToWayPoint
from mavhelm.tasks.xypattern import XYPattern
from mavhelm.tasks.zpattern import ZPattern

TASK_TYPES: dict[str, type[Task]] = {
    "gotowaypoint": GoToWayPoint,
    "trackline": TrackLine,
    "xypattern": XYPattern,
    "orbit": Orbit,
    "survey": Survey,
    "constantheading": ConstantHeading,
    "timer": Timer,
    "timeout": Timer,
    "overalltimeout": OverallTimeOut,
    "endmission": EndMission,
    "setactuator": SetActuator,
    "limitbox": LimitBox,
    "limitaltitude": LimitAltitude,
    "holdingpattern": HoldingPattern,
    "steerthendrivexypattern": SteerThenDriveXYPattern,
    "variableheading": VariableHeading,
    "constantdepth": ConstantDepth,
    "gotodepth": GoToDepth,
    "zpattern": ZPattern,
    "limitdepth": LimitDepth,
    "divetask": DiveTask,
}


SPELLINGS: dict[str, str] = {"timeout": "TimeOut"}
"""How a user writes an alias (the spec calls the Timer task TimeOut)."""


NOT_SUPPORTED: dict[str, tuple[str, str]] = {
    "seabedtrack": ("SeabedTrack", "holding an altitude above the seabed is not supported; "
                    "LimitAltitude watches it"),
    "pilot": ("Pilot", "set points from other processes (DepthControllingProcess, "
              "YawControllingProcess, SpeedControllingProcess) are not supported; "
              "VariableHeading holds a heading posted on the bus"),
    "thirdparty": ("ThirdParty", "a third party's task comes over the bus or MAVLink, granted "
                   "by the pHelm block's Allow, not from the mission file"),
    "agvheadingspeed": ("AGVHeadingSpeed", "not supported; VariableHeading holds a heading "
                        "posted on the bus"),
    "vehicleframewaypoint": ("VehicleFrameWayPoint", "waypoints in the vehicle's frame are "
                             "not supported; GoToWayPoint takes them in the mission's frame"),
}
"""Task types of the original pHelm that mavhelm refuses, with why."""


def spelling(key: str) -> str:
    """A registry key as a user would write it."""
    return SPELLINGS.get(key, TASK_TYPES[key].keyword)


def known_types() -> list[str]:
    """Keywords as a user would write them, for error messages."""
    return sorted({spelling(key) for key in TASK_TYPES}, key=str.lower)


def task_class(keyword: str) -> type[Task] | None:
    return TASK_TYPES.get(keyword.strip().lower())


def build_task(block: Block, gains: HelmGains | None = None) -> Task:
    """Build one task from its ``Task = Type { … }`` block, or raise a located MissionError."""
    cls = task_class(block.name)
    refused = NOT_SUPPORTED.get(block.name.strip().lower())
    if cls is None and refused is not None:
        raise block.error(f"task type {refused[0]} is not supported by mavhelm: {refused[1]}")
    if cls is None:
        raise block.error(f"unknown task type {block.name!r} (known: {', '.join(known_types())})")
    return cls(block, gains)
