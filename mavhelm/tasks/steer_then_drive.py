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

The pattern reads as XYPattern's: the ``Location`` lines in order, flown 1 + ``Repeat`` times
(``Repeat`` counts the passes after the first; ``FOREVER`` patrols until the TimeOut), a
waypoint reached closer than ``Radius``; successive Locations closer than ``Radius`` are
refused. Unlike XYPattern it steers straight at each waypoint (no track line): the pivot is
what keeps it on the line. The task completes on reaching the last point of the last pass (the
original never completed and ended on its TimeOut). It posts ``<NAME>_WAYPOINT`` (the index of
the waypoint it now heads for, 0 = the first Location line, as XYPattern) and ``<NAME>_PHASE``
(TURN or DRIVE) on each change. Needs NAV_X, NAV_Y and NAV_HEADING.
"""

from __future__ import annotations

import math

from mavhelm.core.geodesy import wrap_degrees
from mavhelm.core.mission import Block
from mavhelm.core.params import Alias, Number, Param, Point, Refused
from mavhelm.tasks.base import HEADING, NavState, Task, Votes
from mavhelm.tasks.waypoint import RADIUS
from mavhelm.tasks.xypattern import Passes, check_pattern

TURN = "TURN"
DRIVE = "DRIVE"


class SteerThenDriveXYPattern(Task):
    keyword = "SteerThenDriveXYPattern"
    summary = ("an XY pattern (1 + Repeat passes) that turns on the spot (THRUST 0) at each "
               "waypoint until the heading error is below HeadingTolerance, then drives; "
               "completes after the last pass; posts <NAME>_WAYPOINT and <NAME>_PHASE")
    params = (
        Param("Location", Point(), [], "m", "a waypoint x,y; one line each, in order (at "
              "least one)", repeat=True, attr="locations"),
        Param("Radius", RADIUS, 5.0, "m", "a waypoint is reached closer than this"),
        Param("Repeat", Passes(), 0, "passes", "passes after the first; FOREVER patrols until "
              "the task's TimeOut"),
        Param("Thrust", Number(0.0, 100.0, lo_open=True), unit="%",
              doc="thrust while driving with the heading error within HeadingTolerance"),
        Param("HeadingTolerance", Number(0.0, 90.0, lo_open=True), 10.0, "deg",
              "turn on the spot until the heading error to the waypoint is below this",
              attr="heading_tolerance", aliases=(Alias("InnerYawLimit"),)),
        Param("OuterYawLimit", Number(0.0, 180.0, lo_open=True), 40.0, "deg",
              "while driving, thrust tapers to 0 as the error grows to this; beyond it, turn "
              "on the spot again; must exceed HeadingTolerance", attr="outer_yaw_limit"),
        Param("ThrustDamping", Refused("mavhelm's thrust follows the heading error directly "
                                       "(tapering to 0 at OuterYawLimit), with no first-order "
                                       "filter"), None, attr="thrust_damping"),
    )
    locations: list[tuple[float, float, float | None]]
    radius: float
    repeat: int | None
    thrust: float
    heading_tolerance: float
    outer_yaw_limit: float

    def check(self, block: Block) -> None:
        check_pattern(self, block)
        if not self.outer_yaw_limit > self.heading_tolerance:
            given = [e for e in (block.entry("OuterYawLimit"), block.entry("HeadingTolerance"))
                     if e is not None]
            where = max(given, key=lambda e: e.line)
            raise where.error(f"OuterYawLimit = {self.outer_yaw_limit:g} must exceed "
                              f"HeadingTolerance = {self.heading_tolerance:g}")

    def needs(self) -> set[str]:
        return {"NAV_X", "NAV_Y", HEADING}

    def initialise(self, now: float) -> None:
        self.leg = 0
        """Waypoints reached so far: the goal is Location number leg % count."""
        self.phase: str | None = None
        self._announce()

    def _announce(self) -> None:
        self.post(f"{self.name}_WAYPOINT", float(self.leg % len(self.locations)))

    def _set_phase(self, phase: str) -> None:
        if phase != self.phase:
            self.phase = phase
            self.post(f"{self.name}_PHASE", phase)

    @property
    def goal(self) -> tuple[float, float]:
        x, y, _ = self.locations[self.leg % len(self.locations)]
        return x, y

    def _advance(self) -> bool:
        """Move to the next waypoint; False when the last one of the last pass is done."""
        n = len(self.locations)
        if self.repeat is not None and self.leg + 1 >= n * (1 + self.repeat):
            return False
        self.leg += 1
        self.yaw_pid.reset()  # a new bearing is a step, not a rate of change
        self._set_phase(TURN)
        self._announce()
        return True

    def update(self, nav: NavState, now: float) -> Votes | None:
        assert nav.x is not None and nav.y is not None and nav.heading is not None
        if math.hypot(self.goal[0] - nav.x, self.goal[1] - nav.y) < self.radius:
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
