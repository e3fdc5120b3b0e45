"""ConstantHeading: hold a compass heading until the task times out."""

from __future__ import annotations

from mavhelm.core.params import Number, Param
from mavhelm.tasks.base import HEADING, NavState, Votes
from mavhelm.tasks.steering import SteeringTask


class ConstantHeading(SteeringTask):
    keyword = "ConstantHeading"
    summary = "holds a compass heading; ends on its TimeOut"
    params = (
        Param("Heading", Number(-360.0, 360.0), unit="deg",
              doc="compass heading to hold, clockwise from true north"),
    )
    heading: float

    def check(self, block) -> None:
        self.heading %= 360.0

    def describe_goal(self) -> str | None:
        return f"heading {self.heading:g} deg"

    def needs(self) -> set[str]:
        return {HEADING}

    def update(self, nav: NavState, now: float) -> Votes | None:
        return self.drive(self.heading, nav)
