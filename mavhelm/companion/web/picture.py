"""What the map and the panels show, as plain data (JSON-ready dicts), from the helm's tasks,
the bus variables and the typed status.

Pure: no I/O, no clock. The page draws whatever it gets, so every decision about what the
operator sees (which estimate, which shape for which task, how long a task has left) is here,
where a test can read it.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Mapping
from typing import Any

from mavhelm.companion.status import CompanionStatus
from mavhelm.nav.ekf import Beacon
from mavhelm.tasks.base import Task
from mavhelm.tasks.holding import HoldingPattern
from mavhelm.tasks.limit_box import LimitBox
from mavhelm.tasks.orbit import Orbit
from mavhelm.tasks.steer_then_drive import SteerThenDriveXYPattern
from mavhelm.tasks.survey import Survey
from mavhelm.tasks.trackline import RouteTask, TrackLine
from mavhelm.tasks.waypoint import GoToWayPoint
from mavhelm.tasks.xypattern import XYPattern

Shape = dict[str, Any]
Pose = dict[str, float]

POSES: dict[str, tuple[str, str, str | None]] = {
    "nav": ("NAV_X", "NAV_Y", "NAV_HEADING"),
    "gps": ("GPS_X", "GPS_Y", "GPS_HEADING"),
    "autopilot": ("AP_X", "AP_Y", "AP_HEADING"),
    "truth": ("TRUTH_X", "TRUTH_Y", "TRUTH_HEADING"),
    "ekf": ("EKF_X", "EKF_Y", "EKF_HEADING"),
}
"""Each estimate the map can draw: its x, y and heading variables."""

RANGE = re.compile(r"_RANGE_(\w+)$")
"""A beacon range variable, ``<sensor>_RANGE_<beacon>``."""

ALERT_LINES = 8
"""Alerts and warnings the page lists (newest first)."""


def _xy(p: Iterable[float | None]) -> list[float]:
    x, y = list(p)[:2]
    return [round(float(x or 0.0), 2), round(float(y or 0.0), 2)]


def _task_shapes(task: Task) -> list[Shape]:
    """The geometry one task flies or guards, in metres east and north of the origin."""
    name = task.name
    if isinstance(task, GoToWayPoint):
        return [{"task": name, "kind": "point", "p": _xy(task.location), "r": task.radius}]
    if isinstance(task, TrackLine):
        points = [_xy(task.p2)] if task.p1 is None else [_xy(task.p1), _xy(task.p2)]
        return [{"task": name, "kind": "line", "points": points, "r": task.radius}]
    if isinstance(task, (XYPattern, SteerThenDriveXYPattern)):
        return [{"task": name, "kind": "line", "points": [_xy(p) for p in task.locations],
                 "r": task.radius}]
    if isinstance(task, Orbit):
        return [{"task": name, "kind": "circle", "p": _xy(task.location), "r": task.radius}]
    if isinstance(task, Survey):
        points = [_xy(p) for leg in task.legs for p in leg]
        return [{"task": name, "kind": "line", "points": points, "r": 0.0}]
    if isinstance(task, LimitBox):
        return [{"task": name, "kind": "box", "min": [task.x_min, task.y_min],
                 "max": [task.x_max, task.y_max]}]
    if isinstance(task, HoldingPattern) and task.location is not None:
        return [{"task": name, "kind": "point", "p": _xy(task.location), "r": task.radius}]
    return []


def mission_shapes(tasks: Iterable[Task]) -> list[Shape]:
    """Every task's geometry, in mission order."""
    return [shape for task in tasks for shape in _task_shapes(task)]


def beacon_shapes(beacons: Iterable[Beacon]) -> list[Shape]:
    return [{"name": b.name, "p": [b.x, b.y]} for b in beacons]


def active_goal(task: Task) -> Shape | None:
    """Where the task that holds the rudder is steering now: its line, or its point."""
    if isinstance(task, RouteTask) and task.follower is not None:
        f = task.follower
        return {"task": task.name, "kind": "line", "points": [_xy(f.p1), _xy(f.p2)]}
    if isinstance(task, GoToWayPoint):
        return {"task": task.name, "kind": "point", "p": _xy(task.location), "r": task.radius}
    if isinstance(task, SteerThenDriveXYPattern):
        return {"task": task.name, "kind": "point", "p": _xy(task.goal), "r": task.radius}
    if isinstance(task, HoldingPattern) and task.location is not None:
        return {"task": task.name, "kind": "point", "p": _xy(task.location), "r": task.radius}
    return None


def _finite(value: object) -> float | None:
    if isinstance(value, float) and math.isfinite(value):
        return value
    return None


def poses(values: Mapping[str, float | str]) -> dict[str, Pose]:
    """Every estimate the bus has a finite position for."""
    out: dict[str, Pose] = {}
    for label, (xs, ys, hs) in POSES.items():
        x, y = _finite(values.get(xs)), _finite(values.get(ys))
        if x is None or y is None:
            continue
        pose: Pose = {"x": round(x, 2), "y": round(y, 2)}
        heading = _finite(values.get(hs)) if hs else None
        if heading is not None:
            pose["heading"] = round(heading % 360.0, 1)
        out[label] = pose
    ekf = out.get("ekf")
    sx, sy = _finite(values.get("EKF_SIGMA_X")), _finite(values.get("EKF_SIGMA_Y"))
    if ekf is not None and sx is not None and sy is not None:
        ekf["sigma_x"], ekf["sigma_y"] = round(sx, 2), round(sy, 2)
    return out


def ranges(values: Mapping[str, float | str]) -> dict[str, float]:
    """The last range heard to each beacon (m), by beacon name."""
    out: dict[str, float] = {}
    for name, value in values.items():
        match = RANGE.search(name)
        if match is not None and (r := _finite(value)) is not None:
            out[match.group(1)] = round(r, 2)
    return out


def running_tasks(tasks: Iterable[Task], now: float) -> list[dict[str, Any]]:
    """The active tasks with their priority and the time their TimeOut leaves (None: none)."""
    out = []
    for task in tasks:
        if not task.active or task.start_time is None:
            continue
        left = None if task.timeout is None else max(0.0, task.timeout - task.elapsed(now))
        out.append({"name": task.name, "type": task.keyword, "priority": task.priority,
                    "left": None if left is None else round(left, 1)})
    return out


def flag_names(tasks: Iterable[Task]) -> list[str]:
    """Every flag a task starts on, fires or finishes with (sorted, once each)."""
    names: set[str] = set()
    for task in tasks:
        names.update(task.start_flags, task.finish_flags, task.event_flags)
    return sorted(names)


def status_dict(status: CompanionStatus) -> dict[str, Any]:
    """The typed status, as the page reads it."""
    return {"link_up": status.link_up, "mode": status.mode, "armed": status.armed,
            "online": status.online, "status": status.status, "tasks": list(status.tasks),
            "owner": status.owner, "goal": status.goal,
            "mission_ended": status.mission_ended, "handed_back": status.handed_back,
            "nav_sources": dict(status.nav_sources), "nav_lost": list(status.nav_lost),
            "nav_warning": status.nav_warning, "nav_failure": status.nav_failure}
