"""Watching each beacon's ranges against the others' (spec 2.2.6): a beacon off its survey.

A beacon a few metres from its surveyed position is wrong by an amount that turns with the
bearing it is heard from: ``−d cos θ`` for a displacement ``d``. Its innovations do not show
it: the filter, trusting the beacon, moves the position and learns the mean of that error as
the beacon's range offset, and every beacon's χ² distances then look alike (Plaza1 with one
beacon 5 m off: 0.31–0.35 per dof for all four). What does show is the learned offset: a
beacon whose ranges are consistently biased against what the other beacons say carries an
offset unlike theirs (Plaza1: 4.0 m against 0.1–0.7 m; clean, all within 0.2 m of each other).

:class:`BeaconWatch` takes each beacon's learned offset, less its prior, against the median of
every beacon's (a delay shared by every beacon is a common offset, not a survey error). A
beacon that deviates by more than ``BIAS_LIMIT``, ``SIGNIFICANCE`` σ clear of the filter's
own uncertainty of its offset (straight after the boot every offset is uncertain by metres,
and they disagree while the position settles), is reported and down-weighted: its ranges' σ
is combined with ``SWING`` × the deviation. The swing is the least the error left can reach:
the offset absorbs the mean of ``−d cos θ`` (at most ``d``), so as the bearing turns the
error still left reaches ``d`` plus the offset's size, at least twice the offset. A beacon
whose deviation falls back under half the limit is reported again and trusted as declared.
It needs three beacons (with two, which one is off cannot be told) and learned offsets
(``EKF_BEACON_OFFSETS``), and holds at most a minority of them off at once (one of three or
four, two of five): when more disagree, it is the position the offsets were learned against
that is wrong, not the survey (Plaza1 with its heading 90° out: all four beacons were judged
off their survey in the first 40 s under way, and the filter, down-weighting every range,
took 20 minutes to come back: 3.2 m RMS; held to one, 2.2 m, back in 10 minutes).
Down-weighting a beacon on any deviation, significant or not, scored a little better with a
beacon off (Plaza1 0.64 m) but took the position evidence a heading watch needs when the
heading wanders (the simulator: 0.38 → 0.73 m), so only a significant one counts.

Measured (NAV RMS, NEES mean), with one beacon 5 m off its survey: Plaza1 1.01 m, 9.4 →
0.75 m, 1.5 (beacon 0 reported at 148 s, 2.4 m); the simulator's box patrol 0.84 m, 20 →
0.43 m, 3.6 (GPS alone 0.55 m). Clean runs and the other faults are unchanged (no beacon
reported).

A beacon can also be locked out by the filter rather than by its survey. Straight after the
boot every offset is uncertain by metres, so one bad range accepted then is learned as the
beacon's offset, and from then on every good range to that beacon fails the gate against it
(Plaza1 with range outliers, one draw: a range 13 m short accepted 3 s after the boot, the
next fifty of that beacon's ranges refused, NAV 3.0 m RMS). Bad ranges scatter; good ones
refused against a wrong offset agree with each other. So when ``LOCKED_OUT`` ranges in a
row to one beacon are refused and their innovations lie within ``AGREEMENT`` σ of each
other, :meth:`BeaconWatch.refused` says so and the owner re-opens the offset
(:meth:`~mavhelm.nav.ekf.EKF.reopen_offset`), which the next range sets again.

Pure logic: the owner asks ``sigma`` for each range, tells ``refused`` each range's fate and
calls ``review`` once a slice with ranges, for the decisions to publish.
"""

from __future__ import annotations

import math
import statistics
from collections import deque
from typing import Final

from mavhelm.nav.ekf import EKF
from mavhelm.nav.filter_safety import BEACON, Decision

