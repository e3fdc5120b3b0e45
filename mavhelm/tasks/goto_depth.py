"""GoToDepth: go to a depth and end there.

Spec Table 2: "Spiral to a given depth and exit. Requires Pitch and Depth data." It is
ConstantDepth that completes once NAV_DEPTH is within ``Tolerance`` of ``Depth``; with a
``Rudder`` (a fixed rudder angle) and a ``Thrust`` it also votes those, which is what makes
the descent a spiral. The original's default tolerance, 3.14 m, is kept.
"""

from __future__ import annotations

from mavhelm.core.params import Number, Param
from mavhelm.tasks.base import THRUST, NavState, Votes
from mavhelm.tasks.constant_depth import ConstantDepth

RUDDER_DEGREES = Number(-90.0, 90.0)


class GoToDepth(ConstantDepth):
    keyword = "GoToDepth"
    summary = ("goes to Depth (with an optional fixed Rudder and Thrust: a spiral); completes "
               "within Tolerance of it")
    params = (
        Param("Tolerance", Number(0.01, 1000.0), 3.14, "m",
              "the task completes when the depth is this close to Depth"),
        Param("Rudder", RUDDER_DEGREES, None, "deg",
              "rudder held on the way down; without it the task does not steer"),
        Param("Thrust", THRUST, None, "%", "thrust on the way down; without it none is voted"),
    )
    tolerance: float
    rudder: float | None
    thrust: float | None

    def describe_goal(self) -> str | None:
        return f"down to {self.depth:g} m within {self.tolerance:g} m"

    def update(self, nav: NavState, now: float) -> Votes | None:
        if abs(self.depth_error(nav, self.depth)) < self.tolerance:
            self.complete()
            return None
        votes = super().update(nav, now) or {}
        if self.rudder is not None:
            votes["RUDDER"] = self.rudder
        if self.thrust is not None:
            votes["THRUST"] = self.thrust
        return votes
