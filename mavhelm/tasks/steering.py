"""The base of tasks that drive the vehicle: steer to a heading and, if given a Thrust, drive.

ConstantHeading and GoToWayPoint are both this with a different way of choosing the heading;
so are the track-following tasks of the spec (TrackLine, Orbit, XYPattern, Survey).
"""

from __future__ import annotations

from typing import ClassVar

from mavhelm.core.params import Param
from mavhelm.tasks.base import THRUST, NavState, Task, Votes


class SteeringTask(Task):
    params: ClassVar[tuple[Param, ...]] = (
        Param("Thrust", THRUST, None, "%",
              "thrust vote while the task runs; without it the task steers only"),
    )
    thrust: float | None

    def drive(self, heading: float, nav: NavState) -> Votes:
        """Votes for RUDDER towards ``heading`` (degrees) and, if the task has one, THRUST."""
        votes: Votes = {"RUDDER": self.steer(heading, nav)}
        if self.thrust is not None:
            votes["THRUST"] = self.thrust
        return votes
