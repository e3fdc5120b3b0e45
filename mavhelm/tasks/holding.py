"""HoldingPattern: keep a vehicle waiting for an event, either on station or with fixed actuators.

With ``Location`` it keeps station, bang-bang with hysteresis, as a boat waiting for the next
leg (or a human) should: it steers at the station with ``Thrust`` until closer than ``Radius``,
then cuts the thrust (votes THRUST 0 and RUDDER 0) and drifts; once wind or current has carried
it further than ``Radius + Hysteresis`` it drives back. ``<NAME>_ON_STATION`` is posted 1/0
when that changes (and on the first data). It needs NAV_X, NAV_Y and NAV_HEADING.

Without ``Location`` it is the original MOOS ``CHoldingPatternTask``: it votes the given
``Rudder``, ``Thrust`` and ``Elevator`` open loop (e.g. ``Rudder = 15, Thrust = 20`` circles
slowly; ``Thrust = 0`` just waits), needs no navigation and so never starves. That is all the
original did — it had no station keeping — so old missions keep their meaning.

Either way it never completes by itself: it ends on its TimeOut, or when a higher-priority
task takes the actuators it simply loses the vote.
"""

from __future__ import annotations

import math

from mavhelm.core.mission import Block
from mavhelm.core.params import Number, Param, Point
from mavhelm.tasks.base import HEADING, THRUST, NavState, Task, Votes
from mavhelm.tasks.end_mission import RUDDER_DEGREES
from mavhelm.tasks.waypoint import RADIUS

_STATION_ONLY = ("Radius", "Hysteresis")
_OPEN_LOOP_ONLY = ("Rudder", "Elevator")


class HoldingPattern(Task):
    keyword = "HoldingPattern"
    summary = ("waits for an event: with Location keeps station (drive in, drift inside "
               "Radius, drive back beyond Radius + Hysteresis); without it holds Rudder, "
               "Thrust, Elevator open loop; ends on its TimeOut")
    params = (
        Param("Location", Point(), None, "m",
              "the station, x east and y north of the origin; without it the task holds "
              "Rudder/Thrust/Elevator open loop"),
        Param("Radius", RADIUS, 5.0, "m",
              "with Location: thrust is cut closer than this to the station"),
        Param("Hysteresis", Number(0.0, 1000.0), 2.0, "m",
              "with Location: drive back once further than Radius + this"),
        Param("Thrust", THRUST, None, "%",
              "with Location: the thrust to drive back with (required, > 0); without it: "
              "the thrust held"),
        Param("Rudder", RUDDER_DEGREES, None, "deg",
              "without Location only: the rudder held (positive turns clockwise)"),
        Param("Elevator", RUDDER_DEGREES, None, "deg", "without Location only: the elevator held"),
    )
    location: tuple[float, float, float | None] | None
    radius: float
    hysteresis: float
    thrust: float | None
    rudder: float | None
    elevator: float | None

    def check(self, block: Block) -> None:
        if self.location is not None:
            for key in _OPEN_LOOP_ONLY:
                entry = block.entry(key)
                if entry is not None:
                    raise entry.error(f"{key} is for a HoldingPattern without Location (open "
                                      "loop); keeping station, the task steers itself")
            if self.thrust is None:
                raise block.error(f"HoldingPattern task {self.name} keeps station at Location "
                                  "and needs Thrust (%, > 0) to drive back with")
            if self.thrust <= 0:
                raise block.require("Thrust").error(
                    f"Thrust must be > 0 to drive back to the station, got {self.thrust:g}")
            return
        for key in _STATION_ONLY:
            entry = block.entry(key)
            if entry is not None:
                raise entry.error(f"{key} is for keeping station: give Location too")
        if self.rudder is None and self.thrust is None and self.elevator is None:
            raise block.error(f"HoldingPattern task {self.name} needs Location (keep station) "
                              "or at least one of Rudder, Thrust, Elevator (hold them)")

    def needs(self) -> set[str]:
        return set() if self.location is None else {"NAV_X", "NAV_Y", HEADING}

    def initialise(self, now: float) -> None:
        self._driving: bool | None = None

    def distance(self, nav: NavState) -> float:
        assert self.location is not None and nav.x is not None and nav.y is not None
        return math.hypot(self.location[0] - nav.x, self.location[1] - nav.y)

    def update(self, nav: NavState, now: float) -> Votes | None:
        if self.location is None:
            return self._open_loop()
        assert nav.x is not None and nav.y is not None
        d = self.distance(nav)
        if self._driving is False:  # drifting: hysteresis before driving back
            driving = d > self.radius + self.hysteresis
        else:
            driving = d >= self.radius
        if driving != self._driving:
            if driving:
                self.yaw_pid.reset()  # no derivative across the drift
            self._driving = driving
            self.post(f"{self.name}_ON_STATION", 0.0 if driving else 1.0)
        if not driving:
            return {"RUDDER": 0.0, "THRUST": 0.0}
        bearing = math.degrees(math.atan2(self.location[0] - nav.x, self.location[1] - nav.y))
        assert self.thrust is not None
        return {"RUDDER": self.steer(bearing % 360.0, nav), "THRUST": self.thrust}

    def _open_loop(self) -> Votes:
        votes: Votes = {}
        for actuator, value in (("RUDDER", self.rudder), ("THRUST", self.thrust),
                                ("ELEVATOR", self.elevator)):
            if value is not None:
                votes[actuator] = value
        return votes
