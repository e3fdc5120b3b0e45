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
uncertainty of that deviation (straight after the boot the offsets disagree while the
position settles), is reported and all but left out: its ranges' σ is combined with
``SWING`` × the deviation. Down-weighted only by the error left as the bearing turns (twice
the deviation), its ranges held the position where it had drifted. The filter is then told to
forget what the ranges taught it (the owner re-opens the other beacons' offsets to their
prior and widens the position by the deviation) so that the beacons still trusted set them
again. A beacon whose deviation falls back under half the limit is trusted as declared again.

It needs three beacons (with two, which one is off cannot be told) and learned offsets
(``EKF_BEACON_OFFSETS``), and holds at most a minority of them off at once (one of three or
four, two of five): when more disagree, it is the position the offsets were learned against
that is wrong, not the survey (Plaza1 with its heading 90° out: all four beacons were judged
off their survey in the first 40 s under way). The first beacon to stand out need not be
the one off its survey: the position's error spreads over every offset. So the blame moves
to a beacon whose deviation reaches ``SWITCH`` times that of the one held off, but not within
``SETTLE`` s of the last change, while the filter re-learns.

Measured (NAV RMS), with one beacon 5 m off its survey in a random direction: the
simulator's box patrol (three beacons and a GPS) 0.57 m, the right beacon found at 70 s (GPS
alone 0.55 m). On Plaza1 (four beacons, odometry, no GPS) the offsets named the wrong beacon
as often as the right one (sixteen draws: mean 1.94 m, 0.63-2.88 m): the filter settles
early to a position and offsets that agree with every beacon, the displaced one included,
within the ranges' noise (tried and not kept: the beacons' positions as filter states, σ 2 m:
1.2-1.8 m). So where there are four beacons or more the track judges instead
(:mod:`mavhelm.nav.survey_check`; ``blame_by_offsets`` false): the beacon it singles out
(``review``'s ``singled_out``) takes the blame from any the offsets found and keeps it until
the track singles out another (Plaza1: mean 0.78 m, the right beacon every time). Once a
position fix (a GPS) has been accepted the offsets are anchored to it and judge again beside
the track, which some geometries leave unable to tell two beacons apart (the simulator's box
patrol among four beacons and a GPS: 0.41-1.03 m; before, on a 60 s track alone, 0.70-1.39 m).

A beacon can also be locked out by the filter rather than by its survey. One bad range
accepted straight after the boot, while the offsets are uncertain by metres, can leave a state
against which every good range to some beacon fails the gate (Plaza1 with range outliers, one
draw, the offsets then uncorrelated: a range 13 m short accepted 3 s after the boot, the next
fifty of that beacon's ranges refused, NAV 3.0 m RMS). Bad ranges scatter; good ones refused
against a wrong state agree with each other. So when ``LOCKED_OUT`` ranges in a row to one
beacon are refused and their innovations lie within ``AGREEMENT`` σ of each other,
:meth:`BeaconWatch.refused` says so and the owner makes the filter forget what the ranges
taught it, as for a beacon off its survey (every offset back to its prior,
:meth:`~mavhelm.nav.ekf.EKF.reopen_offsets`, the position widened by the innovation). On
that draw, re-opening the locked-out beacon's offset alone gave 1.1 m; with the offsets'
prior correlated (each beacon's own part 0.5 m) the bad range is refused and it scores
0.38 m. The rule stays for what the prior does not cover, such as a still vehicle's first
ranges with nothing else to check them against (``tests/test_nav_beacon_watch.py``: half
the ranges refused to the end without it).

Pure logic: the owner asks ``sigma`` for each range, tells ``refused`` each range's fate and
calls ``review`` once a slice with ranges, for the decisions to publish.
"""

from __future__ import annotations

import math
import statistics
from collections import deque
from itertools import pairwise
from typing import Final

import numpy as np

from mavhelm.nav.ekf import EKF
from mavhelm.nav.filter_safety import BEACON, Decision

BIAS_LIMIT: Final = 1.0
"""m: a beacon's offset further than this from the beacons' median is a survey error (clean
Plaza1: every offset within 0.2 m of the others')."""
SIGNIFICANCE: Final = 3.0
"""How many σ of the filter's own uncertainty of the deviation it must clear: the offsets'
differences straight after the boot prove nothing."""
SWING: Final = 50.0
"""A beacon off its survey has its ranges' σ combined with this many deviations: all but
left out. With twice the deviation (the least error its ranges still carry as the bearing
turns) they held the position where it had drifted; on eight Plaza1 draws, with an earlier
form of the watch, 2, 5, 10, 20 and 50 gave a mean NAV RMS of 1.82, 1.64, 1.42, 1.30 and
1.46 m (the differences are mostly one draw, seed 2: 2.2–3.5 m)."""
SWITCH: Final = 1.5
"""How many times the deviation of the beacon held off its survey another's must reach for
the blame to move to it: straight after the boot the position's error spreads over every
offset, and the first to stand out need not be the one off its survey."""
SETTLE: Final = 60.0
"""s after a beacon is found off its survey before the blame may move to another: the
filter, told to forget what that beacon taught it, takes a while to settle, and meanwhile the
offsets it re-learns disagree (the simulator's three beacons: the blame went round all three
in 40 s)."""
MIN_BEACONS: Final = 3
"""Beacons needed to tell which one is off (two agreeing against one)."""
LOCKED_OUT: Final = 5
"""Ranges to one beacon refused in a row, agreeing, before its offset is re-opened."""
AGREEMENT: Final = 4.0
"""Spread (largest less smallest innovation), in the ranges' σ, within which refused ranges
agree: good ranges against a wrong offset."""
ADRIFT_RUN: Final = 3
ADRIFT_BEACONS: Final = 2
ADRIFT_WINDOW: Final = 30.0
"""``ADRIFT_RUN`` ranges in a row refused to each of ``ADRIFT_BEACONS`` beacons, the last
within ``ADRIFT_WINDOW`` s: the filter is off, not a beacon (a beacon off its survey is one
beacon; an outlier, one range). Its refused innovations grow rather than agree, so
the lock-out above waits for the drift to stop: Plaza1, the heading drifting and kicked at
once (seed 3), a kick taken for a turn carried the position 15 m off in 27 s while three
beacons' ranges were refused (1.42 m RMS; 0.79 m with the rule, the owner also doubting the
heading). It never fired on Plaza1 as recorded, nor on seeds 1-7 of its single faults. The
owner holds it while a trusted LSQ already disagrees beyond ``MaxLSQEKFDeviation``: the
re-initialisation (spec 2.2.9) is on its way; it asks the ranges for the heading meanwhile
(``adrift_beacons``, which forgets nothing). Its cost: widened before the heading is
realigned, a heading turned round from the start is realigned later (Plaza1, 180° out:
2.25 → 3.46 m RMS).

A run counts only when its last ``ADRIFT_RUN`` innovations say the same thing (``_one_way``):
one sign (a position off by ``d`` is refused ``−d·u`` by every range of a beacon at bearing
``u``) and a spread within ``AGREEMENT`` σ or their median size (a drift grows smoothly). Random
range outliers are refused in runs too, of either sign and any size: Plaza1 with 20 % of its
ranges 5–50 m out (seed 3), runs of ``[50.5, 25.8, −34.6]`` and ``[28.7, −40.3, 47.4]`` said
the filter was off while it was 0.06 m from the truth; widened by the 47 m refused, it took the
next outliers and ran 49 m off (4.18 m RMS, NEES 30).

Ranges that take a longer path (a radio or acoustic ray reflected round an obstacle, NLOS)
are all long: their outliers share one sign, and runs such as ``[47.2, 17.8, 45.0]`` and
``[38.2, 39.7, 42.8]`` passed those checks (Plaza1, a fifth of the ranges 5–50 m long, seed
3: found adrift 0.2 m from the truth, moved to the LSQ's fix of the same outliers 54 m off,
13.1 m RMS, NEES 44). Against a filter carried off it is the prediction that drifts; the
ranges refused are good ones and go on as ranges heard along a track do. So the ranges
measured (not the innovations) of a run must go on from the beacon's last range accepted
(``_drifts``), each step within ``AGREEMENT`` σ plus ``DRIFT_SPEED`` times the filter's
speed plus ``DRIFT_FLOOR`` times its time (a range changes no faster than the vehicle moves;
twice, for a speed the filter has wrong). An accepted range counts only where it agreed with
the filter within ``AGREEMENT`` σ: one taken far from its prediction under a wide prior (a
still start) may itself be the outlier that carried the filter off. Every run found on
Plaza1's heading faults, alone and joined, on the whole recording, half its ranges and
starts under way (180 runs) still counts; the NLOS ranges above jumped 29–37 m within
3.6 s of the last range accepted."""
DRIFT_SPEED: Final = 2.0
DRIFT_FLOOR: Final = 0.5
"""m/s: ``_drifts``'s bound on how fast the ranges to a beacon change, ``DRIFT_SPEED`` times
the filter's speed plus this."""


class BeaconWatch:
    """``sigma(beacon, declared)`` is the σ a range to ``beacon`` is used with;
    ``review(t, ekf)`` updates the weights once a slice and returns its decisions (a beacon
    found off its survey, or back on it)."""

    def __init__(self, blame_by_offsets: bool = True) -> None:
        self.blame_by_offsets = blame_by_offsets
        """Whether the offsets may find a beacon off its survey: only where the track cannot
        (:mod:`mavhelm.nav.survey_check` needs four beacons)."""
        self.weights: dict[str, float] = {}
        """Beacons found off their survey (down-weighted), with their deviation (m) at the
        last review."""
        self.newly_off: list[str] = []
        """The beacons the last review found off their survey."""
        self._moved = -math.inf
        """When a beacon was last found off its survey."""
        self.fixed: str | None = None
        """The beacon the track singled out (:mod:`mavhelm.nav.survey_check`): held off its
        survey whatever the offsets say, until the track singles out another."""
        self._refusals: dict[str, deque[tuple[float, float, float]]] = {}
        """Each beacon's ranges refused in a row, the latest ``LOCKED_OUT``: when each was
        heard, its innovation (m) and the range measured (m)."""
        self._accepted: dict[str, tuple[float, float, float]] = {}
        """Each beacon's last range accepted, as the runs keep them."""
        self._sigma: dict[str, float] = {}
        """Each beacon's ranges' σ (m) at its last refusal."""

    def deviations(self, ekf: EKF) -> dict[str, tuple[float, float]]:
        """Each beacon's deviation (m) from the median offset of every beacon (with three,
        the others' median would be their mean, and one beacon off would drag it), and the
        filter's 1-σ of its offset less the others' mean (m): the shared delay, however
        uncertain, is no evidence either way."""
        beacons = list(ekf.beacons)
        if len(beacons) < MIN_BEACONS or not ekf.config.learn_beacon_offsets:
            return {}
        x = ekf.x.ravel().tolist()
        index = [ekf.offset_index(name) for name in beacons]
        offsets = [x[i] - ekf.beacons[name].offset for name, i in zip(beacons, index, strict=True)]
        median = statistics.median(offsets)
        a = index[0]
        contiguous = index == list(range(a, a + len(index)))  # as the EKF lays them out
        block = ekf.P[a:a + len(index), a:a + len(index)] if contiguous else \
            ekf.P[index][:, index]
        contrasts = _contrasts(len(index))
        variances = np.einsum("ij,jk,ik->i", contrasts, block, contrasts).tolist()
        return {name: (abs(offset - median), math.sqrt(max(v, 0.0)))
                for name, offset, v in zip(beacons, offsets, variances, strict=True)}

    def sigma(self, beacon: str, declared: float) -> float:
        deviation = self.weights.get(beacon)
        return declared if deviation is None else math.hypot(declared, SWING * deviation)

    def refused(self, t: float, beacon: str, accepted: bool, innovation: float,
                sigma: float, z: float = math.nan) -> Decision | None:
        """One range's fate: a decision when ``beacon`` is locked out (the owner makes the
        filter forget what the ranges taught it). ``z``: the range measured (m; NaN where
        unknown, which leaves ``_drifts`` nothing to judge)."""
        if accepted:
            self._accepted[beacon] = (t, innovation, z)
            if beacon in self._refusals:
                self._refusals[beacon].clear()
            return None
        run = self._refusals.get(beacon)
        if run is None:
            run = self._refusals[beacon] = deque(maxlen=LOCKED_OUT)
        run.append((t, innovation, z))
        self._sigma[beacon] = sigma
        refusals = [y for _, y, _ in run]
        if len(refusals) < LOCKED_OUT or max(refusals) - min(refusals) > AGREEMENT * sigma:
            return None
        mean = statistics.fmean(refusals)
        run.clear()
        return Decision(t, BEACON, f"beacon {beacon}'s last {LOCKED_OUT} ranges were all "
                        f"refused, agreeing with each other ({mean:+.1f} m against the "
                        "filter): the range offsets learned are doubted and re-opened")

    def adrift(self, t: float, speed: float) -> Decision | None:
        """After a refusal: a decision when the ranges refused in a row say the filter is
        off rather than a beacon (the owner widens its position and re-opens the offsets,
        as for a lock-out). ``speed``: the filter's (m/s)."""
        adrift = self.adrift_beacons(t, speed)
        if not adrift:
            return None
        for run in self._refusals.values():
            run.clear()
        return Decision(t, BEACON, f"the ranges to beacons {', '.join(adrift)} were each "
                        f"refused {ADRIFT_RUN} or more times in a row: the filter is off, "
                        "not a beacon: its position is doubted and widened, the range "
                        "offsets learned re-opened")

    def adrift_beacons(self, t: float, speed: float) -> list[str]:
        """The beacons whose ranges refused in a row say the filter is off, when there are
        ``ADRIFT_BEACONS`` of them or more (else none); nothing forgotten. ``speed``: the
        filter's (m/s)."""
        adrift = sorted(name for name, run in self._refusals.items()
                        if len(run) >= ADRIFT_RUN and t - run[-1][0] <= ADRIFT_WINDOW
                        and _one_way([y for _, y, _ in run][-ADRIFT_RUN:], self._sigma[name])
                        and self._drifts(name, speed))
        return adrift if len(adrift) >= ADRIFT_BEACONS else []

    def _drifts(self, beacon: str, speed: float) -> bool:
        """Whether ``beacon``'s ranges refused in a row go on from its last accepted one as
        ranges heard along a track do: each step within ``AGREEMENT`` σ plus
        (``DRIFT_SPEED`` × ``speed`` + ``DRIFT_FLOOR``) × its time. Good ranges refused
        against a filter carried off do; outliers jump. The accepted range counts only where
        the filter expected it (within ``AGREEMENT`` σ): one taken far from its prediction,
        under a wide prior at the boot, may itself be the outlier that carried the filter
        off."""
        steps = list(self._refusals[beacon])
        rate = DRIFT_SPEED * speed + DRIFT_FLOOR
        near = AGREEMENT * self._sigma[beacon]
        accepted = self._accepted.get(beacon)
        if accepted is not None and abs(accepted[1]) <= near:
            steps.insert(0, accepted)
        return not any(abs(z - z0) > near + rate * (t - t0)
                       for (t0, _, z0), (t, _, z) in pairwise(steps))

    def review(self, t: float, ekf: EKF, singled_out: str | None = None) -> list[Decision]:
        """The weights brought up to date; ``newly_off`` names the beacon just found off its
        survey, if any (the owner makes the filter forget what it taught it).
        ``singled_out`` is a beacon the track singled out: it takes the blame from any the
        offsets had found."""
        decisions = []
        found = self.deviations(ekf)
        most = (len(found) - 1) // 2
        self.newly_off = []
        if singled_out is not None and singled_out != self.fixed:
            return self._single_out(t, singled_out, found)
        settling = t - self._moved < SETTLE
        for name in list(self.weights):
            if name == self.fixed:
                continue
            deviation = found[name][0] if name in found else 0.0
            if deviation < BIAS_LIMIT / 2 and not settling:
                del self.weights[name]
                decisions.append(Decision(t, BEACON, f"beacon {name}'s ranges agree with the "
                                          "other beacons' again: trusted as declared"))
            else:
                self.weights[name] = deviation
        if self.fixed is not None or not self.blame_by_offsets:
            return decisions
        suspects = [(deviation, name) for name, (deviation, sigma) in found.items()
                    if name not in self.weights and deviation > BIAS_LIMIT
                    and deviation > SIGNIFICANCE * sigma]
        if not suspects:
            return decisions
        deviation, name = max(suspects)
        if len(self.weights) >= most:
            least = min(self.weights, key=self.weights.__getitem__, default=None)
            if least is None or deviation < SWITCH * self.weights[least] or settling:
                return decisions
            del self.weights[least]
            decisions.append(Decision(t, BEACON, f"beacon {least}'s ranges trusted as declared "
                                      f"again: beacon {name}'s disagree more"))
        self.weights[name] = deviation
        decisions.append(self._hold_off(t, name, f"are biased {deviation:.1f} m against the "
                                        "other beacons'"))
        return decisions

    def _single_out(self, t: float, name: str,
                    found: dict[str, tuple[float, float]]) -> list[Decision]:
        decisions = [Decision(t, BEACON, f"beacon {other}'s ranges trusted as declared again: "
                              f"the track singles out beacon {name}'s")
                     for other in self.weights if other != name]
        deviation = found[name][0] if name in found else 0.0
        self.weights = {name: max(deviation, BIAS_LIMIT)}
        self.fixed = name
        decisions.append(self._hold_off(t, name, "do not fit the track the other beacons' fit"))
        return decisions

    def _hold_off(self, t: float, name: str, why: str) -> Decision:
        """Beacon ``name`` newly held off its survey (its weight already set), and why."""
        self.newly_off.append(name)
        self._moved = t
        return Decision(t, BEACON, f"beacon {name}'s ranges {why}: it is off its survey, its "
                        "ranges all but left out")


_CONTRASTS: dict[int, np.ndarray] = {}


def _contrasts(n: int) -> np.ndarray:
    """Each of ``n`` beacons' offset less the others' mean, as rows (one matrix per ``n``,
    made once: the watch asks at every range)."""
    contrasts = _CONTRASTS.get(n)
    if contrasts is None:
        contrasts = np.full((n, n), -1.0 / (n - 1))
        np.fill_diagonal(contrasts, 1.0)
        contrasts.setflags(write=False)
        _CONTRASTS[n] = contrasts
    return contrasts


def _one_way(run: list[float], sigma: float) -> bool:
    """Whether refused innovations (m) say the filter is off rather than the ranges wild: one
    sign, and a spread within ``AGREEMENT`` ``sigma`` or their median size."""
    if not (all(y > 0 for y in run) or all(y < 0 for y in run)):
        return False
    sizes = [abs(y) for y in run]
    return max(sizes) - min(sizes) <= max(AGREEMENT * sigma, statistics.median(sizes))
