"""How late a message is heard, on the autopilot's clock.

Everything the bridge posts is stamped with the companion's clock when the message is read,
and a link delivers in batches: at ``--speedup 10`` the real SITL's ATTITUDE arrives two at a
time every 0.2 s of vehicle time, the first of each pair 0.1 s old, both stamped alike. A
turn-rate fit on those stamps sees the vehicle jump 0.1 s at a time (17 deg/s of residual at
170 deg/s²). The message's own ``time_boot_ms`` says when the autopilot sent it; the least
late of the recent messages (one read as soon as it was sent) fixes how the two clocks line
up, and each message is heard that much later than it.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

WINDOW_S = 5.0
"""Companion seconds of messages the least late is taken over: many batches, and short
enough that two clocks drifting apart (a crystal's 100 ppm) move it by half a millisecond."""
REBOOT_JUMP_S = 1.0
"""The autopilot's clock going back by more than this is a reboot: the clocks line up anew."""
MAX_LATE_S = 1.0
"""Later than this is not a batch but a stall (or a clock that jumped): not a lateness to
correct a sample by."""


@dataclass
class Lateness:
    """The least (companion stamp − autopilot time) over the last WINDOW_S, kept as a
    monotonic queue: each entry smaller than every later one, the front the least."""

    _queue: deque[tuple[float, float]] = field(default_factory=deque)
    _last_boot: float | None = None

    def heard(self, stamp: float, boot_s: float) -> float:
        """How much later than the least late recent message this one, sent at the
        autopilot's ``boot_s`` and stamped ``stamp``, was heard (s, never below 0)."""
        if self._last_boot is not None and boot_s < self._last_boot - REBOOT_JUMP_S:
            self._queue.clear()
        self._last_boot = boot_s
        offset = stamp - boot_s
        queue = self._queue
        while queue and queue[-1][1] >= offset:
            queue.pop()
        queue.append((stamp, offset))
        while queue[0][0] < stamp - WINDOW_S:
            queue.popleft()
        return offset - queue[0][1]

    def autopilot_time(self, stamp: float) -> float | None:
        """The autopilot's clock at companion stamp ``stamp``, as the least late recent message
        lines the two up (None before any): a message without a time_boot_ms of its own, a
        GPS fix's, is dated by it rather than by the newest clock read in its batch."""
        return stamp - self._queue[0][1] if self._queue else None


def sane(late: float | None) -> float | None:
    """``late`` when it is a lateness to correct a sample by (0 to MAX_LATE_S), else None."""
    return late if late is not None and 0.0 <= late <= MAX_LATE_S else None
