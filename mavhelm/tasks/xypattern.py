"""XYPattern: fly a list of waypoints in order, as track lines, a number of times.

The first line runs from where the vehicle is when the task goes active to the first
``Location``; every next line joins two successive Locations (and, on a repeat pass, the last
to the first), each held as a TrackLine (carrot and donkey with the bounded cross-track integral,
see ``trackline``) with the default lead (LeadTime 1.5 s of the speed). A waypoint is
reached within ``Radius`` or once the vehicle
has passed it along its line. ``Repeat`` is the number of passes *after* the first; ``FOREVER``
patrols until the task's TimeOut (or a more important task) ends it — give it ``TimeOut = NEVER``
for a patrol that runs until the mission ends. Every time the task steers for a new waypoint it
posts ``<NAME>_WAYPOINT`` with that waypoint's index (0 = the first Location line) and, each
tick, ``<NAME>_XTE``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

from mavhelm.core.mission import Block, Entry
from mavhelm.core.params import Kind, Param, Point
from mavhelm.tasks.geometry import Point2
from mavhelm.tasks.trackline import RouteTask
from mavhelm.tasks.waypoint import RADIUS

FOREVER = "FOREVER"


@dataclass(frozen=True)
class Passes(Kind):
    """A whole number of extra passes in [0, hi], or ``FOREVER`` (held as None)."""

    hi: int = 1000

    def describe(self) -> str:
        return f"whole number in [0, {self.hi}] or {FOREVER}"

    def check_value(self, value: Any) -> bool:
        return value is None or (isinstance(value, int) and 0 <= value <= self.hi)

    def parse(self, entry: Entry) -> int | None:
        text = entry.value.strip()
        if text.upper() == FOREVER:
            return None
        try:
            x = float(text)
        except ValueError:
            raise entry.error(f"{entry.key} expects a {self.describe()}, got {text!r}") from None
        if not (math.isfinite(x) and x.is_integer() and 0 <= x <= self.hi):
            raise entry.error(f"{entry.key} must be a {self.describe()}, got {text}")
        return int(x)


class PatternTask(Protocol):
    """What ``check_pattern`` reads of a waypoint-pattern task."""

    keyword: ClassVar[str]
    name: str
    locations: list[Any]
    repeat: int | None
    radius: float


def check_pattern(task: PatternTask, block: Block) -> None:
    """A waypoint pattern's Location lines: at least one; two or more to repeat; none within
    Radius of the one before it (it would count as reached at once). Shared by the pattern
    tasks (XYPattern, SteerThenDriveXYPattern)."""
    entries = block.all("Location")
    if not entries:
        raise block.error(f"{task.keyword} task {task.name} needs at least one Location "
                          "(x,y, one line each)")
    points = [(p[0], p[1]) for p in task.locations]
    if len(points) == 1 and task.repeat != 0:
        raise (block.entry("Repeat") or block).error(
            f"Repeat needs at least two Locations: task {task.name} has one, so a repeat "
            "pass would not move")
    pairs = list(zip(range(1, len(points)), range(len(points) - 1), strict=True))
    if task.repeat != 0 and len(points) > 1:
        pairs.append((0, len(points) - 1))
    for i, j in pairs:
        gap = math.hypot(points[i][0] - points[j][0], points[i][1] - points[j][1])
        if gap < task.radius:
            raise entries[i].error(
                f"Location {entries[i].value.strip()} is {gap:.3g} m from the one before it "
                f"(line {entries[j].line}), within Radius {task.radius:g} m: it would count "
                "as reached at once")


class XYPattern(RouteTask):
    keyword = "XYPattern"
    summary = ("flies its Locations in order as track lines, 1 + Repeat times; completes after "
               "the last pass; posts <NAME>_WAYPOINT")
    params = (
        Param("Location", Point(), [], "m", "a waypoint x,y; one line each, flown in order "
              "(at least one)", repeat=True, attr="locations"),
        Param("Radius", RADIUS, 5.0, "m", "a waypoint is reached closer than this (or once "
              "passed along its line; the original's default is 0)"),
        Param("Repeat", Passes(), 0, "passes", "passes after the first; FOREVER patrols until "
              "the task's TimeOut"),
    )
    locations: list[tuple[float, float, float | None]]
    radius: float
    repeat: int | None

    def check(self, block: Block) -> None:
        check_pattern(self, block)

    def target(self, k: int) -> Point2 | None:
        n = len(self.locations)
        if self.repeat is not None and k >= n * (1 + self.repeat):
            return None
        p = self.locations[k % n]
        return p[0], p[1]

    def capture_radius(self, k: int) -> float:
        return self.radius

    def begin(self, k: int, now: float) -> None:
        self.post(f"{self.name}_WAYPOINT", float(k % len(self.locations)))
