"""A heading-bias state added where a doubted heading needs one (issue 15): the EKF's
augmented copy, and the navigator adding it to a mission that did not declare
``EKF_YAW_BIAS`` when the compass wanders and the motion can tell its bias from the heading."""

from __future__ import annotations

import math

import numpy as np

from mavhelm.nav.ekf import EKF, Beacon, BodyVelocity, EKFConfig, Range, Yaw
from mavhelm.nav.fusion import Fusion, FusionConfig, Start
from mavhelm.nav.sensors import FixedValue, Reading, SensorSpec

BEACONS = (Beacon("1", -60.0, -60.0, -1.0), Beacon("2", 160.0, -50.0, -1.0),
           Beacon("3", 50.0, 160.0, -1.0))
RANGER = SensorSpec("RANGE", "RNG", "radio")
COMPASS = SensorSpec("ORIENTATION", "HDG", "compass")
GYRO = SensorSpec("BODY_VEL", "INS", "gyro")


def test_the_augmented_filter_carries_every_state_and_adds_a_zero_bias() -> None:
    cfg = EKFConfig(estimate_z=True)
    ekf = EKF(0.0, 3.0, 4.0, 0.5, beacons=BEACONS, config=cfg)
    ekf.advance(1.0)
    ekf.update([Range(1.0, "1", 90.0, 0.3), Range(1.0, "2", 170.0, 0.3), Yaw(1.0, 0.4)])
    twin = ekf.with_yaw_bias()
    assert ekf.i_bias is None and twin.i_bias is not None and twin.i_drift is not None
    assert twin.dim == ekf.dim + 2 and twin.t == ekf.t  # the bias and, as EKF_YAW_DRIFT, its rate
    kept = [i for i in range(twin.dim) if i not in (twin.i_bias, twin.i_drift)]
    np.testing.assert_array_equal(twin.x[kept, 0], ekf.x[:, 0])
    np.testing.assert_array_equal(twin.P[np.ix_(kept, kept)], ekf.P)
    assert twin.x[twin.i_bias, 0] == 0.0
    assert twin.P[twin.i_bias, twin.i_bias] == cfg.sigma_yaw_bias**2
    assert twin.x[twin.i_drift, 0] == 0.0
    assert twin.P[twin.i_drift, twin.i_drift] == cfg.sigma_yaw_drift**2
    assert not twin.P[np.ix_([twin.i_bias, twin.i_drift], kept)].any()
    for name in ekf.beacons:  # the offsets behind the new state moved with their names
        assert twin.x[twin.offset_index(name), 0] == ekf.x[ekf.offset_index(name), 0]
    assert twin.with_yaw_bias() is twin
    e, f = ekf.estimate(), twin.estimate()
    assert (e.x, e.y, e.yaw, e.sigma_x, e.offsets) == (f.x, f.y, f.yaw, f.sigma_x, f.offsets)


def _patrol(fusion: Fusion, bias_rate: float, seconds: float = 400.0) -> tuple[list[float],
                                                                               float]:
    """A boat at 2.5 m/s on a 60 m circle heard by three beacons, its compass's bias growing
    at ``bias_rate`` (rad/s): the position errors of the steps, and the final bias."""
    rng = np.random.default_rng(5)
    speed, radius = 2.5, 60.0
    w = speed / radius
    errors = []
    bias = 0.0
    for k in range(int(seconds * 10)):
        t = 0.1 * k
        yaw = w * t  # counter-clockwise about (50, 50) from (110, 50), the bow on the track
        x, y = 50.0 + radius * math.cos(yaw), 50.0 + radius * math.sin(yaw)
        bias = bias_rate * t
        readings = [Reading(COMPASS, Yaw(t, math.remainder(yaw + bias + rng.normal(0, 0.01),
                                                          2 * math.pi), math.radians(0.5))),
                    Reading(GYRO, BodyVelocity(t, yaw_rate=w + rng.normal(0, 0.01)))]
        if k % 5 == 0:
            for b in BEACONS:
                d = math.sqrt((x - b.x) ** 2 + (y - b.y) ** 2 + b.z**2)
                readings.append(Reading(RANGER, Range(t, b.name, d + rng.normal(0, 0.3), 0.3),
                                        b.name, d))
        for r in readings:
            fusion.add(r, t)
        estimate = fusion.step(t)
        if estimate is not None and t > 20.0:
            errors.append(math.hypot(estimate.x - x, estimate.y - y))
    return errors, bias


def _fusion(sideslip: bool) -> Fusion:
    return Fusion(FusionConfig(
        ekf=EKFConfig(velocity_follows_heading=sideslip, learn_beacon_offsets=False,
                      estimate_range_scale=False), beacons=BEACONS, lsq_timeout=None,
        start=Start(110.0, 50.0, 0.0, 2.0, math.radians(5.0)),
        fixed_sideslip=FixedValue(0.0, 0.3) if sideslip else None))


def test_a_wandering_compass_gets_a_bias_state_where_the_motion_tells_it_apart() -> None:
    fusion = _fusion(sideslip=True)
    errors, bias = _patrol(fusion, math.radians(0.4))  # 160° in 400 s
    assert fusion.ekf is not None and fusion.ekf.i_bias is not None
    said = [(d.t, d.why) for d in fusion.decisions]
    added = [t for t, why in said if "heading bias is estimated from now on" in why]
    assert added and added[0] < 30.0, said  # once under way, before any doubt is needed
    assert not any("heading is doubted" in why for _, why in said), said
    learned = fusion.ekf.estimate().yaw_bias
    assert abs(math.degrees(math.remainder(learned - bias, 2 * math.pi))) < 5.0
    assert math.sqrt(np.mean(np.square(errors))) < 0.5
    assert fusion.ekf_config.estimate_yaw_bias  # a later boot keeps it
    xlog = fusion.take_xlog()
    headers = [line for line in xlog if line.startswith("# t ")]
    assert "YAW_BIAS" not in headers[0] and "SIGMA_YAW_BIAS" in headers[-1]  # new columns
    assert len(xlog[-1].split()) == len(headers[-1].split()) - 1  # "#" aside


def test_nothing_is_added_when_the_heading_does_not_move_the_position() -> None:
    fusion = _fusion(sideslip=False)
    _patrol(fusion, math.radians(0.4), seconds=200.0)
    assert fusion.ekf is not None and fusion.ekf.i_bias is None
    assert not any("estimated from now on" in d.why for d in fusion.decisions)
