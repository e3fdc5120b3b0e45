"""One source of time for every app.

No app reads the system clock itself: on the vehicle the clock is the wall clock, in the
simulator and the tests it is a simulated clock advanced in lockstep, so a one-hour mission
can run in seconds and every run is repeatable.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Protocol

BOOT_MS_WRAP = 1 << 32
"""MAVLink's ``time_boot_ms`` is a uint32: it wraps after 49.7 days."""


def boot_ms(elapsed_s: float) -> int:
    """Seconds since boot as a ``time_boot_ms`` field: whole milliseconds, never negative,
    wrapped to uint32 as the autopilot's own counter wraps."""
    return int(max(0.0, elapsed_s) * 1000) % BOOT_MS_WRAP


def boot_seconds(time_boot_ms: int) -> float:
    """A received ``time_boot_ms`` in seconds (the autopilot clock's feed)."""
    return time_boot_ms / 1000.0


class Clock(Protocol):
    def now(self) -> float: ...


class PacedClock(Clock, Protocol):
    """A clock a loop can wait on: the wall's, or the autopilot's."""

    def sleep_until(self, t: float) -> None: ...


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


class AutopilotClock:
    """Time as the autopilot counts it: MOOS's time warp, measured instead of configured.

    A SITL run with ``--speedup 20`` (or a slowed-down one on a loaded machine) lives on its
    own clock, which it stamps on every message as ``time_boot_ms``; a companion paced by the
    wall clock would see 3 s GUIDED time-outs pass in 0.15 s. This clock is fed those stamps
    (``observe``) and between them runs at the rate the autopilot has been running, so tick
    periods, task time-outs and link time-outs are all in autopilot seconds. If the autopilot
    falls silent the clock keeps going at the last rate, so the link time-out still fires; if
    it reboots (its stamps jump back), the clock carries on without running backwards.
    ``now()`` starts at the wall-clock epoch, so logs carry a real date.
    """

    WINDOW_S = 2.0
    """Wall seconds of observations the rate is measured over."""
    MIN_SPAN_S = 0.2
    """Wall seconds of stamps the rate is first measured over."""
    BATCH_S = 0.005
    """Stamps read within this many wall seconds of each other came in one read."""
    MAX_WAIT_S = 0.5
    """Wall seconds one wait lasts at most, whatever the rate: a rate measured far too low
    (the autopilot paused a moment) must not keep the companion from its link for long."""

    def __init__(self, wall: Callable[[], float] = time.monotonic,
                 epoch: float | None = None) -> None:
        self._wall = wall
        start = wall()
        self._t_obs = time.time() if epoch is None else float(epoch)
        self._wall_obs = start
        self._boot_offset: float | None = None
        self._newest_boot: float | None = None
        self._samples: list[tuple[float, float]] = []
        self.warp = 1.0
        self.rate_known = False
        """False until the rate has been measured over ``MIN_SPAN_S`` wall seconds of stamps."""
        self._last_now = self._t_obs

    def now(self) -> float:
        t = self._t_obs + self.warp * (self._wall() - self._wall_obs)
        self._last_now = max(self._last_now, t)
        return self._last_now

    def observe(self, boot_s: float) -> None:
        """The autopilot's ``time_boot_ms`` / 1000 from a message just received.

        A read brings a batch, and a companion that stalled (a loaded machine, a slow first
        tick) reads seconds of stamps at once, all of them late but the newest. So the rate
        is measured on the moments a newer stamp was first heard, a read counting once, by
        its newest stamp: those are late by one read's interval at most. Measured on every
        stamp, a backlog read 0.2 s before fresh ones made a 10x SITL look 100x: the clock
        ran tens of autopilot seconds ahead between two reads."""
        wall = self._wall()
        if self._boot_offset is None or (self._newest_boot is not None
                                         and boot_s < self._newest_boot - 1.0):
            self._boot_offset = self.now() - boot_s  # first stamp, or the autopilot rebooted
            self._samples = []
            self._newest_boot = None
        if self._newest_boot is not None and boot_s <= self._newest_boot:
            return
        self._newest_boot = boot_s
        self._t_obs = boot_s + self._boot_offset
        self._wall_obs = wall
        samples = self._samples
        if samples and wall - samples[-1][0] < self.BATCH_S:
            samples[-1] = (samples[-1][0], boot_s)
        else:
            samples.append((wall, boot_s))
        while wall - samples[0][0] > self.WINDOW_S:
            samples.pop(0)
        first_wall, first_boot = samples[0]
        if wall - first_wall >= self.MIN_SPAN_S:
            self.warp = min(1000.0, max(0.01, (boot_s - first_boot) / (wall - first_wall)))
            self.rate_known = True

    def sleep_until(self, t: float) -> None:
        """Sleep the wall time the autopilot needs to reach ``t`` at its measured rate, once.
        Not "until now() reads t": a clock that ran ahead of the autopilot (its rate
        overestimated from a burst of backlog read at start-up) stands still until the
        stamps catch up, and waiting on it would stop the very reading that corrects it
        (the helm would go online late)."""
        ahead = t - self.now()
        if ahead > 0:
            # until the rate is measured, poll: at an assumed 1x a SITL running at 20x
            # would be read two autopilot seconds at a time, an operator's mode change
            # answered a second late
            wait = ahead / self.warp if self.rate_known else min(ahead, 0.01)
            time.sleep(min(wait, self.MAX_WAIT_S))
