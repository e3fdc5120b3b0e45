"""GoToWayPoint: steer straight at a point and complete inside its radius."""

from __future__ import annotations

import math

from mavhelm.companion.mission import Block, Entry
from mavhelm.tasks.base import HEADING, NavState, Votes
from mavhelm.tasks.pid import HelmGains
from mavhelm.tasks.steering import SteeringTask


def parse_location(entry: Entry) -> tuple[float, float, float | None]:
    """``x,y[,z]`` in metres of the local frame."""
    parts = [p.strip() for p in entry.value.split(",")]
    if len(parts) not in (2, 3):
        raise entry.error(f"{entry.key} expects x,y or x,y,z in metres, got {entry.value!r}")
    try:
        values = [float(p) for p in parts]
    except ValueError:
        raise entry.error(
            f"{entry.key} expects x,y or x,y,z in metres, got {entry.value!r}"
        ) from None
    return values[0], values[1], values[2] if len(values) == 3 else None


class GoToWayPoint(SteeringTask):
    keyword = "GoToWayPoint"
    params = ("Location", "Radius", *SteeringTask.params)

    def __init__(self, block: Block, gains: HelmGains | None = None) -> None:
        self.location: tuple[float, float, float | None] | None = None
        self.radius = 5.0
        super().__init__(block, gains)

    def set_param(self, key: str, entry: Entry) -> bool:
        if key == "location":
            self.location = parse_location(entry)
        elif key == "radius":
            self.radius = entry.as_float()
            if self.radius <= 0:
                raise entry.error(f"Radius must be positive metres, got {entry.value}")
        else:
            return super().set_param(key, entry)
        return True

    def check(self, block: Block) -> None:
        if self.location is None:
            raise block.error(f"GoToWayPoint task {self.name} needs Location = x,y")

    def needs(self) -> set[str]:
        return {"NAV_X", "NAV_Y", HEADING}

    def distance_to_go(self, nav: NavState) -> float:
        assert self.location is not None and nav.x is not None and nav.y is not None
        return math.hypot(self.location[0] - nav.x, self.location[1] - nav.y)

    def update(self, nav: NavState, now: float) -> Votes | None:
        assert self.location is not None and nav.x is not None and nav.y is not None
        if self.distance_to_go(nav) < self.radius:
            self.complete()
            return None
        bearing = math.degrees(math.atan2(self.location[0] - nav.x, self.location[1] - nav.y))
        return self.drive(bearing % 360.0, nav)
