"""Reconnect back-off: wait ``first_s``, doubling to ``max_s``, between attempts.

A link or instrument that fails to open is retried without ever blocking the tick: the caller
asks ``due(now)`` each tick, calls ``failed(now)`` after a failed attempt and ``succeeded()``
after a good one. One object, so the autopilot link, the serial instruments and the simulator's
truth feed all retry the same way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field


@dataclass
class Backoff:
    """Retry timing for one resource; times are seconds on the caller's clock."""

    first_s: float = 1.0
    max_s: float = 8.0
    delay_s: float = field(init=False)
    next_at: float = field(init=False, default=-math.inf)

    def __post_init__(self) -> None:
        if not (0.0 < self.first_s <= self.max_s and math.isfinite(self.max_s)):
            raise ValueError(f"backoff needs 0 < first_s <= max_s, got {self.first_s}, "
                             f"{self.max_s}")
        self.delay_s = self.first_s

    def due(self, now: float) -> bool:
        """True when the next attempt may be made."""
        return now >= self.next_at

    def wait_s(self, now: float) -> float:
        """Seconds until the next attempt (0 if it is due)."""
        return max(0.0, self.next_at - now)

    def failed(self, now: float) -> float:
        """An attempt failed at ``now``: schedule the next one; returns the wait chosen."""
        wait = self.delay_s
        self.next_at = now + wait
        self.delay_s = min(self.max_s, self.delay_s * 2.0)
        return wait

    def succeeded(self) -> None:
        """It worked: the next failure starts again from ``first_s``."""
        self.delay_s = self.first_s
        self.next_at = -math.inf

    def describe(self) -> str:
        return f"retrying every {self.first_s:g}-{self.max_s:g} s"
