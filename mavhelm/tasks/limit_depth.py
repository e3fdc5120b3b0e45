"""LimitDepth: a safety task that drives the vehicle up and fires its EventFlags when it is
deeper than MaximumDepth.

Spec Table 2: "Fires event flag if the vehicle is too deep. A Safety task that is usually run
with timeout=NEVER." Table 1 adds that a depth limit must not quit when it fires: it keeps
running. As the original CLimitDepth, while NAV_DEPTH is beyond the limit it votes full
rising elevator (−MAXELEVATOR); give it the most important priority of the mission's tasks so
that vote wins. Its events follow LimitBox's rule (:class:`~mavhelm.tasks.limit_box.LimitTask`):
once on crossing, then every 10 s while beyond. Chain an EventFlag to EndMission to abort.
It never completes, TimeOut defaults to NEVER, and it starves without NAV_DEPTH.

The original defaulted to priority 0, which the spec reserves for EndMission: here the default
is 1. Its default limit, 50 m, is kept.
"""

from __future__ import annotations

from mavhelm.core.mission import Block
from mavhelm.core.names import NAV_DEPTH
from mavhelm.core.params import Number, Param
from mavhelm.tasks.base import NavState, Votes
from mavhelm.tasks.limit_box import LimitTask


class LimitDepth(LimitTask):
    keyword = "LimitDepth"
    summary = ("safety: beyond MaximumDepth votes full rising elevator and fires its "
               "EventFlags (then every 10 s); never completes")
    params = (
        Param("Priority", Number(1, 1000, integer=True), 1,
              doc="1 (the default) outranks every mission task; 0 is EndMission's"),
        Param("MaximumDepth", Number(0.0, 11_000.0, lo_open=True), 50.0, "m",
              "deepest NAV_DEPTH allowed", attr="maximum_depth"),
    )
    maximum_depth: float

    def check(self, block: Block) -> None:
        """Unlike LimitBox it acts by itself (it rises), so EventFlags are optional."""

    def needs(self) -> set[str]:
        return {NAV_DEPTH}

    def describe_goal(self) -> str | None:
        return f"depth limit {self.maximum_depth:g} m"

    def violations(self, nav: NavState) -> list[str]:
        depth = nav.get(NAV_DEPTH)
        assert depth is not None
        if depth <= self.maximum_depth:
            return []
        return [f"depth {depth:.1f} m is {depth - self.maximum_depth:.1f} m beyond "
                f"MaximumDepth {self.maximum_depth:g}"]

    def update(self, nav: NavState, now: float) -> Votes | None:
        super().update(nav, now)
        if self._ok:
            return None
        return {"ELEVATOR": -self.gains.max_elevator}
