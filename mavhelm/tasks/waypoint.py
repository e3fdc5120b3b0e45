"""GoToWayPoint: steer straight at a point and complete inside its radius."""

from __future__ import annotations

import math

from mavhelm.core.params import Number, Param, Point
from mavhelm.tasks.base import HEADING, NavState, Votes
from mavhelm.tasks.steering import SteeringTask

RADIUS = Number(0.1, 10_000.0)
"""A capture radius in metres: small enough to mean a place, never zero (it would hunt)."""


class GoToWayPoint(SteeringTask):
    keyword = "GoToWayPoint"
    summary = "steers straight at a point; completes inside Radius"
    params = (
        Param("Location", Point(), unit="m", doc="the waypoint, x east and y north of the origin"),
        Param("Radius", RADIUS, 5.0, "m", "the task completes closer than this (the "
              "original's default is 0, which a vehicle never reaches)"),
    )
    location: tuple[float, float, float | None]
    radius: float

    def describe_goal(self) -> str | None:
        return f"waypoint ({self.location[0]:g}, {self.location[1]:g}) within {self.radius:g} m"

    def needs(self) -> set[str]:
        return {"NAV_X", "NAV_Y", HEADING}

    def distance_to_go(self, nav: NavState) -> float:
        assert nav.x is not None and nav.y is not None
        return math.hypot(self.location[0] - nav.x, self.location[1] - nav.y)

    def update(self, nav: NavState, now: float) -> Votes | None:
        assert nav.x is not None and nav.y is not None
        if self.distance_to_go(nav) < self.radius:
            self.complete()
            return None
        bearing = math.degrees(math.atan2(self.location[0] - nav.x, self.location[1] - nav.y))
        return self.drive(bearing % 360.0, nav)
