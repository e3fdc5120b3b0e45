"""ConstantHeading: hold a compass heading until the task times out."""

from __future__ import annotations

from mavhelm.companion.mission import Block, Entry
from mavhelm.tasks.base import HEADING, NavState, Votes
from mavhelm.tasks.pid import HelmGains
from mavhelm.tasks.steering import SteeringTask


class ConstantHeading(SteeringTask):
    keyword = "ConstantHeading"
    params = ("Heading", *SteeringTask.params)

    def __init__(self, block: Block, gains: HelmGains | None = None) -> None:
        self.heading: float | None = None
        super().__init__(block, gains)

    def set_param(self, key: str, entry: Entry) -> bool:
        if key == "heading":
            self.heading = entry.as_float() % 360.0
            return True
        return super().set_param(key, entry)

    def check(self, block: Block) -> None:
        if self.heading is None:
            raise block.error(f"ConstantHeading task {self.name} needs Heading (degrees)")

    def needs(self) -> set[str]:
        return {HEADING}

    def update(self, nav: NavState, now: float) -> Votes | None:
        assert self.heading is not None
        return self.drive(self.heading, nav)
