"""The base of tasks that drive the vehicle: steer to a heading and, if given a Thrust, drive.

ConstantHeading and GoToWayPoint are both this with a different way of choosing the heading;
so are the track-following tasks of the spec (TrackLine, Orbit, XYPattern, Survey).
"""

from __future__ import annotations

from mavhelm.companion.mission import Block, Entry
from mavhelm.tasks.base import NavState, Task, Votes, parse_thrust
from mavhelm.tasks.pid import HelmGains


class SteeringTask(Task):
    params = ("Thrust",)

    def __init__(self, block: Block, gains: HelmGains | None = None) -> None:
        self.thrust: float | None = None
        super().__init__(block, gains)

    def set_param(self, key: str, entry: Entry) -> bool:
        if key == "thrust":
            self.thrust = parse_thrust(entry)
            return True
        return False

    def drive(self, heading: float, nav: NavState) -> Votes:
        """Votes for RUDDER towards ``heading`` (degrees) and, if the task has one, THRUST."""
        votes: Votes = {"RUDDER": self.steer(heading, nav)}
        if self.thrust is not None:
            votes["THRUST"] = self.thrust
        return votes
