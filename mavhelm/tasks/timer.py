"""Timer (the spec's TimeOut task): wait, then post its FinishFlags; used to sequence others."""

from __future__ import annotations

from mavhelm.core.params import Param, Seconds
from mavhelm.tasks.base import Task


class Timer(Task):
    """Votes on nothing, needs nothing; ends by its TimeOut (cause ``timeout``), as in MOOS."""

    keyword = "Timer"
    summary = "waits, then posts its FinishFlags: a pause between tasks; ends on its TimeOut"
    params = (
        Param("TimeOut",
              Seconds(never=False,
                      never_reason="a Timer with TimeOut = NEVER would never finish"),
              100.0, "s", "how long to wait", attr="timeout"),
    )
