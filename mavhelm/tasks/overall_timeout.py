"""OverallTimeOut: the mission's last-resort clock; its FinishFlags usually start EndMission."""

from __future__ import annotations

from mavhelm.companion.mission import Block, Entry
from mavhelm.tasks.base import Task
from mavhelm.tasks.pid import HelmGains


class OverallTimeOut(Task):
    """On from the mission start, never starves, ends only by timing out.

    TimeOut must be written out (a silent 100 s default would end a real mission early) and
    FinishFlags are required, because timing out is this task's only effect.
    """

    keyword = "OverallTimeOut"
    default_initial_on = True

    def __init__(self, block: Block, gains: HelmGains | None = None) -> None:
        self._timeout_given = False
        super().__init__(block, gains)

    def parse_timeout(self, entry: Entry) -> float | None:
        timeout = super().parse_timeout(entry)
        if timeout is None:
            raise entry.error("an OverallTimeOut with TimeOut = NEVER would never end the mission")
        self._timeout_given = True
        return timeout

    def check(self, block: Block) -> None:
        if not self._timeout_given:
            raise block.error(f"OverallTimeOut task {self.name} needs TimeOut (seconds)")
        if not self.finish_flags:
            raise block.error(
                f"OverallTimeOut task {self.name} needs a FinishFlag (e.g. the EndMission "
                "task's StartFlag), or timing out does nothing"
            )
