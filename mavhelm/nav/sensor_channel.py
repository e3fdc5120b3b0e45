"""Consensus outlier rejection on one sensor channel (spec 2.2.6, ``LSQ_REJECTION``).

The LSQ has no prior to test a range against, so it tests each channel (one beacon heard by
one sensor) against its own recent history: sensor noise is fast, vehicle motion — and hence
good data — is slow, so over a short window good values lie near a straight line in time.
The line with the largest consensus (most points within ``tolerance``) among the lines through
every pair of recent points is taken as the truth; a new value further than ``tolerance`` from
it is an outlier. Exhaustive over pairs (a window of 8 is 28 lines), which for the window
sizes used is cheaper and more repeatable than random sampling. Written by hand: the robust
fitters at hand (scikit-learn's RANSAC) are random, heavyweight, and answer a batch, not "is
this next point on the line?".
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any, ClassVar

from mavhelm.core.mission import Entry
from mavhelm.core.params import Kind, Number, Param


@dataclass(frozen=True)
class RejectionRule:
    """``LSQ_REJECTION = sensor @ points, tolerance``: the sensor's channels are tested over
    the last ``points`` values with ``tolerance`` in the sensor's unit (s for LBL, m for
    RANGE)."""

    sensor: str
    points: int
    tolerance: float


@dataclass(frozen=True)
class RejectionLine(Kind):
    label: ClassVar[str] = "sensor @ points, tolerance"

    def describe(self) -> str:
        return ("sensor name @ points (3–50), tolerance (the sensor's unit); or as the "
                "original, sensor : History = points, Fail = tolerance")

    def check_value(self, value: Any) -> bool:
        return isinstance(value, RejectionRule)

    def parse(self, entry: Entry) -> RejectionRule:
        if "@" not in entry.value and ":" in entry.value:
            return self._original(entry)
        sensor, at, rest = (p.strip() for p in entry.value.partition("@"))
        parts = rest.split(",")
        if not at or not sensor or len(parts) != 2:
            raise entry.error(f"{entry.key} expects {self.describe()}, got {entry.value!r}")
        points = Number(3, 50, integer=True).parse_text(parts[0], entry, f"{entry.key} points")
        tolerance = Number(0.0, 1e4, lo_open=True).parse_text(parts[1], entry,
                                                              f"{entry.key} tolerance")
        return RejectionRule(sensor, int(points), tolerance)

    def _original(self, entry: Entry) -> RejectionRule:
        """The original pNav's ``sensor : History = n, Fail = x`` (keys in any order)."""
        sensor, _, rest = (p.strip() for p in entry.value.partition(":"))
        given: dict[str, str] = {}
        for item in rest.split(","):
            key, eq, value = (p.strip() for p in item.partition("="))
            if not eq or key.upper() not in ("HISTORY", "FAIL") or key.upper() in given:
                raise entry.error(f"{entry.key} expects {self.describe()}, got "
                                  f"{entry.value!r}")
            given[key.upper()] = value
        if not sensor or set(given) != {"HISTORY", "FAIL"}:
            raise entry.error(f"{entry.key} expects {self.describe()}, got {entry.value!r}")
        return self.parse(Entry(entry.key, f"{sensor} @ {given['HISTORY']}, {given['FAIL']}",
                                entry.file, entry.line))


LSQ_REJECTION = Param("LSQ_REJECTION", RejectionLine(), [], repeat=True, attr="lsq_rejection",
                      doc="consensus outlier rejection on a ranging sensor's channels "
                      "(spec 2.2.6)")


class SensorChannel:
    """The recent history of one channel; ``test(t, value)`` says whether a new value agrees
    with the consensus line (True: keep it). Every value joins the history either way, so a
    real step change (a new beacon geometry) is accepted once it is the consensus."""

    def __init__(self, points: int, tolerance: float) -> None:
        self.tolerance = tolerance
        self._history: deque[tuple[float, float]] = deque(maxlen=points)
        self.rejected = 0

    def test(self, t: float, value: float) -> bool:
        history = list(self._history)
        self._history.append((t, value))
        if len(history) < 3:
            return True
        best_votes, best_miss = -1, math.inf
        for i in range(len(history)):
            t1, v1 = history[i]
            for t2, v2 in history[i + 1:]:
                if t2 == t1:
                    continue
                slope = (v2 - v1) / (t2 - t1)
                votes = sum(abs(v1 + slope * (tk - t1) - vk) <= self.tolerance
                            for tk, vk in history)
                miss = abs(v1 + slope * (t - t1) - value)
                if votes > best_votes or (votes == best_votes and miss < best_miss):
                    best_votes, best_miss = votes, miss
        if best_votes < 2 or best_votes * 2 < len(history):
            return True  # no consensus yet: nothing to judge by
        if best_miss > self.tolerance:
            self.rejected += 1
            return False
        return True
