"""LimitBox: a safety task that fires its EventFlags while the vehicle is outside a working box.

Spec Table 2: "Fire event flags if 3D working volume of mission is exceeded. A Safety task
useful for trapping navigation failure." It watches ``NAV_X``/``NAV_Y`` (and ``NAV_DEPTH`` when
``DepthMax`` is given) and votes on nothing: what to do about it is the mission's choice, chained
by the EventFlags (the StartFlag of a GoToWayPoint back inside, or of EndMission). Because it
needs the navigation, it starves (FinishFlags, ``<NAME>_ERROR``) when pNav stops publishing
position for 10 s: that is how it traps a navigation failure.

Events (shared with LimitAltitude, see :class:`LimitTask`): none in the first ``IgnoreTime``
seconds after the task goes active; then once when the vehicle is first seen outside, and again
every 10 s (``EVENT_REPEAT_S``) while it stays outside; coming back inside re-arms it, so the
next excursion fires at once. The value posted on each EventFlag names every limit exceeded and
by how much. ``<NAME>_INSIDE`` is posted 1/0 whenever that changes (and on the first data).
The task never completes; its TimeOut defaults to NEVER here (a safety task that quietly
retires after the usual 100 s would be a trap).

The original MOOS CLimitBox differed in two ways worth knowing when porting a mission: there
``IgnoreTime`` (default 10 s) was a debounce — the vehicle had to stay outside that long before
anything happened — and it also voted thrust 0, rudder 0 and elevator up at priority 0.
"""

from __future__ import annotations

from typing import ClassVar

from mavhelm.core.mission import Block
from mavhelm.core.params import Number, Param, Seconds
from mavhelm.tasks.base import NavState, Task, Votes

EVENT_REPEAT_S = 10.0
"""While a limit stays exceeded, the EventFlags are posted again this often."""

METRES = Number(-100_000.0, 100_000.0)
"""A coordinate of the local frame in metres (the range of a Location)."""


def _m(x: float) -> str:
    return f"{x:.1f}"


class LimitTask(Task):
    """A safety task: watches a condition, posts EventFlags while it is violated, votes nothing.

    A subclass says what it needs and returns from ``violations(nav)`` one phrase per limit
    exceeded (empty when all is well); ``on_state(ok)`` hears every change of that verdict.
    """

    params: ClassVar[tuple[Param, ...]] = (
        Param("TimeOut", Seconds(), None, "s", "the longest the task may watch (default NEVER: "
              "a safety task normally watches the whole mission)", attr="timeout"),
        Param("IgnoreTime", Number(0.0, 3600.0), 0.0, "s",
              "no events in the first seconds after the task goes active (a start outside "
              "the limit, a sensor settling; the original's default is 10 s)",
              attr="ignore_time"),
    )
    ignore_time: float

    def check(self, block: Block) -> None:
        if not self.event_flags:
            raise block.error(
                f"{self.keyword} task {self.name} needs an EventFlag (e.g. the StartFlag of a "
                "task that brings the vehicle back, or EndMission), or exceeding the limit "
                "warns no one"
            )

    def violations(self, nav: NavState) -> list[str]:
        raise NotImplementedError

    def on_state(self, ok: bool) -> None:
        """The verdict changed (or was reached for the first time)."""

    def initialise(self, now: float) -> None:
        self._ok: bool | None = None
        self._last_event: float | None = None

    def update(self, nav: NavState, now: float) -> Votes | None:
        problems = self.violations(nav)
        ok = not problems
        if ok != self._ok:
            self._ok = ok
            self.on_state(ok)
        if ok:
            self._last_event = None
            return None
        assert self.start_time is not None
        if now - self.start_time < self.ignore_time:
            return None
        if self._last_event is None or now - self._last_event >= EVENT_REPEAT_S:
            self._last_event = now
            self.event("; ".join(problems))
        return None


class LimitBox(LimitTask):
    keyword = "LimitBox"
    summary = ("safety: fires its EventFlags when the vehicle leaves the box (then every 10 s "
               "while outside); votes nothing, never completes, starves without NAV_X/NAV_Y")
    params = (
        Param("XMin", METRES, unit="m", doc="west edge of the box (x east of the origin)",
              attr="x_min"),
        Param("XMax", METRES, unit="m", doc="east edge of the box; must exceed XMin",
              attr="x_max"),
        Param("YMin", METRES, unit="m", doc="south edge of the box (y north of the origin)",
              attr="y_min"),
        Param("YMax", METRES, unit="m", doc="north edge of the box; must exceed YMin",
              attr="y_max"),
        Param("DepthMax", Number(0.0, 11_000.0, lo_open=True), None, "m",
              "deepest allowed NAV_DEPTH; without it depth is not watched (nor needed)",
              attr="depth_max"),
    )
    x_min: float
    x_max: float
    y_min: float
    y_max: float
    depth_max: float | None

    def check(self, block: Block) -> None:
        for lo, hi, low, high in (("XMin", "XMax", self.x_min, self.x_max),
                                  ("YMin", "YMax", self.y_min, self.y_max)):
            if not low < high:
                later = max(block.require(lo), block.require(hi), key=lambda e: e.line)
                raise later.error(f"{lo} = {low:g} must be less than {hi} = {high:g}: "
                                  "the box would be empty")
        super().check(block)

    def needs(self) -> set[str]:
        names = {"NAV_X", "NAV_Y"}
        if self.depth_max is not None:
            names.add("NAV_DEPTH")
        return names

    def violations(self, nav: NavState) -> list[str]:
        x, y = nav.x, nav.y
        assert x is not None and y is not None
        out = []
        if x < self.x_min:
            out.append(f"X {_m(x)} m is {_m(self.x_min - x)} m beyond XMin {self.x_min:g}")
        if x > self.x_max:
            out.append(f"X {_m(x)} m is {_m(x - self.x_max)} m beyond XMax {self.x_max:g}")
        if y < self.y_min:
            out.append(f"Y {_m(y)} m is {_m(self.y_min - y)} m beyond YMin {self.y_min:g}")
        if y > self.y_max:
            out.append(f"Y {_m(y)} m is {_m(y - self.y_max)} m beyond YMax {self.y_max:g}")
        if self.depth_max is not None:
            depth = nav.get("NAV_DEPTH")
            assert depth is not None
            if depth > self.depth_max:
                out.append(f"depth {_m(depth)} m is {_m(depth - self.depth_max)} m beyond "
                           f"DepthMax {self.depth_max:g}")
        return out

    def on_state(self, ok: bool) -> None:
        self.post(f"{self.name}_INSIDE", 1.0 if ok else 0.0)
