"""Ticks that overran their period, told to the operator.

A field engineer whose boat steers late first asks whether the companion keeps up: a tick
(and the idle time after it: logs, telemetry) that takes longer than the period delays the
next one, so the helm's commands and the navigator's estimate go out that much later. The
loop of ``mavhelm run`` hands each tick's start and end to :class:`TickWatch`; one that took
more than ``LATE`` periods is an overrun. The first of a spell is said at once; while they
go on, one line every ``REPORT`` s says how many and the slowest, so a slow companion
computer does not flood the ground station.

Pure logic: the times come from the loop's clock (the wall, or the autopilot's beside a SITL
run faster than real time).
"""

from __future__ import annotations

import math
from typing import Final

LATE: Final = 1.5
"""Periods a tick may take before it is an overrun: the next tick then starts at least half
a period late (the loop does not catch up with a burst of ticks)."""
REPORT: Final = 10.0
"""s between two lines about overruns."""


class TickWatch:
    """``finished(started, ended)`` after each tick; a line for the operator, or None."""

    def __init__(self, period: float) -> None:
        self.period = period
        self.overruns = 0
        """Overruns since the start."""
        self.slowest = 0.0
        """The slowest tick since the start, s."""
        self._unsaid = 0
        self._unsaid_slowest = 0.0
        self._said_at = -math.inf

    def finished(self, started: float, ended: float) -> str | None:
        took = ended - started
        if not took > LATE * self.period:
            return None
        self.overruns += 1
        self.slowest = max(self.slowest, took)
        self._unsaid += 1
        self._unsaid_slowest = max(self._unsaid_slowest, took)
        if ended - self._said_at < REPORT:
            return None
        if self._said_at == -math.inf or ended - self._said_at > 2 * REPORT:
            line = (f"the companion is behind: a tick took {took:.2f} s (period "
                    f"{self.period:.2f} s); commands and estimates go out late")
        else:
            line = (f"the companion is still behind: {self._unsaid} ticks over "
                    f"{LATE * self.period:.2f} s in the last {ended - self._said_at:.0f} s, "
                    f"the slowest {self._unsaid_slowest:.2f} s")
        self._said_at = ended
        self._unsaid, self._unsaid_slowest = 0, 0.0
        return line
