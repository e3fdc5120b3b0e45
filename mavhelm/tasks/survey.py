"""Survey: mow the lawn over a box, every leg and every turn between legs a track line.

The box is ``A`` metres along the legs by ``B`` across, centred on ``Center``, its legs running
along compass direction ``Rotation``. Legs are ``Spacing`` apart and centred across the box
(``floor(B / Spacing) + 1`` of them; the outer legs lie on its edges when B is a multiple of
Spacing). Leg 0 is the one furthest to port of ``Rotation`` and is flown along ``Rotation``; the
next is one spacing to starboard and flown back the other way, and so on (boustrophedon). The
vehicle first runs a line from where it is when the task goes active to the start of leg 0;
then each leg, and each joining segment from the end of one leg to the start of the next, is
held as a TrackLine (carrot ``Lead`` metres ahead, bounded cross-track integral, see
``trackline``). The turns are planned (``turn_plan``): where half the join is within 0.5–2
Leads (a 20 m join from 5 to 20 m of Lead: at 5 m/s with the default LeadTime), the U-turn from
a leg to the next is one half circle whose diameter is the join, flown beyond the legs' ends
(Spacing / 2 outside the box), so each leg is flown whole, from its start to its end; else each
corner is an arc of one Lead that cuts it. A line is left a turn-in before its corner (where
its arc starts, plus the heading loop's lag run: ``RouteTask.turn_in``), else within 1 m of it
or once past it along the line. The task posts ``<NAME>_LEG``
(index from 0) as each leg begins and ``<NAME>_XTE`` every tick, and completes at the end of
the last leg.

``LegTimeOut``: a leg still being flown after that long is abandoned — ``<NAME>_WARNING`` and the
EventFlags are posted — and the vehicle runs a line from where it is to the start of the next
leg (the last leg abandoned ends the task). Only legs are timed; the approach and the joins are
bounded by the task's TimeOut.
"""

from __future__ import annotations

from mavhelm.core.mission import Block
from mavhelm.core.params import Number, Param, Point, Seconds
from mavhelm.tasks.base import NavState, Votes
from mavhelm.tasks.geometry import Point2, lawnmower
from mavhelm.tasks.trackline import LEAD_PARAMS, RouteTask

EXTENT = Number(0.0, 100_000.0, lo_open=True)
MAX_LEGS = 1000
CAPTURE = 1.0
"""A leg's end (or the next leg's start) counts as reached this close, in metres."""


class Survey(RouteTask):
    keyword = "Survey"
    plans_turns = True
    summary = ("mows the lawn over an A × B box: legs Spacing apart, alternate directions, "
               "joined at the ends, all as track lines; posts <NAME>_LEG; completes after the "
               "last leg")
    params = (
        Param("Center", Point(), unit="m", doc="centre of the box, x east and y north"),
        Param("A", EXTENT, unit="m", doc="length of the box along the legs", attr="a"),
        Param("B", EXTENT, unit="m", doc="width of the box across the legs", attr="b"),
        Param("Spacing", EXTENT, unit="m", doc="distance between legs, at most B"),
        Param("Rotation", Number(-360.0, 360.0), 0.0, "deg",
              "direction of the legs (of leg 0), clockwise from north"),
        *LEAD_PARAMS,
        Param("LegTimeOut", Seconds(), None, "s",
              "a leg flown longer than this is abandoned for the next one (default NEVER: "
              "no limit, as a long leg is not a fault; the original's default is 100 s)",
              attr="leg_timeout"),
    )
    center: tuple[float, float, float | None]
    a: float
    b: float
    spacing: float
    rotation: float
    leg_timeout: float | None

    def check(self, block: Block) -> None:
        where = block.entry("Spacing") or block
        if self.spacing > self.b:
            raise where.error(f"Spacing must be at most B ({self.b:g} m), got {self.spacing:g}")
        if self.b / self.spacing + 1 > MAX_LEGS:
            raise where.error(f"Spacing {self.spacing:g} m across B = {self.b:g} m makes more "
                              f"than {MAX_LEGS} legs")
        self.rotation %= 360.0
        self.legs = lawnmower((self.center[0], self.center[1]), self.a, self.b, self.spacing,
                              self.rotation)

    def target(self, k: int) -> Point2 | None:
        leg, end = divmod(k, 2)
        if leg >= len(self.legs):
            return None
        return self.legs[leg][end]

    def capture_radius(self, k: int) -> float:
        """Every corner is turned in to, a leg's end as well as its start (a U-turn's half
        circle only the lag's run early: it starts at the leg's end)."""
        return max(CAPTURE, self.turn_in(k))

    def begin(self, k: int, now: float) -> None:
        if k % 2 == 1:
            self.post(f"{self.name}_LEG", float(k // 2))

    def update(self, nav: NavState, now: float) -> Votes | None:
        if (self.leg_timeout is not None and self.index % 2 == 1 and self.follower is not None
                and now - self.segment_start_time > self.leg_timeout):
            assert nav.x is not None and nav.y is not None
            leg = self.index // 2
            reason = f"leg {leg} abandoned after {self.leg_timeout:g} s"
            self.post(f"{self.name}_WARNING", reason)
            self.event(reason)
            self.start_line(self.index + 1, (nav.x, nav.y), now)
        return super().update(nav, now)
