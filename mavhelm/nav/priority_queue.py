"""pNav priority queues (spec 2.1): which source feeds one ``NAV_*`` output right now.

A queue line such as ``X = GPS @ 2.0 , EKF @ 2.5 ,LSQ @ 5.0 ,`` lists sources best first, each
with the longest silence tolerated before it is presumed dead. The best source that is still
alive wins; when it falls silent the queue falls back to the next, and it "pops" back the moment
the better source speaks again. Pure logic, no bus and no clock: times are passed in.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from mavhelm.core.mission import Entry
from mavhelm.core.params import Kind

MAX_TIMEOUT = 3600.0
DEFAULT_TIMEOUT = 3.0
"""Seconds a source may stay silent when its entry has no ``@timeout`` (the original pNav's)."""

_SOURCE = re.compile(r"[A-Za-z][A-Za-z0-9_]*")


@dataclass(frozen=True)
class Source:
    """One ``NAME @ timeout`` entry: silent longer than ``timeout`` seconds means stale."""

    name: str
    timeout: float


class PriorityQueue:
    """The routing of one NAV key: sources in order of preference, each with a time-out."""

    def __init__(self, key: str, sources: list[Source]) -> None:
        if not sources:
            raise ValueError(f"priority queue {key} has no sources")
        self.key = key
        self.sources = list(sources)
        self._index = {s.name: i for i, s in enumerate(self.sources)}
        self._timeouts = {s.name: s.timeout for s in self.sources}
        self._order = tuple((s.name, s.timeout) for s in self.sources)
        """(name, time-out) best first: what each routed value is checked against."""
        self._last: dict[str, float] = {}
        self._values: dict[str, float] = {}

    @classmethod
    def parse(cls, entry: Entry) -> PriorityQueue:
        """``Key = SRC [@ timeout] , SRC [@ timeout] , …``; errors point at the entry's line."""
        sources: list[Source] = []
        for item in entry.value.split(","):
            item = item.strip()
            if not item:
                continue
            name, at, timeout_text = (part.strip() for part in item.partition("@"))
            if not _SOURCE.fullmatch(name):
                raise entry.error(
                    f"{entry.key}: expected SOURCE @ timeout, got {item!r}"
                    " (sources are separated by commas)"
                )
            name = name.upper()
            if name in (s.name for s in sources):
                raise entry.error(f"{entry.key}: source {name} is listed twice")
            timeout = DEFAULT_TIMEOUT
            if at:
                try:
                    timeout = float(timeout_text)
                except ValueError:
                    timeout = math.nan
                if not (math.isfinite(timeout) and 0 < timeout <= MAX_TIMEOUT):
                    raise entry.error(
                        f"{entry.key}: the timeout of {name} must be seconds in"
                        f" (0, {MAX_TIMEOUT:g}], got {timeout_text!r}"
                    )
            sources.append(Source(name, timeout))
        if not sources:
            raise entry.error(f"{entry.key}: expected at least one SOURCE @ timeout")
        return cls(entry.key.upper(), sources)

    def __contains__(self, source: str) -> bool:
        return source in self._index

    def timeout(self, source: str) -> float:
        return self._timeouts[source]

    def is_fresh(self, source: str, now: float) -> bool:
        """Whether ``source`` delivered within its time-out before ``now``."""
        last = self._last.get(source)
        return last is not None and now - last <= self._timeouts[source]

    def last_value(self, source: str) -> float | None:
        """The latest value ``source`` delivered, fresh or not (for displays and logs)."""
        return self._values.get(source)

    def current_source(self, now: float) -> str | None:
        """The leftmost source that is still alive at ``now``; None when every one is stale."""
        last = self._last
        for name, timeout in self._order:
            t = last.get(name)
            if t is not None and now - t <= timeout:  # is_fresh, inline: once per value routed
                return name
        return None

    def offer(self, source: str, value: float, time: float) -> bool:
        """Record that ``source`` delivered at ``time``; True if its value should be published.

        Published only while every better source is stale at ``time``. A value stamped earlier
        than that source's last one is ignored, so NAV never runs backwards in time.
        """
        if source not in self._index:
            return False
        last = self._last.get(source)
        if last is not None and time < last:
            return False
        self._last[source] = time
        self._values[source] = value
        return self.current_source(time) == source


class QueueSpec(Kind):
    """The schema kind of a priority queue line: parses to a :class:`PriorityQueue`."""

    def describe(self) -> str:
        return (f"SOURCE @ timeout, … best first; timeouts in seconds in (0, {MAX_TIMEOUT:g}],"
                f" default {DEFAULT_TIMEOUT:g}")

    def parse(self, entry: Entry) -> PriorityQueue:
        return PriorityQueue.parse(entry)
