"""ConstantDepth: level flight at a depth until the task times out.

Spec Table 2: "Level Flight. Requires only depth data and pitch data." It votes ELEVATOR from
the depth-by-pitch controller and nothing else, so it runs beside a task that steers and
drives (a TrackLine, a Survey). It never completes; it ends on its TimeOut. The original's
default depth, 0.2 m, is kept.
"""

from __future__ import annotations

from typing import ClassVar

from mavhelm.core.params import Number, Param
from mavhelm.tasks.base import NavState, Votes
from mavhelm.tasks.depth import DepthTask

DEPTH_M = Number(0.0, 11_000.0)
"""A depth below the surface in metres: the deepest ocean at most."""


class ConstantDepth(DepthTask):
    keyword = "ConstantDepth"
    summary = "holds a depth (votes ELEVATOR only); ends on its TimeOut"
    params: ClassVar[tuple[Param, ...]] = (
        Param("Depth", DEPTH_M, 0.2, "m", "depth to hold, metres below the surface"),
    )
    depth: float

    def describe_goal(self) -> str | None:
        return f"depth {self.depth:g} m"

    def target(self) -> float:
        """The depth being held now (ZPattern moves it)."""
        return self.depth

    def update(self, nav: NavState, now: float) -> Votes | None:
        return {"ELEVATOR": self.elevator(self.target(), nav)}
