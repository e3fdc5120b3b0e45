"""OverallTimeOut: the mission's last-resort clock; its FinishFlags usually start EndMission."""

from __future__ import annotations

from mavhelm.core.mission import Block
from mavhelm.core.params import Choice, Param, Seconds
from mavhelm.tasks.base import Task


class OverallTimeOut(Task):
    """On from the mission start, never starves, ends only by timing out.

    TimeOut must be written out (a silent 100 s default would end a real mission early) and
    FinishFlags are required, because timing out is this task's only effect.
    """

    keyword = "OverallTimeOut"
    summary = "limits the whole mission: on from the start, ends only by timing out"
    params = (
        Param("TimeOut",
              Seconds(never=False, never_reason="an OverallTimeOut with TimeOut = NEVER "
                                                "would never end the mission"),
              unit="s", doc="the whole mission's limit", attr="timeout"),
        Param("InitialState", Choice(("ON", "OFF")), "ON", attr="initial_state",
              doc="ON: the clock runs from the mission start"),
        Param("TimeOutClock", Choice(("ONLINE", "ALWAYS")), "ALWAYS", attr="timeout_clock",
              doc="ALWAYS: the mission's limit counts time in MANUAL too"),
    )

    def check(self, block: Block) -> None:
        if not self.finish_flags:
            raise block.error(
                f"OverallTimeOut task {self.name} needs a FinishFlag (e.g. the EndMission "
                "task's StartFlag), or timing out does nothing"
            )
