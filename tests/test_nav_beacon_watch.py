"""The beacon watch (mavhelm.nav.beacon_watch): a beacon whose learned range offset departs
from the other beacons' is reported and down-weighted; one back in line is trusted again."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavhelm.nav.beacon_watch import AGREEMENT, BIAS_LIMIT, LOCKED_OUT, SWING, BeaconWatch
from mavhelm.nav.ekf import EKF, Beacon, EKFConfig, Range
from mavhelm.nav.filter_safety import BEACON

BEACONS = (Beacon("A", 0, 0), Beacon("B", 50, 0), Beacon("C", 0, 50, offset=2.0),
           Beacon("D", 50, 50))


def _ekf(offsets: dict[str, float], sigma: float = 0.1, **config: bool) -> EKF:
    ekf = EKF(0.0, 25.0, 25.0, beacons=BEACONS, config=EKFConfig(**config))
    for name, value in offsets.items():
        i = ekf.offset_index(name)
        ekf.x[i, 0] = value
        ekf.P[i, i] = sigma**2
    return ekf


def test_a_beacon_off_the_others_is_reported_and_down_weighted() -> None:
    # a common 0.3 m delay, beacon C's prior of 2 m taken off: only A stands out
    ekf = _ekf({"A": 3.3, "B": 0.3, "C": 2.3, "D": 0.2})
    watch = BeaconWatch()
    decisions = watch.review(10.0, ekf)
    assert [(d.kind, d.t) for d in decisions] == [(BEACON, 10.0)]
    assert "beacon A's ranges are biased 3.0 m" in decisions[0].why
    assert watch.sigma("A", 1.0) == pytest.approx(math.hypot(1.0, SWING * 3.0))
    assert watch.sigma("B", 1.0) == 1.0
    assert watch.review(11.0, ekf) == []  # said once


def test_three_beacons_one_off_is_told_apart() -> None:
    ekf = EKF(0.0, 0.0, 0.0, beacons=BEACONS[:3], config=EKFConfig())
    for name, value in {"A": 4.0, "B": 0.0, "C": 2.0}.items():
        i = ekf.offset_index(name)
        ekf.x[i, 0], ekf.P[i, i] = value, 0.01
    watch = BeaconWatch()
    assert [d.why.split("'")[0] for d in watch.review(0.0, ekf)] == ["beacon A"]
    assert set(watch.weights) == {"A"}


def test_an_uncertain_offset_proves_nothing() -> None:
    ekf = _ekf({"A": 3.0, "B": 0.0, "C": 2.0, "D": 0.0}, sigma=2.0)  # 3 m at σ 2 m
    watch = BeaconWatch()
    assert watch.review(0.0, ekf) == [] and watch.weights == {}


def test_a_beacon_back_in_line_is_trusted_again() -> None:
    ekf = _ekf({"A": 3.0, "B": 0.0, "C": 2.0, "D": 0.0})
    watch = BeaconWatch()
    watch.review(0.0, ekf)
    ekf.x[ekf.offset_index("A"), 0] = 0.5 * BIAS_LIMIT  # between half the limit and the limit
    assert watch.review(1.0, ekf) == [] and "A" in watch.weights
    ekf.x[ekf.offset_index("A"), 0] = 0.2 * BIAS_LIMIT
    decisions = watch.review(2.0, ekf)
    assert len(decisions) == 1 and "trusted as declared" in decisions[0].why
    assert watch.sigma("A", 1.0) == 1.0


@pytest.mark.parametrize(("beacons", "config"), [(BEACONS[:2], {}),
                                                 (BEACONS, {"learn_beacon_offsets": False})])
def test_nothing_to_tell_without_three_beacons_or_learned_offsets(beacons, config) -> None:
    ekf = EKF(0.0, 0.0, 0.0, beacons=beacons, config=EKFConfig(**config))
    ekf.x[ekf.offset_index("A"), 0] = 10.0
    assert BeaconWatch().review(0.0, ekf) == []


def test_no_more_than_a_minority_is_held_off_its_survey() -> None:
    """Four beacons whose offsets scatter two up, two down: that is the position the offsets
    were learned against, not four surveys wrong; one at most is held off (the first)."""
    ekf = _ekf({"A": 4.0, "B": 3.0, "C": 2.0 - 3.0, "D": -4.0})
    watch = BeaconWatch()
    decisions = watch.review(0.0, ekf)
    assert len(decisions) == 1 and len(watch.weights) == 1
    assert [name for name, (deviation, _) in watch.deviations(ekf).items()
            if deviation > BIAS_LIMIT] == ["A", "B", "C", "D"]


def test_good_ranges_refused_in_a_row_lock_a_beacon_out() -> None:
    """Ranges refused against a wrong learned offset agree with each other: after
    ``LOCKED_OUT`` of them the watch says the offset is doubted (the owner re-opens it)."""
    watch = BeaconWatch()
    refusals = [8.1, 8.4, 7.9, 8.3, 8.2]
    assert len(refusals) == LOCKED_OUT
    decisions = [watch.refused(float(k), "B", False, y, 1.0) for k, y in enumerate(refusals)]
    assert decisions[:-1] == [None] * (LOCKED_OUT - 1)
    last = decisions[-1]
    assert last is not None and last.kind == BEACON and last.t == LOCKED_OUT - 1
    assert "beacon B's last 5 ranges were all refused" in last.why and "+8.2 m" in last.why
    assert watch.refused(9.0, "B", False, 8.0, 1.0) is None  # said once; counting again


@pytest.mark.parametrize("fates", [
    [(False, 20.0), (False, -15.0), (False, 40.0), (False, -8.0), (False, 12.0)],  # outliers
    [(False, 8.0), (False, 8.1), (True, 0.2), (False, 8.2), (False, 8.0), (False, 8.1)],
    [(False, 8.0), (False, 8.1), (False, 8.2), (False, 8.0), (False, 8.0 + AGREEMENT + 0.1)],
])
def test_scattered_or_interrupted_refusals_are_no_lockout(fates) -> None:
    watch = BeaconWatch()
    assert all(watch.refused(float(k), "A", accepted, y, 1.0) is None
               for k, (accepted, y) in enumerate(fates))


def test_a_reopened_offset_lets_the_beacons_ranges_in_again() -> None:
    """An offset learned 8 m wrong refuses every good range; re-opened, the next one is used
    and sets it."""
    ekf = _ekf({"A": 0.0, "B": 8.0, "C": 2.0, "D": 0.0}, sigma=0.05, estimate_range_scale=False)
    ekf.P[0, 0] = ekf.P[1, 1] = 0.01
    good = Range(0.0, "B", math.dist((25.0, 25.0), (50.0, 0.0)))
    assert not ekf.update(good).verdicts[0].accepted
    verdict = ekf.update(good).verdicts[0]
    assert verdict.innovation == pytest.approx(-8.0)
    i = ekf.offset_index("B")
    before = float(ekf.P[i, i])
    ekf.reopen_offset("B")
    assert float(ekf.P[i, i]) == pytest.approx(before + EKFConfig().offset_sigma**2)
    assert np.all(np.linalg.eigvalsh(ekf.P) > 0)
    assert ekf.update(good).verdicts[0].accepted
    assert abs(float(ekf.x[i, 0])) < 0.5
