"""SteerThenDriveXYPattern: an XY pattern for vehicles that can turn on the spot.

For skid-steer rovers and twin-thruster boats: driving off towards a new waypoint while still
pointing the wrong way sweeps a wide arc (into whatever is beside the track); these vehicles
can pivot instead. At each waypoint the task first turns with THRUST voted 0 until the heading
error to the waypoint is below ``HeadingTolerance``, then drives with ``Thrust``. While driving,
the thrust tapers linearly to 0 as the error grows from ``HeadingTolerance`` to
``OuterYawLimit``; beyond that it stops and turns on the spot again (these two limits and the
taper are the original MOOS task's ``InnerYawLimit``/``OuterYawLimit``, defaults 10° and 40°;
its ``ThrustDamping`` filter is not reproduced). The rudder vote always comes from the heading
controller, so a positive rudder still turns clockwise.

The pattern is the ``Location`` lines in order, run ``Repeat`` times (Repeat = 1: each point
once); a waypoint counts as reached closer than ``Radius``. The task completes on reaching the
last point of the last pass (the original never completed and ended on its TimeOut; the
spec's XYPattern "number of repetitions" reads more naturally this way). It posts
``<NAME>_WAYPOINT`` ("index/count pass p/Repeat") on each new waypoint and ``<NAME>_PHASE``
(TURN or DRIVE) on each change. Needs NAV_X, NAV_Y and NAV_HEADING.
"""

from __future__ import annotations

import math

from mavhelm.core.geodesy import wrap_degrees
from mavhelm.core.mission import Block
from mavhelm.core.params import Number, Param, Point
from mavhelm.tasks.base import HEADING, NavState, Task, Votes
from mavhelm.tasks.waypoint import RADIUS

TURN = "TURN"
DRIVE = "DRIVE"


class SteerThenDriveXYPattern(Task):
    keyword = "SteerThenDriveXYPattern"
    summary = ("an XY pattern that turns on the spot (THRUST 0) at each waypoint until the "
               "heading error is below HeadingTolerance, then drives; completes after the "
               "last pass")
    params = (
        Param("Location", Point(), unit="m", repeat=True, attr="locations",
              doc="a waypoint, x east and y north of the origin; one line each, in order"),
        Param("Radius", RADIUS, 5.0, "m", "a waypoint is reached closer than this"),
        Param("Repeat", Number(1, 1000, integer=True), 1,
              doc="how many times to run the whole pattern"),
        Param("Thrust", Number(0.0, 100.0, lo_open=True), unit="%",
              doc="thrust while driving with the heading error within HeadingTolerance"),
        Param("HeadingTolerance", Number(0.0, 90.0, lo_open=True), 10.0, "deg",
              "turn on the spot until the heading error to the waypoint is below this",
              attr="heading_tolerance"),
        Param("OuterYawLimit", Number(0.0, 180.0, lo_open=True), 40.0, "deg",
              "while driving, thrust tapers to 0 as the error grows to this; beyond it, turn "
              "on the spot again; must exceed HeadingTolerance", attr="outer_yaw_limit"),
    )
    locations: list[tuple[float, float, float | None]]
    radius: float
    repeat: int
    thrust: float
    heading_tolerance: float
    outer_yaw_limit: float

    def check(self, block: Block) -> None:
        if not self.outer_yaw_limit > self.heading_tolerance:
            entries = [e for e in (block.entry("OuterYawLimit"), block.entry("HeadingTolerance"))
                       if e is not None]
            where = max(entries, key=lambda e: e.line)
            raise where.error(f"OuterYawLimit = {self.outer_yaw_limit:g} must exceed "
                              f"HeadingTolerance = {self.heading_tolerance:g}")

    def needs(self) -> set[str]:
        return {"NAV_X", "NAV_Y", HEADING}

    def initialise(self, now: float) -> None:
        self.index = 0
        self.pass_number = 1
        self.phase: str | None = None
        self._announce()

    def _announce(self) -> None:
        self.post(f"{self.name}_WAYPOINT", f"{self.index + 1}/{len(self.locations)} "
                                           f"pass {self.pass_number}/{self.repeat}")

    def _set_phase(self, phase: str) -> None:
        if phase != self.phase:
            self.phase = phase
            self.post(f"{self.name}_PHASE", phase)

    @property
    def goal(self) -> tuple[float, float]:
        x, y, _ = self.locations[self.index]
        return x, y

    def _advance(self) -> bool:
        """Move to the next waypoint; False when the last one of the last pass is done."""
        if self.index == len(self.locations) - 1 and self.pass_number == self.repeat:
            return False
        self.index += 1
        if self.index == len(self.locations):
            self.index = 0
            self.pass_number += 1
        self.yaw_pid.reset()  # a new bearing is a step, not a rate of change
        self._set_phase(TURN)
        self._announce()
        return True

    def update(self, nav: NavState, now: float) -> Votes | None:
        assert nav.x is not None and nav.y is not None and nav.heading is not None
        while math.hypot(self.goal[0] - nav.x, self.goal[1] - nav.y) < self.radius:
            if not self._advance():
                self.complete()
                return None
        gx, gy = self.goal
        bearing = math.degrees(math.atan2(gx - nav.x, gy - nav.y)) % 360.0
        error = abs(wrap_degrees(bearing - nav.heading))
        if self.phase != DRIVE and error < self.heading_tolerance:
            self._set_phase(DRIVE)
        elif self.phase == DRIVE and error > self.outer_yaw_limit:
            self._set_phase(TURN)
        elif self.phase is None:
            self._set_phase(TURN)
        if self.phase == TURN:
            thrust = 0.0
        elif error <= self.heading_tolerance:
            thrust = self.thrust
        else:
            span = self.outer_yaw_limit - self.heading_tolerance
            thrust = self.thrust * (self.outer_yaw_limit - error) / span
        return {"RUDDER": self.steer(bearing, nav), "THRUST": thrust}
