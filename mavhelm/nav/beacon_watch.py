"""Watching each beacon's ranges against the others' (spec 2.2.6): a beacon off its survey.

A beacon a few metres from its surveyed position is wrong by an amount that turns with the
bearing it is heard from: ``−d cos θ`` for a displacement ``d``. Its innovations do not show
it: the filter, trusting the beacon, moves the position and learns the mean of that error as
the beacon's range offset, and every beacon's χ² distances then look alike (Plaza1 with one
beacon 5 m off: 0.31–0.35 per dof for all four). What does show is the learned offset: a
beacon whose ranges are consistently biased against what the other beacons say carries an
offset unlike theirs (Plaza1: 4.0 m against 0.1–0.7 m; clean, all within 0.2 m of each other).

:class:`BeaconWatch` takes each beacon's learned offset, less its prior, against the median of
the others' (a delay shared by every beacon is a common offset, not a survey error). A beacon
that deviates by more than ``BIAS_LIMIT`` is down-weighted: its ranges' σ is combined with
``SWING`` × the deviation. It is reported once the deviation is also ``SIGNIFICANCE`` σ clear
of the filter's own uncertainty of the offset (straight after the boot every offset is
uncertain by metres and they disagree while the position settles: the weights then follow
the disagreement, quietly). The swing is the least the remaining error can reach: the offset
absorbs the mean of ``−d cos θ`` (at most ``d``), so as the bearing turns the error still left
reaches ``d`` plus the offset's size, at least twice the offset. A reported beacon whose
deviation falls back under half the limit is reported again, trusted as declared. It needs three beacons
(with two, which one is off cannot be told) and learned offsets (``EKF_BEACON_OFFSETS``).

Measured (NAV RMS, NEES mean): Plaza1 with one beacon 5 m off 1.01 m, 9.4 → 0.64 m, 1.03;
clean Plaza1 0.47 → 0.40 m (a beacon's offset early in the run, before the others agree on
the position); the simulator's box patrol with a beacon 5 m off 0.84 → 0.53 m (GPS 0.55 m).

Pure logic: the owner asks ``sigma`` for each range and ``review`` once a slice with ranges
for the decisions to publish.
"""

from __future__ import annotations

import math
import statistics
from typing import Final

from mavhelm.nav.ekf import EKF
from mavhelm.nav.filter_safety import BEACON, Decision

BIAS_LIMIT: Final = 1.0
"""m: a beacon's offset further than this from the others' median is a survey error (clean
Plaza1: every offset within 0.2 m of the others')."""
SIGNIFICANCE: Final = 3.0
"""How many σ of the filter's own offset uncertainty the deviation must clear: a beacon's
offset straight after the boot (σ 5 m) proves nothing."""
SWING: Final = 2.0
"""The least range error left, in deviations, as the bearing to a displaced beacon turns."""
MIN_BEACONS: Final = 3
"""Beacons needed to tell which one is off (the median of at least two others)."""


class BeaconWatch:
    """``sigma(beacon, declared)`` is the σ a range to ``beacon`` is used with;
    ``review(t, ekf)`` updates the weights once a slice and returns its decisions (a beacon
    found off its survey, or back on it)."""

    def __init__(self) -> None:
        self.weights: dict[str, float] = {}
        """Beacons down-weighted now, with their deviation (m) at the last review."""
        self.reported: set[str] = set()
        """Beacons reported off their survey (and not yet back)."""

    def deviations(self, ekf: EKF) -> dict[str, tuple[float, float]]:
        """Each beacon's deviation (m) from the others' median offset, and the filter's 1-σ
        of its offset (m)."""
        beacons = ekf.beacons
        if len(beacons) < MIN_BEACONS or not ekf.config.learn_beacon_offsets:
            return {}
        x, P = ekf.x, ekf.P
        index = {name: ekf.offset_index(name) for name in beacons}
        offsets = {name: float(x[i, 0]) - beacons[name].offset for name, i in index.items()}
        return {name: (abs(offset - statistics.median(v for k, v in offsets.items()
                                                      if k != name)),
                       math.sqrt(max(float(P[index[name], index[name]]), 0.0)))
                for name, offset in offsets.items()}

    def sigma(self, beacon: str, declared: float) -> float:
        deviation = self.weights.get(beacon)
        return declared if deviation is None else math.hypot(declared, SWING * deviation)

    def review(self, t: float, ekf: EKF) -> list[Decision]:
        decisions = []
        self.weights = {}
        for name, (deviation, sigma) in sorted(self.deviations(ekf).items()):
            if deviation > BIAS_LIMIT:
                self.weights[name] = deviation
                if name not in self.reported and deviation > SIGNIFICANCE * sigma:
                    self.reported.add(name)
                    decisions.append(Decision(
                        t, BEACON, f"beacon {name}'s ranges are biased {deviation:.1f} m "
                        "against the other beacons': it is off its survey, its ranges "
                        "down-weighted"))
            elif deviation < BIAS_LIMIT / 2 and name in self.reported:
                self.reported.discard(name)
                decisions.append(Decision(t, BEACON, f"beacon {name}'s ranges agree with the "
                                          "other beacons' again: trusted as declared"))
        return decisions
