"""Timer (the spec's TimeOut task): wait, then post its FinishFlags; used to sequence others."""

from __future__ import annotations

from mavhelm.companion.mission import Entry
from mavhelm.tasks.base import Task


class Timer(Task):
    """Votes on nothing, needs nothing; ends by its TimeOut (cause ``timeout``), as in MOOS."""

    keyword = "Timer"

    def parse_timeout(self, entry: Entry) -> float | None:
        timeout = super().parse_timeout(entry)
        if timeout is None:
            raise entry.error("a Timer with TimeOut = NEVER would never finish")
        return timeout
