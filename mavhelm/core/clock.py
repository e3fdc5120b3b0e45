"""One source of time for every app.

No app reads the system clock itself: on the vehicle the clock is the wall clock, in the
simulator and the tests it is a simulated clock advanced in lockstep, so a one-hour mission
can run in seconds and every run is repeatable.
"""

from __future__ import annotations

import time
from typing import Protocol


class Clock(Protocol):
    def now(self) -> float: ...


class WallClock:
    """Seconds since the Unix epoch, as MOOS time stamps are."""

    def now(self) -> float:
        return time.time()

    def sleep_until(self, t: float) -> None:
        delay = t - time.time()
        if delay > 0:
            time.sleep(delay)


class SimClock:
    """A clock that only moves when told to (lockstep simulation)."""

    def __init__(self, start: float = 0.0) -> None:
        self._t = float(start)

    def now(self) -> float:
        return self._t

    def advance(self, dt: float) -> float:
        if dt < 0:
            raise ValueError("a simulated clock cannot run backwards")
        self._t += dt
        return self._t

    def set(self, t: float) -> None:
        if t < self._t:
            raise ValueError("a simulated clock cannot run backwards")
        self._t = t
