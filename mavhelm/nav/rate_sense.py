"""Whether a body velocity sensor's yaw rate turns the way the headings do.

A yaw rate of the wrong sense is a wiring fault no bias or scale state can learn (linearised
about +1, a scale of −1 is out of reach): a gyro mounted upside down, or, most often, a
NED gyro's or MAVLink's clockwise-positive rate given where pNav's yaw rate is
anticlockwise-positive like its yaw. Fused, it fights every heading reading in every turn.
Plaza1 with its odometry's rate negated: NAV 7.76 m RMS, 290 decisions, none of them naming
the cause.

So every heading reading is compared with the turn each rate sensor integrated since the
heading sensor's previous reading. An interval votes where the vehicle clearly turns (the
heading at least ``MIN_STEP`` round, the rate's turn at least ``MIN_RATE`` times the
interval): it agrees if both turn the same way. ``CONTRARY`` of the last ``VOTES`` votes
against: that sensor's rate is reversed, and :class:`mavhelm.nav.fusion.Fusion` takes it
negated, says so, and forgets what it taught the filter. Votes go on with the rate as read,
so one that agrees again is taken as it reads again.

Which of the two is wrong the headings and rates alone cannot tell: the owner asks the motion
(:meth:`mavhelm.nav.fusion.Fusion._test_sense`) and takes neither meanwhile, then either
keeps the rate negated or forgives it (``forgive``) and reads the heading the other way
round. Negated rather than left out once told: the rate is what tells a heading jump from a
turn (Plaza1 with heading jumps and the rate reversed, seeds 1-2: 3.01/2.75 m RMS with the
rate left out, 0.42/0.49 m with it negated; jumps alone 0.34/0.35 m).

Short intervals (one heading reading to the next) and clear turns only: a heading bias that
wanders (even 180° within minutes: ~1°/s) moves a heading less in one interval than a turn
of ``MIN_RATE`` does; a stuck heading does not move, so it does not vote; a jump is one
vote among ``VOTES``.

Pure logic: the owner calls ``rate`` and ``heading`` with each reading in time order;
``reversed`` holds the rate sensors to be negated.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Final

MIN_RATE: Final = math.radians(3.0)
"""rad/s: a turn slower than this over an interval is not a clear one (a still or cruising
vehicle's noise)."""
MIN_STEP: Final = math.radians(0.5)
"""rad: the heading must turn at least this much between two readings to vote."""
MAX_GAP: Final = 2.0
"""s: headings further apart than this (a gap in the data), or a rate last read longer ago,
are not compared."""
VOTES: Final = 20
"""The votes judged: the last this many."""
CONTRARY: Final = 0.8
"""The share of the votes against that finds a rate reversed, and of the votes for that
finds it agreeing again."""


@dataclass
class _Rate:
    """One rate sensor: its turn integrated so far, its latest rate and when, its votes."""

    turned: float = 0.0
    rate: float = 0.0
    t: float | None = None
    votes: deque[bool] = field(default_factory=lambda: deque(maxlen=VOTES))

    def turned_at(self, t: float) -> float:
        """The turn integrated to ``t``, the latest rate held since its reading."""
        return self.turned + (self.rate * (t - self.t) if self.t is not None else 0.0)


@dataclass(frozen=True)
class Finding:
    """A rate sensor found reversed (``reversed`` True) or agreeing again, with its votes."""

    sensor: str
    heading: str
    reversed: bool
    against: int
    votes: int

    def __str__(self) -> str:
        if self.reversed:
            return (f"the yaw rate {self.sensor} turns against the heading of "
                    f"{self.heading} in {self.against} of the last {self.votes} turns: one "
                    f"of the two is of the wrong sense (check both signs: pNav's yaw rate is "
                    f"anticlockwise-"
                    f"positive, a NED gyro's clockwise; S_YAW anticlockwise from east, "
                    f"S_HEADING clockwise from north)")
        return (f"the yaw rate {self.sensor} turns with the heading of {self.heading} "
                f"again in {self.votes - self.against} of the last {self.votes} turns: "
                f"taken as it reads")


class RateSense:
    """Votes each rate sensor's turns against the headings'; ``reversed`` names those turning
    the wrong way."""

    def __init__(self) -> None:
        self.reversed: set[str] = set()
        self._rates: dict[str, _Rate] = {}
        self._headings: dict[str, tuple[float, float, dict[str, float]]] = {}
        """Per heading sensor: its last reading's time and yaw, and each rate sensor's
        integrated turn then."""

    def rate(self, sensor: str, t: float, rate: float) -> None:
        """A yaw rate (rad/s, anticlockwise) read by ``sensor`` at ``t``."""
        if not math.isfinite(rate):
            return
        state = self._rates.get(sensor)
        if state is None:
            state = self._rates[sensor] = _Rate()
        if state.t is not None and t > state.t:
            state.turned = state.turned_at(t)
        state.rate, state.t = rate, t

    def heading(self, sensor: str, t: float, yaw: float) -> list[Finding]:
        """A heading (yaw, rad) read by ``sensor`` at ``t``; the rate sensors found reversed
        or agreeing again by its votes."""
        if not math.isfinite(yaw):
            return []
        turned = {name: r.turned_at(t) for name, r in self._rates.items()
                  if r.t is not None and 0.0 <= t - r.t <= MAX_GAP}  # a silent rate: no vote
        last = self._headings.get(sensor)
        self._headings[sensor] = (t, yaw, turned)
        if last is None or not 0.0 < t - last[0] <= MAX_GAP:
            return []
        dt = t - last[0]
        step = math.remainder(yaw - last[1], 2.0 * math.pi)
        if abs(step) < MIN_STEP:
            return []
        findings = []
        for name, now in turned.items():
            if name not in last[2]:
                continue
            turn = now - last[2][name]
            if not abs(turn) >= MIN_RATE * dt:
                continue
            votes = self._rates[name].votes
            votes.append((turn > 0.0) == (step > 0.0))
            finding = self._judge(name, sensor, votes)
            if finding is not None:
                findings.append(finding)
        return findings

    @property
    def heard(self) -> list[str]:
        """The rate sensors heard so far, by name."""
        return sorted(self._rates)

    def forgive(self, sensor: str) -> None:
        """A rate found reversed taken as it reads again, its votes and every heading's last
        reading forgotten: the heading it was judged by was the one of the wrong sense, and
        is read the other way round from now on."""
        self.reversed.discard(sensor)
        state = self._rates.get(sensor)
        if state is not None:
            state.votes.clear()
        self._headings.clear()

    def mirror(self) -> None:
        """Every rate heard taken the other way round from now on, their votes and every
        heading's last reading forgotten: the ranges found the turns of the wrong sense
        where no heading turned against them (none sensed, or one read the wrong way round
        with its rate)."""
        for name, state in self._rates.items():
            self.reversed.symmetric_difference_update({name})
            state.votes.clear()
        self._headings.clear()

    def _judge(self, name: str, heading: str, votes: deque[bool]) -> Finding | None:
        if len(votes) < VOTES:
            return None
        against = votes.count(False)
        if name not in self.reversed and against >= CONTRARY * len(votes):
            self.reversed.add(name)
            return Finding(name, heading, True, against, len(votes))
        if name in self.reversed and len(votes) - against >= CONTRARY * len(votes):
            self.reversed.discard(name)
            return Finding(name, heading, False, against, len(votes))
        return None
