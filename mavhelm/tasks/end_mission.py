"""EndMission: priority 0, holds every actuator at its end value and locks out all other tasks."""

from __future__ import annotations

from mavhelm.companion.mission import Block, Entry
from mavhelm.tasks.base import NavState, Task, Votes
from mavhelm.tasks.pid import HelmGains


class EndMission(Task):
    """Never starves, never times out, never completes: the mission is over."""

    keyword = "EndMission"
    default_priority = 0
    default_timeout = None
    params = ("EndRudder", "EndThrust", "EndElevator")

    def __init__(self, block: Block, gains: HelmGains | None = None) -> None:
        self.end_votes: Votes = {"RUDDER": 0.0, "THRUST": 0.0, "ELEVATOR": 0.0}
        super().__init__(block, gains)

    def set_param(self, key: str, entry: Entry) -> bool:
        actuator = {"endrudder": "RUDDER", "endthrust": "THRUST", "endelevator": "ELEVATOR"}.get(
            key
        )
        if actuator is None:
            return False
        self.end_votes[actuator] = entry.as_float()
        return True

    def parse_timeout(self, entry: Entry) -> float | None:
        if entry.value.strip().upper() != "NEVER":
            raise entry.error("EndMission never times out; remove TimeOut or write NEVER")
        return None

    def parse_priority(self, entry: Entry) -> int:
        if entry.value.strip() not in ("0", "0.0"):
            raise entry.error(f"EndMission always has priority 0, got {entry.value}")
        return 0

    def update(self, nav: NavState, now: float) -> Votes | None:
        return dict(self.end_votes)
