"""Orbit: circle a point, flying a regular polygon's sides as track lines.

The polygon has ``Sides`` vertices on the circle of ``Radius`` about ``Location`` (vertex 0 due
north of the centre). The task first steers from where the vehicle is when it goes active to the
vertex nearest it, then flies side after side — clockwise (bearing from the centre increasing)
for ``Direction = CW``, anticlockwise for ``CCW`` — each side held as a TrackLine (carrot and
donkey with the bounded cross-track integral, see ``trackline``) with the default lead
(LeadTime 1.5 s of the speed). A vertex is
reached within ``PosRadius`` or once the vehicle has passed it along its side. The task
completes when it is back at the first vertex after ``Repeat`` orbits, posting
``<NAME>_ORBIT`` (orbits done) at the end of each and ``<NAME>_XTE`` every tick.
"""

from __future__ import annotations

from mavhelm.core.mission import Block
from mavhelm.core.params import Alias, Choice, Number, Param, Point
from mavhelm.tasks.geometry import Point2, nearest, polygon, side_length
from mavhelm.tasks.trackline import RouteTask
from mavhelm.tasks.waypoint import RADIUS

DEFAULT_POS_RADIUS = 3.0
"""PosRadius when none is given, unless 40% of a side is shorter."""


class Orbit(RouteTask):
    keyword = "Orbit"
    summary = ("circles Location on a polygon of Sides track lines, CW or CCW, from the vertex "
               "nearest the vehicle; completes after Repeat orbits; posts <NAME>_ORBIT")
    params = (
        Param("Location", Point(), unit="m", doc="centre of the orbit, x east and y north"),
        Param("Radius", Number(2.0, 10_000.0), unit="m", doc="radius of the orbit"),
        Param("PosRadius", RADIUS, None, "m",
              "capture radius of each vertex; less than half a side (default 3 m, or 40% of "
              "a side if shorter; the original's default is 2 m)", attr="pos_radius"),
        Param("Direction", Choice(("CW", "CCW")), "CW",
              doc="CW: clockwise seen from above (bearing from the centre increasing); CCW: "
              "anticlockwise; the original's default is CCW"),
        Param("Repeat", Number(1, 1000, integer=True), 1, "orbits",
              "number of orbits before the task completes; the original orbits until its "
              "TimeOut when Repeat is not given"),
        Param("Sides", Number(3, 360, integer=True), 16,
              doc="sides of the polygon flown as the circle; the original's default is 6 (at "
              "most 30), which flies a hexagon rather than a circle", aliases=(Alias("TotalPos"),)),
    )
    location: tuple[float, float, float | None]
    radius: float
    pos_radius: float | None
    direction: str
    repeat: int
    sides: int

    def check(self, block: Block) -> None:
        side = side_length(self.radius, self.sides)
        if self.pos_radius is None:
            self.capture = min(DEFAULT_POS_RADIUS, 0.4 * side)
        elif self.pos_radius >= side / 2.0:
            raise (block.entry("PosRadius") or block).error(
                f"PosRadius must be less than half a side ({side / 2.0:.3g} m for Radius "
                f"{self.radius:g} and {self.sides} Sides), got {self.pos_radius:g}: "
                "vertices would be captured several at a time")
        else:
            self.capture = self.pos_radius

    def plan(self, start: Point2, now: float) -> None:
        self.vertices = polygon((self.location[0], self.location[1]), self.radius, self.sides)
        self.first = nearest(self.vertices, start)
        self.step_sign = 1 if self.direction == "CW" else -1

    def target(self, k: int) -> Point2 | None:
        if k > self.sides * self.repeat:
            return None
        return self.vertices[(self.first + self.step_sign * k) % self.sides]

    def capture_radius(self, k: int) -> float:
        return self.capture

    def arrived(self, k: int, now: float) -> None:
        if k > 0 and k % self.sides == 0:
            self.post(f"{self.name}_ORBIT", float(k // self.sides))