BIAS_LIMIT: Final = 1.0
"""m: a beacon's offset further than this from the beacons' median is a survey error (clean
Plaza1: every offset within 0.2 m of the others')."""
SIGNIFICANCE: Final = 3.0
"""How many σ of the filter's own offset uncertainty the deviation must clear: a beacon's
offset straight after the boot (σ 5 m) proves nothing."""
SWING: Final = 2.0
"""The least range error left, in deviations, as the bearing to a displaced beacon turns."""
MIN_BEACONS: Final = 3
"""Beacons needed to tell which one is off (two agreeing against one)."""
LOCKED_OUT: Final = 5
"""Ranges to one beacon refused in a row, agreeing, before its offset is re-opened."""
AGREEMENT: Final = 4.0
"""Spread (largest less smallest innovation), in the ranges' σ, within which refused ranges
agree: good ranges against a wrong offset."""


class BeaconWatch:
    """``sigma(beacon, declared)`` is the σ a range to ``beacon`` is used with;
    ``review(t, ekf)`` updates the weights once a slice and returns its decisions (a beacon
    found off its survey, or back on it)."""

    def __init__(self) -> None:
        self.weights: dict[str, float] = {}
        """Beacons found off their survey (down-weighted), with their deviation (m) at the
        last review."""
        self._refusals: dict[str, deque[float]] = {}
        """Each beacon's innovations (m) refused in a row, the latest ``LOCKED_OUT``."""

    def deviations(self, ekf: EKF) -> dict[str, tuple[float, float]]:
        """Each beacon's deviation (m) from the median offset of every beacon (with three,
        the others' median would be their mean, and one beacon off would drag it), and the
        filter's 1-σ of its offset (m)."""
        beacons = ekf.beacons
        if len(beacons) < MIN_BEACONS or not ekf.config.learn_beacon_offsets:
            return {}
        x, P = ekf.x, ekf.P
        index = {name: ekf.offset_index(name) for name in beacons}
        offsets = {name: float(x[i, 0]) - beacons[name].offset for name, i in index.items()}
        median = statistics.median(offsets.values())
        return {name: (abs(offset - median), math.sqrt(max(float(P[i, i]), 0.0)))
                for (name, offset), i in zip(offsets.items(), index.values(), strict=True)}

    def sigma(self, beacon: str, declared: float) -> float:
        deviation = self.weights.get(beacon)
        return declared if deviation is None else math.hypot(declared, SWING * deviation)

    def refused(self, t: float, beacon: str, accepted: bool, innovation: float,
                sigma: float) -> Decision | None:
        """One range's fate: a decision when ``beacon`` is locked out (the owner re-opens its
        offset)."""
        if accepted:
            if beacon in self._refusals:
                self._refusals[beacon].clear()
            return None
        refusals = self._refusals.get(beacon)
        if refusals is None:
            refusals = self._refusals[beacon] = deque(maxlen=LOCKED_OUT)
        refusals.append(innovation)
        if len(refusals) < LOCKED_OUT or max(refusals) - min(refusals) > AGREEMENT * sigma:
            return None
        mean = statistics.fmean(refusals)
        refusals.clear()
        return Decision(t, BEACON, f"beacon {beacon}'s last {LOCKED_OUT} ranges were all "
                        f"refused, agreeing with each other ({mean:+.1f} m against the "
                        "filter): its learned range offset is doubted and re-opened")

    def review(self, t: float, ekf: EKF) -> list[Decision]:
        decisions = []
        found = self.deviations(ekf)
        most = (len(found) - 1) // 2
        for name, (deviation, sigma) in sorted(found.items()):
            if name not in self.weights:
                if (deviation > BIAS_LIMIT and deviation > SIGNIFICANCE * sigma
                        and len(self.weights) < most):
                    self.weights[name] = deviation
                    decisions.append(Decision(
                        t, BEACON, f"beacon {name}'s ranges are biased {deviation:.1f} m "
                        "against the other beacons': it is off its survey, its ranges "
                        "down-weighted"))
            elif deviation < BIAS_LIMIT / 2:
                del self.weights[name]
                decisions.append(Decision(t, BEACON, f"beacon {name}'s ranges agree with the "
                                          "other beacons' again: trusted as declared"))
            else:
                self.weights[name] = deviation
        return decisions
