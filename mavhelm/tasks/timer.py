"""Timer (the spec's TimeOut task): wait, then post its FinishFlags; used to sequence others."""

from __future__ import annotations

from mavhelm.companion.mission import Block, Entry
from mavhelm.tasks.base import NavState, Task, Votes


class Timer(Task):
    """Completes (cause ``complete``) when its TimeOut has elapsed: waiting is its goal."""

    keyword = "Timer"

    def parse_timeout(self, entry: Entry) -> float | None:
        timeout = super().parse_timeout(entry)
        if timeout is None:
            raise entry.error("a Timer with TimeOut = NEVER would never finish")
        return timeout

    def check(self, block: Block) -> None:
        assert self.timeout is not None
        self.duration: float = self.timeout
        self.timeout = None

    def update(self, nav: NavState, now: float) -> Votes | None:
        assert self.start_time is not None
        if now - self.start_time >= self.duration:
            self.complete()
        return None
