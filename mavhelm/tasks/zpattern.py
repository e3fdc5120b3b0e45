"""ZPattern: a series of depth set points between MinDepth and MaxDepth.

Spec Table 2: "Performs a series of depth set points. Requires depth and pitch data. For
example combining this with an orbit task will execute a helical pattern." As the original
CZPatternTask: it first goes to ``MinDepth``; a set point counts as reached within
``Tolerance``. ``Pattern = YOYO`` then turns at once between MinDepth and MaxDepth; ``SQUARE``
levels off at each for ``LevelTime`` seconds first. It votes ELEVATOR (and THRUST if given)
and never completes: it ends on its TimeOut.
"""

from __future__ import annotations

from mavhelm.core.mission import Block
from mavhelm.core.params import Choice, Number, Param
from mavhelm.tasks.base import THRUST, NavState, Votes
from mavhelm.tasks.constant_depth import DEPTH_M
from mavhelm.tasks.depth import DepthTask


class ZPattern(DepthTask):
    keyword = "ZPattern"
    summary = ("depth set points: YOYO between MinDepth and MaxDepth, or SQUARE (levelling "
               "LevelTime at each); ends on its TimeOut")
    params = (
        Param("Pattern", Choice(("YOYO", "SQUARE")), doc="YOYO turns at each depth at once; "
              "SQUARE holds each for LevelTime"),
        Param("MinDepth", DEPTH_M, 1.0, "m", "the shallow set point (the first)",
              attr="min_depth"),
        Param("MaxDepth", DEPTH_M, 1.0, "m", "the deep set point; not less than MinDepth",
              attr="max_depth"),
        Param("Tolerance", Number(0.01, 1000.0), 0.3, "m", "a set point is reached this close"),
        Param("LevelTime", Number(0.0, 86_400.0), 20.0, "s",
              "SQUARE: how long each depth is held", attr="level_time"),
        Param("Thrust", THRUST, None, "%", "thrust while the task runs; without it none"),
    )
    pattern: str
    min_depth: float
    max_depth: float
    tolerance: float
    level_time: float
    thrust: float | None

    def check(self, block: Block) -> None:
        if self.max_depth < self.min_depth:
            entry = block.entry("MaxDepth") or block.entry("MinDepth") or block
            raise entry.error(f"MaxDepth = {self.max_depth:g} is shallower than MinDepth = "
                              f"{self.min_depth:g}")

    def initialise(self, now: float) -> None:
        self.goal = self.min_depth
        self.level_since: float | None = None

    def describe_goal(self) -> str | None:
        return f"{self.pattern.lower()} {self.min_depth:g}-{self.max_depth:g} m"

    def _other(self) -> float:
        return self.max_depth if self.goal == self.min_depth else self.min_depth

    def _next_set_point(self, nav: NavState, now: float) -> None:
        if abs(self.depth_error(nav, self.goal)) > self.tolerance:
            return
        if self.pattern == "YOYO":
            self.goal = self._other()
            return
        if self.level_since is None:
            self.level_since = now
        elif now - self.level_since >= self.level_time:
            self.goal = self._other()
            self.level_since = None

    def update(self, nav: NavState, now: float) -> Votes | None:
        self._next_set_point(nav, now)
        votes: Votes = {"ELEVATOR": self.elevator(self.goal, nav)}
        if self.thrust is not None:
            votes["THRUST"] = self.thrust
        return votes
