"""The pNav EKF and LSQ (mavhelm.nav.ekf, .lsq, .fusion) on synthetic data.

The synthetic vehicle drives a circle among four beacons in the MOOS yaw convention (yaw =
−heading, bow along (−sin H, cos H)); its odometry, orientation sensor and ranges are made
from the truth with known noise, offsets and bias, so every learned quantity has a known answer.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from filterpy.common import Q_continuous_white_noise

from mavhelm.nav.ekf import (
    EKF,
    I_H,
    I_VH,
    I_VX,
    I_VY,
    I_X,
    I_Y,
    Beacon,
    BodyVelocity,
    EKFConfig,
    NavigationFailure,
    Position,
    Range,
    Yaw,
    odometry,
    white_noise_block,
)
from mavhelm.nav.filter_safety import DivergenceMonitor
from mavhelm.nav.fusion import Start
from mavhelm.nav.lsq import LSQ, Fix, solve
from mavhelm.nav.replay import accuracy
from tests.support.fusion_rig import replay, track_accuracy

BEACONS = [Beacon("A", -30.0, -30.0), Beacon("B", 30.0, -30.0), Beacon("C", 30.0, 30.0),
           Beacon("D", -30.0, 30.0)]


def circle_run(seconds: float = 300.0, *, offset: float = 0.0, yaw_bias: float = 0.0,
               range_noise: float = 0.3, seed: int = 1, outlier_every: int = 0,
               range_scale: float = 0.0, speed_scale: float = 0.0):
    """Observations and truth of a 1 m/s circle (radius 20 m) around (5, 0).

    Odometry at 5 Hz (as distance and yaw change; the distance ``speed_scale`` × itself
    long), the orientation sensor at 5 Hz reading yaw + ``yaw_bias``, one range every 0.5 s
    in turn to A, B, C, D, each ``range_scale`` × distance + ``offset`` long.
    """
    rng = np.random.default_rng(seed)
    speed, radius, centre = 1.0, 20.0, (5.0, 0.0)
    omega = speed / radius
    h0 = 0.3

    def pose(t: float) -> tuple[float, float, float]:
        h = h0 + omega * t
        return centre[0] + radius * math.cos(h), centre[1] + radius * math.sin(h), h

    obs: list = []
    truth: list[tuple[float, float, float]] = []
    dt = 0.2
    for k in range(1, int(seconds / dt) + 1):
        t = k * dt
        x, y, h = pose(t)
        truth.append((t, x, y))
        obs.append(odometry(t, dt, (1 + speed_scale) * speed * dt + rng.normal(0, 0.005),
                            omega * dt + rng.normal(0, 0.002)))
        obs.append(Yaw(t, math.remainder(h + yaw_bias + rng.normal(0, 0.01), 2 * math.pi)))
    n_ranges = int(seconds / 0.5)
    for k in range(1, n_ranges + 1):
        t = k * 0.5 + 0.05
        x, y, _ = pose(t)
        b = BEACONS[k % 4]
        z = (1 + range_scale) * math.hypot(x - b.x, y - b.y) + offset \
            + rng.normal(0, range_noise)
        if outlier_every and k % outlier_every == 0:
            z += 50.0
        obs.append(Range(t, b.name, z, sigma=max(range_noise, 0.3)))
    obs.sort(key=lambda o: o.t)
    start = pose(0.0)
    return obs, np.array(truth), start


# ------------------------------------------------------------------------------ shapes


def test_state_layout_and_shapes() -> None:
    ekf = EKF(0.0, 1.0, 2.0, 0.5, beacons=BEACONS[:2],
              config=EKFConfig(estimate_yaw_bias=True))
    # X Y H Ẋ Ẏ Ḣ, heading bias and its drift rate, range scale, two offsets
    assert ekf.dim == 11
    assert ekf.x.shape == (11, 1) and ekf.P.shape == (11, 11)
    assert (ekf.i_bias, ekf.i_drift, ekf.i_scale) == (6, 7, 8)
    assert [ekf.offset_index(b) for b in ("A", "B")] == [9, 10]
    assert ekf.state_names() == ["X", "Y", "H", "X_VEL", "Y_VEL", "H_VEL", "YAW_BIAS",
                                 "YAW_DRIFT", "RANGE_SCALE", "OFFSET_A", "OFFSET_B"]
    ekf.predict(0.5)
    assert ekf.F.shape == ekf.Q.shape == (11, 11)
    assert ekf.F[I_X, I_VX] == ekf.F[I_Y, I_VY] == ekf.F[I_H, I_VH] == 0.5
    assert ekf.F[6, 7] == 0.5  # the bias moves at its drift rate
    plain = EKF(0.0, 1.0, 2.0, 0.5, beacons=BEACONS[:2],
                config=EKFConfig(estimate_yaw_bias=True, estimate_yaw_drift=False))
    assert plain.dim == 10 and plain.i_drift is None and plain.i_scale == 7
    bare = EKF(0.0, 0, 0)  # no beacons, no bias asked for
    assert bare.dim == 6 and bare.i_bias is None and bare.i_scale is None


def test_a_drifting_bias_is_carried_on_at_its_learned_rate() -> None:
    """EKF_YAW_DRIFT: the bias and its rate are a constant-velocity pair. A compass whose
    bias drifts at 0.5°/s while positions pin the heading teaches the filter that rate; when
    the positions stop, the bias goes on at it (a random-walk bias alone would stay where it
    was), so the heading taken out of the compass stays right."""
    rate = math.radians(0.5)

    def run(drift: bool) -> tuple[EKF, float]:
        ekf = EKF(0.0, 0.0, 0.0, config=EKFConfig(estimate_yaw_bias=True,
                                                  estimate_yaw_drift=drift,
                                                  velocity_follows_heading=True))
        t = 0.0
        for k in range(1, 1201):  # north at 1 m/s (yaw 0), 10 Hz
            t = k * 0.1
            ekf.advance(t)
            observations: list = [Yaw(t, rate * t, sigma=math.radians(0.5)),
                                  BodyVelocity(t, 1.0, 0.0, None, 0.05, 0.05)]
            if t <= 90.0:  # positions for 90 s, then 30 s without
                observations.append(Position(t, 0.0, t, sigma=0.3))
            ekf.update(observations)
        return ekf, t
    with_rate, t = run(True)
    assert with_rate.x[with_rate.i_drift, 0] == pytest.approx(rate, rel=0.1)
    assert with_rate.x[I_H, 0] == pytest.approx(0.0, abs=math.radians(2.0))
    without, _ = run(False)
    assert abs(without.x[I_H, 0]) > math.radians(5.0)  # 30 s × 0.5°/s taken as a turn
    twin = EKF(0.0, 0.0, 0.0, config=EKFConfig()).with_yaw_bias()  # added, not declared:
    assert twin.state_names()[6:] == ["YAW_BIAS", "YAW_DRIFT"]  # its rate as EKF_YAW_DRIFT says
    alone = EKF(0.0, 0.0, 0.0, config=EKFConfig(estimate_yaw_drift=False)).with_yaw_bias()
    assert alone.state_names()[6:] == ["YAW_BIAS"]


def test_an_integrated_headings_yaw_rate_reads_its_drift_and_the_heading_holds_without_fixes(
) -> None:
    """An odometer's heading is its yaw rate integrated, so when the heading drifts (1°/s
    here, the boat going straight north) its yaw rate reads that drift too. Taken as the
    boat's turn, the rate carried the heading off with the sensor through 60 s without
    positions while the bias held (Plaza1, 180° within two minutes across its 100 s without
    ranges: 1.89 m RMS); read as the drift (the bias's rate state), the heading holds."""
    drift = math.radians(1.0)

    def run(integrated: bool) -> tuple[EKF, float]:
        ekf = EKF(0.0, 0.0, 0.0, config=EKFConfig(estimate_yaw_bias=True,
                                                  velocity_follows_heading=True))
        worst = 0.0
        for k in range(1, 1801):  # north at 1 m/s (yaw 0), 10 Hz
            t = k * 0.1
            ekf.advance(t)
            observations: list = [Yaw(t, math.remainder(drift * t, 2 * math.pi),
                                      sigma=math.radians(0.5)),
                                  BodyVelocity(t, 1.0, 0.0, drift, 0.05, 0.05,
                                               math.radians(0.5), integrated=integrated)]
            if t <= 120.0:  # positions for 120 s, then 60 s without
                observations.append(Position(t, 0.0, t, sigma=0.3))
            ekf.update(observations)
            if t > 120.0:
                worst = max(worst, abs(math.remainder(ekf.x[I_H, 0], 2 * math.pi)))
        return ekf, worst
    read_as_drift, worst = run(True)
    assert read_as_drift.x[read_as_drift.i_drift, 0] == pytest.approx(drift, rel=0.1)
    assert worst < math.radians(0.5)  # measured 0.00002°
    _, carried_off = run(False)
    assert carried_off > math.radians(15.0)  # measured 21.4°
    # the row itself: (1 + κ) ω + ḃ, its Jacobian 1 on the drift
    ekf = EKF(0.0, 0.0, 0.0, config=EKFConfig(estimate_yaw_bias=True, estimate_yaw_scale=True))
    ekf.x[I_VH, 0], ekf.x[ekf.i_yaw_scale, 0], ekf.x[ekf.i_drift, 0] = 0.2, 0.05, 0.01
    ((measured, predicted, jacobian, _var, _angle),) = ekf._rows(
        BodyVelocity(0.0, None, None, 0.3, integrated=True), ekf.x[:, 0].tolist())
    assert predicted == pytest.approx(1.05 * 0.2 + 0.01)
    assert dict(jacobian) == {I_VH: pytest.approx(1.05), ekf.i_yaw_scale: pytest.approx(0.2),
                              ekf.i_drift: 1.0}


def test_an_integrated_headings_scale_error_is_learned_and_carried_through_the_turns() -> None:
    """EKF_YAW_SCALE: an odometer's heading is its yaw rate integrated, both 6 % long, so
    the heading's error grows with each turn and unwinds with the next turn back, which no
    drift in time follows. A boat weaving (0.15 rad/s left for 30 s, then right) with
    positions for 150 s learns the scale, and carries the heading through 60 s without them
    on it (2.9° at worst); without the state the bias trails the turns (10.7°)."""
    kappa, dt = 0.06, 0.1

    def run(scaled: bool) -> tuple[EKF, float]:
        ekf = EKF(0.0, 0.0, 0.0, config=EKFConfig(
            estimate_yaw_bias=True, estimate_yaw_scale=scaled, velocity_follows_heading=True))
        yaw = x = y = 0.0
        worst = 0.0
        for k in range(1, 2101):
            t = k * dt
            w = 0.15 if (t // 30.0) % 2 == 0 else -0.15
            yaw += w * dt
            x, y = x - math.sin(yaw) * dt, y + math.cos(yaw) * dt
            ekf.advance(t)
            observations: list = [Yaw(t, math.remainder((1 + kappa) * yaw, 2 * math.pi),
                                      sigma=math.radians(0.5)),
                                  BodyVelocity(t, 1.0, 0.0, (1 + kappa) * w, 0.05, 0.05,
                                               math.radians(0.5), integrated=True)]
            if t <= 150.0:
                observations.append(Position(t, x, y, sigma=0.3))
            ekf.update(observations)
            if t > 150.0:
                worst = max(worst, abs(math.remainder(ekf.x[I_H, 0] - yaw, 2 * math.pi)))
        return ekf, worst
    scaled, worst = run(True)
    assert scaled.state_names()[6:9] == ["YAW_BIAS", "YAW_DRIFT", "YAW_SCALE"]
    assert scaled.x[scaled.i_yaw_scale, 0] == pytest.approx(kappa, abs=0.01)
    assert worst < math.radians(4.0)  # measured 2.9°
    assert scaled.estimate().yaw_scale == scaled.x[scaled.i_yaw_scale, 0]
    _, trailing = run(False)
    assert trailing > math.radians(8.0)  # measured 10.7°


def test_the_yaw_scale_moves_the_bias_with_the_turn_and_reads_the_yaw_rate_long() -> None:
    ekf = EKF(0.0, 0.0, 0.0, config=EKFConfig(estimate_yaw_bias=True, estimate_yaw_drift=False,
                                              estimate_yaw_scale=True))
    ekf.x[I_VH, 0], ekf.x[ekf.i_yaw_scale, 0], ekf.x[ekf.i_bias, 0] = 0.2, 0.05, 0.1
    ekf.predict(0.5)
    assert ekf.x[ekf.i_bias, 0] == pytest.approx(0.1 + 0.5 * 0.05 * 0.2)  # b + dt κ ω
    # the covariance moved by the linearised step: ∂b/∂κ = dt ω, ∂b/∂ω = dt κ
    assert ekf._F[ekf.i_bias, ekf.i_yaw_scale] == pytest.approx(0.5 * 0.2)
    assert ekf._F[ekf.i_bias, I_VH] == pytest.approx(0.5 * 0.05)
    # a gyro of its own (not integrated into the heading) is read as the yaw rate
    w = ekf.x[I_VH, 0]
    for integrated, expected in ((True, 1.05 * w), (False, w)):
        result = ekf.update([BodyVelocity(ekf.t, None, None, expected, integrated=integrated)])
        assert result.verdicts[0].innovation == pytest.approx(0.0, abs=1e-12), integrated
    off = EKF(0.0, 0.0, 0.0, config=EKFConfig(estimate_yaw_scale=True))  # no bias: no scale
    assert off.i_yaw_scale is None


def test_process_noise_is_filterpys_continuous_white_noise_scaled_by_dynamics() -> None:
    for dt in (0.01, 0.2, 3.0):
        expected = Q_continuous_white_noise(dim=2, dt=dt, spectral_density=1.0)
        assert np.allclose(np.reshape(white_noise_block(dt), (2, 2)), expected)
    ekf = EKF(0.0, 0, 0, config=EKFConfig(xy_dynamics=10, yaw_dynamics=0))
    ekf.predict(1.0)
    assert np.allclose(ekf.Q[np.ix_([I_X, I_VX], [I_X, I_VX])],
                       Q_continuous_white_noise(2, 1.0, 1.0))
    assert ekf.Q[I_VH, I_VH] == 0.0  # yaw dynamics 0: the yaw rate never changes
    with pytest.raises(ValueError, match="xy_dynamics"):
        EKFConfig(xy_dynamics=11)


def test_constant_velocity_prediction_grows_uncertainty() -> None:
    ekf = EKF(0.0, 0.0, 0.0, beacons=())
    ekf.x[I_VX, 0], ekf.x[I_VY, 0], ekf.x[I_VH, 0] = 1.0, -0.5, 0.1
    before = np.trace(ekf.P)
    ekf.advance(2.0)
    e = ekf.estimate()
    assert (e.x, e.y, e.t) == pytest.approx((2.0, -1.0, 2.0))
    assert e.yaw == pytest.approx(0.2)
    assert np.trace(ekf.P) > before
    assert ekf.forecast(3.0).x == pytest.approx(3.0)
    assert ekf.estimate().x == pytest.approx(2.0)  # forecasting changes nothing
    ekf.advance(1.0)  # the past: nothing to do
    assert ekf.t == 2.0


def test_position_update_is_the_textbook_kalman_correction() -> None:
    ekf = EKF(0.0, 10.0, -4.0, beacons=(), config=EKFConfig(sigma_xy=4.0))
    result = ekf.update(Position(0.0, 13.0, -4.0, sigma=3.0))
    assert result.rejected == []
    gain = 16.0 / (16.0 + 9.0)
    assert ekf.x[I_X, 0] == pytest.approx(10.0 + gain * 3.0)
    assert ekf.P[I_X, I_X] == pytest.approx((1 - gain) * 16.0)
    assert ekf.mahalanobis == pytest.approx(3.0 / 5.0)  # filterpy's, after the update


def test_the_short_form_update_equals_filterpys_joseph_form() -> None:
    """The update is written out (P − K S Kᵀ) for speed; on the filter's real updates —
    a converged run's ranges, body velocity and yaw together — it matches filterpy's own
    Joseph-form ``update`` to round-off."""
    from filterpy.kalman import ExtendedKalmanFilter

    ekf = converged_filter()
    ekf.advance(ekf.t + 0.2)
    guess = [Range(ekf.t, "A", 0.0), Range(ekf.t, "C", 0.0), BodyVelocity(ekf.t, 0, 0, 0),
             Yaw(ekf.t, 0.0)]
    hx0 = [ekf._linearise(o).hx for o in guess]  # what the filter expects, nudged below
    slice_ = [Range(ekf.t, "A", hx0[0][0] + 0.4), Range(ekf.t, "C", hx0[1][0] - 0.3),
              BodyVelocity(ekf.t, hx0[2][0] + 0.02, hx0[2][1] - 0.03, hx0[2][2] + 0.01),
              Yaw(ekf.t, hx0[3][0] + 0.01)]
    rows = [ekf._linearise(o) for o in slice_]
    H = np.vstack([r.H for r in rows])
    hx = np.concatenate([r.hx for r in rows])
    z = np.concatenate([r.z for r in rows])
    R = np.diag(np.concatenate([r.r for r in rows]))
    reference = ExtendedKalmanFilter(dim_x=ekf.dim, dim_z=len(z))
    reference.x, reference.P = ekf.x.copy(), ekf.P.copy()
    reference.update(z.reshape(-1, 1), lambda _x: H, lambda _x: hx.reshape(-1, 1), R=R,
                     residual=lambda a, b: np.where(np.arange(len(z))[:, None] == 5,
                                                    (a - b + np.pi) % (2 * np.pi) - np.pi,
                                                    a - b))
    result = ekf.update(slice_)
    assert result.rejected == []
    assert np.allclose(ekf.x, reference.x, atol=1e-9)
    assert np.allclose(ekf.P, reference.P, atol=1e-12)


def test_yaw_innovation_wraps_around_pi() -> None:
    cfg = EKFConfig(sigma_yaw=0.1)
    ekf = EKF(0.0, 0, 0, math.pi - 0.05, config=cfg)
    ekf.update(Yaw(0.0, -math.pi + 0.05, sigma=0.1))  # 0.1 rad away, not 2π − 0.1
    assert abs(math.remainder(ekf.estimate().yaw - math.pi, 2 * math.pi)) < 0.05


def test_body_velocity_sets_earth_velocity_along_the_bow() -> None:
    cfg = EKFConfig(sigma_yaw=0.01)
    heading_east = -math.pi / 2  # yaw = −heading: 90° east
    ekf = EKF(0.0, 0, 0, heading_east, config=cfg)
    ekf.update(BodyVelocity(0.0, forward=2.0, starboard=0.0, yaw_rate=0.0))
    e = ekf.estimate()
    assert e.x_vel == pytest.approx(2.0, abs=0.05) and abs(e.y_vel) < 0.05
    assert e.heading == pytest.approx(90.0, abs=0.5)
    bv = odometry(1.0, 0.2, 0.4, -0.02)
    assert (bv.forward, bv.starboard, bv.yaw_rate) == pytest.approx((2.0, 0.0, -0.1))


# ------------------------------------------------------------------------------ rejection


def converged_filter() -> EKF:
    obs, truth, start = circle_run(120.0)
    track = replay(obs, BEACONS, start=Start(start[0], start[1], start[2], 2.0))
    assert track.failure is None
    ekf = EKF(track.final.t, track.final.x, track.final.y, track.final.yaw, beacons=BEACONS,
              sigma_xy=0.3, sigma_yaw=0.05, config=EKFConfig(sigma_beacon_offset=0.2,
                                                             sigma_range_scale=0.005))
    return ekf


def test_chi2_gate_rejects_a_50_m_range_outlier_and_keeps_the_state() -> None:
    ekf = converged_filter()
    b = BEACONS[0]
    true_range = math.hypot(ekf.x[0, 0] - b.x, ekf.x[1, 0] - b.y)
    x_before = ekf.x.copy()
    result = ekf.update(Range(ekf.t, b.name, true_range + 50.0))
    assert len(result.rejected) == 1 and result.verdicts[0].d2 > 100
    assert np.array_equal(ekf.x, x_before)
    good = Range(ekf.t, "B", math.hypot(ekf.x[0, 0] - 30, ekf.x[1, 0] + 30) + 0.2)
    bad = Range(ekf.t, "C", math.hypot(ekf.x[0, 0] - 30, ekf.x[1, 0] - 30) + 50.0)
    result = ekf.update([good, bad])
    assert result.accepted == [good] and result.rejected == [bad]


def test_joint_test_drops_the_worse_of_a_pair_that_passes_alone() -> None:
    ekf = EKF(0.0, 0.0, 0.0, config=EKFConfig(sigma_xy=0.01))
    # each fix alone is inside its 2-dof gate (13.8), together they fail the 4-dof one (18.5)
    worse = Position(0.0, 3.6, 0.0, sigma=1.0)   # d² ≈ 13.0
    better = Position(0.0, 0.0, 3.3, sigma=1.0)  # d² ≈ 10.9
    result = ekf.update([worse, better])
    assert all(v.d2 < 13.8 for v in result.verdicts)
    assert result.accepted == [better] and result.rejected == [worse]
    # a consistent pair is taken whole
    ekf2 = EKF(0.0, 0.0, 0.0, config=EKFConfig(sigma_xy=0.01))
    result = ekf2.update([Position(0.0, 1.0, 0.0, 1.0), Position(0.0, 0.0, 1.0, 1.0)])
    assert result.rejected == []


def test_run_with_outliers_rejects_them_all() -> None:
    obs, truth, start = circle_run(200.0, outlier_every=7)
    track = replay(obs, BEACONS, start=Start(start[0], start[1], start[2], 2.0))
    n_outliers = sum(1 for k in range(1, 401) if k % 7 == 0)
    assert track.rejected >= n_outliers
    acc = track_accuracy(track, truth[:, 0], truth[:, 1], truth[:, 2])
    assert acc.rms < 1.0


# ------------------------------------------------------------------------------ hidden states


def test_beacon_offset_of_3_m_is_learned() -> None:
    obs, truth, start = circle_run(400.0, offset=3.0)
    track = replay(obs, BEACONS, start=Start(start[0] + 3.0, start[1] - 4.0, start[2], 5.0))
    assert track.failure is None
    offsets = track.final.offsets
    print("learned offsets", {k: round(v, 2) for k, v in offsets.items()},
          "scale", round(track.final.range_scale, 4))
    for name in "ABCD":
        assert offsets[name] == pytest.approx(3.0, abs=0.6)
    assert abs(track.final.range_scale) < 0.02
    tail = track.t > track.t[-1] - 100
    acc = accuracy(track.t[tail], track.x[tail], track.y[tail], truth[:, 0], truth[:, 1],
                   truth[:, 2])
    assert acc.rms < 0.5


def test_ranges_5_percent_long_are_a_scale_not_an_offset() -> None:
    """The odometer taken at its word (EKF_SPEED_SCALE = false). With its scale learned too
    (the default), a circle tells the two scales apart only slowly: range scale 0.037 and
    speed scale −0.012 after 400 s, 0.042 and −0.007 after 1200 s, the position as good
    (0.42 m, 0.20 m RMS over the last 100 s)."""
    obs, truth, start = circle_run(400.0, range_scale=0.05)
    track = replay(obs, BEACONS, start=Start(start[0] + 3.0, start[1] - 4.0, start[2], 5.0),
                   speed_scale=False)
    assert track.final.range_scale == pytest.approx(0.05, abs=0.01)
    assert all(abs(v) < 0.6 for v in track.final.offsets.values())
    tail = track.t > track.t[-1] - 100
    acc = accuracy(track.t[tail], track.x[tail], track.y[tail], truth[:, 0], truth[:, 1],
                   truth[:, 2])
    assert acc.rms < 0.5


@pytest.mark.parametrize("scale", [0.08, -0.1])
def test_an_odometer_off_its_wheel_size_is_learned_against_the_ranges(scale: float) -> None:
    """Odometry 8 % long or 10 % short: the speed-scale state (added at the first speed, as
    EKF_SPEED_SCALE says by default) takes it; without it the position trails or leads the
    ranges all the way round."""
    obs, truth, start = circle_run(400.0, speed_scale=scale)
    begin = Start(start[0] + 3.0, start[1] - 4.0, start[2], 5.0)
    tail_rms = []
    for learned in (True, False):
        track = replay(obs, BEACONS, start=begin, speed_scale=learned)
        tail = track.t > track.t[-1] - 100
        tail_rms.append(accuracy(track.t[tail], track.x[tail], track.y[tail], truth[:, 0],
                                 truth[:, 1], truth[:, 2]).rms)
        if learned:
            assert track.final.speed_scale == pytest.approx(scale, abs=0.02)
    assert tail_rms[0] < 0.5 and tail_rms[0] < tail_rms[1], tail_rms


def test_heading_bias_of_5_degrees_is_learned() -> None:
    bias = math.radians(5.0)
    obs, truth, start = circle_run(300.0, yaw_bias=bias)
    track = replay(obs, BEACONS, start=Start(start[0], start[1], start[2], 2.0),
                   config=EKFConfig(estimate_yaw_bias=True))
    assert math.degrees(track.final.yaw_bias) == pytest.approx(5.0, abs=1.0)
    true_yaw = 0.3 + track.final.t / 20.0
    assert abs(math.remainder(track.final.yaw - true_yaw, 2 * math.pi)) < math.radians(1.0)


# ------------------------------------------------------------------------------ safety


def test_silly_rate_states_are_reset_with_a_warning() -> None:
    ekf = EKF(0.0, 0, 0)
    ekf.x[I_VX, 0] = 12.0
    ekf.predict(0.1)
    assert ekf.x[I_VX, 0] == 0.0 and ekf.rate_resets == 1
    assert "exceeds 10 m/s" in ekf.warnings[-1]
    assert ekf.P[I_VX, I_X] == 0.0
    ekf.x[I_VH, 0] = -4.0
    ekf.predict(0.1)
    assert ekf.x[I_VH, 0] == 0.0 and ekf.rate_resets == 2
    assert "yaw rate" in ekf.warnings[-1]


def test_navigation_failure_when_position_is_unobservable() -> None:
    cfg = EKFConfig(sigma_xy=2.0, max_position_sigma=10.0)
    ekf = EKF(0.0, 0, 0, config=cfg)
    t = 0.0
    with pytest.raises(NavigationFailure, match="exceeds the limit 10"):
        for _ in range(1000):  # heading only: the position drifts unobserved
            t += 0.5
            ekf.advance(t)
            ekf.update(Yaw(t, 0.0))
    assert not ekf.online and t < 400
    with pytest.raises(NavigationFailure):
        ekf.update(Yaw(t, 0.0))
    # replay reports it and stops
    obs = [Yaw(0.5 * k, 0.0) for k in range(1, 2000)]
    track = replay(obs, [], config=cfg, start=Start(0, 0, 0, 2.0))
    assert track.failure and "exceeds the limit" in track.failure
    assert track.t[-1] < 400


# ------------------------------------------------------------------------------ LSQ


def test_lsq_solves_three_exact_ranges_and_a_common_offset_with_four() -> None:
    beacons = {b.name: b for b in BEACONS}
    p = (7.0, -12.0)
    ranges = [Range(0.0, n, math.hypot(p[0] - b.x, p[1] - b.y)) for n, b in beacons.items()]
    fix = solve(ranges[:3], beacons)
    assert fix is not None and (fix.x, fix.y) == pytest.approx(p, abs=1e-3)
    assert solve(ranges[:2], beacons) is None  # unobservable
    long = [replace(r, z=r.z + 2.5) for r in ranges]
    fix = solve(long, beacons, estimate_offset=True)
    assert fix is not None and (fix.x, fix.y, fix.offset) == pytest.approx((*p, 2.5), abs=1e-3)


def test_lsq_accrues_until_observable_and_drops_a_bad_range() -> None:
    lsq = LSQ(BEACONS, window=5.0)
    p = (-3.0, 8.0)

    def rng(t: float, name: str, extra: float = 0.0) -> Range:
        b = next(b for b in BEACONS if b.name == name)
        return Range(t, name, math.hypot(p[0] - b.x, p[1] - b.y) + extra)

    assert lsq.add(rng(0.0, "A")) is None
    assert lsq.add(rng(0.5, "B")) is None
    assert lsq.add(rng(10.0, "C")) is None  # A and B are too old now: unobservable
    assert lsq.add(rng(10.5, "D", extra=25.0)) is None
    # three beacons, one of them 25 m long: inconsistent, no fix, and the window starts again
    assert lsq.add(rng(11.0, "A")) is None
    assert (lsq.failures, lsq.last_fix) == (1, None)
    # waiting for four beacons, one bad: the one whose absence leaves a consistent fix goes
    lsq = LSQ(BEACONS, window=5.0, min_beacons=4)
    for t, name in ((12.0, "A"), (12.5, "B"), (13.0, "C")):
        assert lsq.add(rng(t, name, extra=25.0 if name == "B" else 0.0)) is None
    fix = lsq.add(rng(13.5, "D"))
    assert fix is not None and (fix.x, fix.y) == pytest.approx(p, abs=0.01)
    assert lsq.rejected == 1 and fix.beacons == ("A", "C", "D")
    assert lsq.add(rng(14.0, "C")) is None  # starts from scratch after a fix


def test_divergence_monitor_needs_six_disagreements_in_a_row() -> None:
    mon = DivergenceMonitor()
    far = Fix(0.0, 30.0, 0.0, 1.0, 0.1, 3, ("A", "B", "C"))
    near = replace(far, x=5.0)
    assert [mon.check(far, 0.0, 0.0) for _ in range(5)] == [False] * 5
    assert mon.check(near, 0.0, 0.0) is False  # agreement resets the count
    assert [mon.check(far, 0.0, 0.0) for _ in range(6)] == [False] * 5 + [True]


# ------------------------------------------------------------------------------ replay


def test_replay_boots_from_the_lsq_without_a_start() -> None:
    obs, truth, _ = circle_run(200.0, offset=1.0)
    track = replay(obs, BEACONS)
    assert track.boot_fix is not None and track.boot_fix.t < 30.0
    tail = track.t > 100
    acc = accuracy(track.t[tail], track.x[tail], track.y[tail], truth[:, 0], truth[:, 1],
                   truth[:, 2])
    assert acc.rms < 0.6


def test_a_diverged_filter_is_reinitialised_to_the_lsq() -> None:
    obs, truth, start = circle_run(200.0)
    # 60 m off and sure of it: every range is refused, the filter cannot recover by itself
    track = replay(obs, BEACONS, start=Start(start[0] + 60.0, start[1], start[2], 0.5))
    assert track.reinitialisations >= 1
    assert any("re-initialised" in w for w in track.warnings)
    tail = track.t > 100
    acc = accuracy(track.t[tail], track.x[tail], track.y[tail], truth[:, 0], truth[:, 1],
                   truth[:, 2])
    assert acc.rms < 1.0


def test_accuracy_interpolates_truth_in_time() -> None:
    truth_t, truth_x, truth_y = np.array([0.0, 10.0]), np.array([0.0, 10.0]), np.zeros(2)
    acc = accuracy(np.array([5.0, 2.5, 20.0]), np.array([5.0, 3.5, 0.0]), np.zeros(3),
                   truth_t, truth_x, truth_y)
    assert acc.n == 2  # t = 20 is outside the truth
    assert acc.rms == pytest.approx(math.sqrt(0.5)) and acc.max == pytest.approx(1.0)


def test_forget_turn_takes_the_heading_and_rate_back_to_their_priors() -> None:
    """What a reversed yaw rate taught (:mod:`mavhelm.nav.rate_sense`): the rate and its
    scale back at their priors, the heading the sensor's less its bias, each uncorrelated."""
    cfg = EKFConfig(estimate_yaw_bias=True, estimate_yaw_scale=True)
    ekf = EKF(0.0, 0.0, 0.0, config=cfg)
    for k in range(1, 30):  # a fight: a heading turning left, a rate saying right
        ekf.advance(0.2 * k)
        ekf.update([Yaw(0.2 * k, 0.05 * k), BodyVelocity(0.2 * k, 1.0, 0.0, -0.25)])
    assert abs(ekf.x[I_VH, 0]) > 0.01 and ekf.P[I_H, I_VH] != 0.0
    ekf.forget_turn(1.0)
    assert ekf.x[I_VH, 0] == 0.0 and ekf.x[I_H, 0] == pytest.approx(1.0)
    assert ekf.x[ekf.i_yaw_scale, 0] == 0.0
    for i, sigma in ((I_VH, cfg.sigma_yaw_rate), (I_H, cfg.sigma_yaw),
                     (ekf.i_yaw_scale, cfg.sigma_yaw_scale)):
        assert ekf.P[i, i] == pytest.approx(sigma**2)
        assert np.count_nonzero(ekf.P[i]) == 1
    np.linalg.cholesky(ekf.P)  # still positive definite


def test_a_held_speed_scale_is_considered_not_learned() -> None:
    """``hold_speed_scale`` (the fusion holds it while a yaw rate or heading may turn the wrong
    way): a speed that disagrees with the filter's velocity moves the velocity, not the
    scale, whose uncertainty still widens the speed's innovation; the covariance stays
    symmetric and positive definite (the non-optimal gain's full update)."""
    def moved(hold: bool) -> tuple[EKF, float]:
        ekf = EKF(0.0, 0.0, 0.0, config=EKFConfig(estimate_speed_scale=True))
        ekf.update(BodyVelocity(0.0, forward=2.0, sigma_forward=0.05))
        before = ekf.kf.x.item(ekf.i_speed)
        ekf.hold_speed_scale = hold
        ekf.predict(0.1)
        ekf.update(BodyVelocity(0.1, forward=2.6, sigma_forward=0.05))
        return ekf, ekf.kf.x.item(ekf.i_speed) - before
    held, change = moved(True)
    assert change == 0.0
    learned, change_free = moved(False)
    assert abs(change_free) > 1e-4
    P = held.kf.P
    assert np.allclose(P, P.T) and np.all(np.linalg.eigvalsh(P) > 0)
    assert P[held.i_speed, held.i_speed] == pytest.approx(
        learned.config.sigma_speed_scale**2, rel=0.5)  # not shrunk by what it did not learn
