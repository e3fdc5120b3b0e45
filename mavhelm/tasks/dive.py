"""DiveTask: dive from the surface, ahead or astern, and end at the depth.

Spec Table 2: "Dive from surface (e.g reverse dive)." As the original CDiveTask, it votes
THRUST, RUDDER and ELEVATOR together:

- ``Mode = NORMAL`` (default): the depth-by-pitch controller drives to ``Depth`` under
  ``Thrust`` ahead; the task completes once the vehicle is deeper than ``Depth``.
- ``REVERSE``: the same astern (thrust negated, the controller reversed: a vehicle going
  backwards pitches the other way for the same elevator).
- ``CHUCK``: an open-loop reverse dive — fixed ``Elevator`` until ``Depth`` (or 70 % of the
  TimeOut), then the opposite elevator until the nose is down (pitch below zero), then
  complete; deeper than 3 m on the way it stops at once, as the original did.

The original's defaults are kept: Depth 3 m, Elevator 2°, Rudder 0, Thrust 20 %, TimeOut 60 s.
"""

from __future__ import annotations

from mavhelm.core.names import NAV_DEPTH, NAV_PITCH
from mavhelm.core.params import Choice, Number, Param, Seconds
from mavhelm.tasks.base import THRUST, NavState, Votes
from mavhelm.tasks.constant_depth import DEPTH_M
from mavhelm.tasks.depth import DepthTask

CHUCK_DIVE_MAX = 3.0
"""Metres: an open-loop CHUCK dive deeper than this has gone wrong and stops."""
CHUCK_LEVEL_FRACTION = 0.7
"""A CHUCK dive starts levelling off after this fraction of its TimeOut at the latest."""
ANGLE = Number(-90.0, 90.0)


class DiveTask(DepthTask):
    keyword = "DiveTask"
    summary = ("dives from the surface ahead, astern (REVERSE) or open loop (CHUCK); "
               "completes at Depth")
    params = (
        Param("Mode", Choice(("NORMAL", "REVERSE", "CHUCK")), "NORMAL",
              doc="NORMAL ahead under control; REVERSE astern; CHUCK open-loop astern"),
        Param("Depth", DEPTH_M, 3.0, "m", "the dive ends deeper than this"),
        Param("Elevator", ANGLE, 2.0, "deg", "CHUCK: the fixed elevator of the dive",
              attr="elevator_setting"),
        Param("Rudder", ANGLE, 0.0, "deg", "rudder held during the dive"),
        Param("Thrust", THRUST, 20.0, "%", "thrust magnitude (astern in REVERSE and CHUCK)"),
        Param("TimeOut", Seconds(), 60.0, "s", "the longest the dive may take", attr="timeout"),
    )
    mode: str
    depth: float
    elevator_setting: float
    rudder: float
    thrust: float

    @property
    def reversing(self) -> bool:  # type: ignore[override]
        return self.mode != "NORMAL"

    def describe_goal(self) -> str | None:
        return f"{self.mode.lower()} dive to {self.depth:g} m"

    def _chuck(self, nav: NavState, now: float) -> float | None:
        depth, pitch = nav.get(NAV_DEPTH), nav.get(NAV_PITCH)
        assert depth is not None and pitch is not None
        if depth > CHUCK_DIVE_MAX:
            self.complete()
            return None
        levelling_at = CHUCK_LEVEL_FRACTION * (self.timeout or 0.0)
        if depth < self.depth and (self.timeout is None or self.elapsed(now) < levelling_at):
            return self.elevator_setting
        if pitch < 0.0:
            self.complete()
            return None
        return -self.elevator_setting

    def update(self, nav: NavState, now: float) -> Votes | None:
        if self.mode == "CHUCK":
            elevator = self._chuck(nav, now)
        elif self.depth_error(nav, self.depth) < 0.0:
            self.complete()
            elevator = None
        else:
            elevator = self.elevator(self.depth, nav)
        if elevator is None:
            return None
        sign = -1.0 if self.reversing else 1.0
        return {"THRUST": sign * self.thrust, "RUDDER": self.rudder, "ELEVATOR": elevator}
