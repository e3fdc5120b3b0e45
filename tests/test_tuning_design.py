"""``mavhelm tune``'s gain design: the turn-rate fit sees an acceleration limit, and the gains
it proposes are predicted no slower and no less damped than the product's defaults."""

from __future__ import annotations

import numpy as np
import pytest

from mavhelm.companion.tune import default_gains
from mavhelm.tuning.gains import Course, design, predict
from mavhelm.tuning.identify import Recording, identify
from mavhelm.tuning.model import Series, YawModel, fit_yaw, simulate_lag

T = np.arange(0.0, 60.0, 0.1)
TURN = np.where((T // 4) % 2 == 0, 90.0, -90.0) * (T >= 5.0)
SAMPLED = T + 0.03
SLEWED = YawModel(gain=0.8, time_constant=0.12, delay=0.1, rate_limit=60.0, rms=0.0,
                  accel_limit=110.0)
"""Close to what the real SITL motorboat fits to at 5 m/s."""


def slewing_vehicle() -> Recording:
    y = SLEWED
    rate = simulate_lag(Series(T, TURN), SAMPLED, y.gain, y.time_constant, y.delay,
                        y.rate_limit, accel=y.accel_limit)
    rate += np.random.default_rng(2).normal(0.0, 0.3, len(SAMPLED))
    thrust = np.where(T < 3.0, 40.0, 100.0)
    speed = simulate_lag(Series(T, thrust), SAMPLED, 0.05, 1.0, 0.3)
    return Recording(list(zip(T, TURN, strict=True)), list(zip(SAMPLED, rate, strict=True)),
                     list(zip(T, thrust, strict=True)), list(zip(SAMPLED, speed, strict=True)))


def test_the_fit_recovers_an_acceleration_limit():
    rec = slewing_vehicle()
    yaw = fit_yaw(Series.of(rec.turn_command), Series.of(rec.turn_rate))
    assert yaw.accel_limit == pytest.approx(110.0, rel=0.1)
    assert yaw.rate_limit == pytest.approx(60.0, abs=2.0)
    assert yaw.rms < 2.0


def test_the_gains_are_predicted_no_worse_than_the_defaults():
    tuning = identify(slewing_vehicle(), max_rudder=20.0, app_tick=10.0, cruise_thrust=100.0,
                      baseline=default_gains())
    assert tuning.baseline_prediction is not None
    assert tuning.prediction.no_worse_than(tuning.baseline_prediction)
    assert tuning.prediction.turn_swing is not None
    assert tuning.prediction.turn_swing <= tuning.baseline_prediction.turn_swing
    report = "\n".join(tuning.report())
    assert "predicted, these gains" in report and "predicted, the defaults" in report
    assert f"LeadTime {tuning.gains.lead_time:g} s" in report


def test_without_a_better_candidate_the_defaults_are_kept(monkeypatch):
    import mavhelm.tuning.gains as gains
    monkeypatch.setattr(gains, "KPSI", (0.3,))  # only a far too slow loop to choose from
    baseline = default_gains()
    chosen, prediction, reference = design(SLEWED, max_rudder=20.0, app_tick=10.0,
                                           course=Course(5.0), baseline=baseline)
    assert (chosen.yaw_kp, chosen.yaw_kd, chosen.max_turn_rate, chosen.lead_time) == \
        (baseline.yaw_kp, baseline.yaw_kd, baseline.max_turn_rate, baseline.lead_time)
    assert prediction == reference


def test_a_faster_task_swings_further_at_the_same_gains():
    g = default_gains()
    slow = predict(g, SLEWED, 2.0, max_rudder=20.0, app_tick=10.0)
    fast = predict(g, SLEWED, 5.0, max_rudder=20.0, app_tick=10.0)
    assert slow.turn_swing is not None and fast.turn_swing is not None
    assert slow.turn_swing < fast.turn_swing


def test_doubled_stamps_give_a_finite_response():
    t = np.array([0.0, 0.1, 0.1, 0.2, 0.3])
    command = Series(np.array([0.0]), np.array([50.0]))
    for accel in (np.inf, 100.0):
        out = simulate_lag(command, t, 0.05, 1.0, 0.0, accel=accel)
        assert np.all(np.isfinite(out))


def test_full_rudder_asks_for_at_least_the_fitted_rate_limit():
    from mavhelm.tuning.gains import candidates
    overshooting = YawModel(gain=2.3, time_constant=0.66, delay=0.0, rate_limit=101.0, rms=13.9,
                            accel_limit=542.0)
    assert {g.max_turn_rate for g in candidates(overshooting, 20.0)} == {101.0}
    assert {g.max_turn_rate for g in candidates(SLEWED, 20.0)} == {75.0}  # 60 / 0.8


def test_the_tracks_lag_behind_the_heading_is_fitted():
    from mavhelm.tuning.model import fit_course_lag
    t = np.arange(0.0, 40.0, 0.1)
    heading = 90.0 + 30.0 * np.sin(t / 2.0)  # zig-zags, degrees
    course = np.radians(90.0 + 30.0 * np.sin((t - 0.3) / 2.0))  # the track 0.3 s late
    east = np.cumsum(5.0 * np.sin(course) * 0.1)
    north = np.cumsum(5.0 * np.cos(course) * 0.1)
    lag = fit_course_lag(Series(t, heading), Series(t, east), Series(t, north), 4.0)
    assert lag == pytest.approx(0.3, abs=0.06)
    assert fit_course_lag(Series(t[:5], heading[:5]), Series(t[:5], east[:5]),
                          Series(t[:5], north[:5]), 4.0) == 0.0


def test_the_tunes_model_of_the_helm_matches_the_helm() -> None:
    """``tuning`` may import only core, so it restates what of the helm it simulates: the
    derivative's taps, and the planned turn onto the next line (tests/test_turn_plan.py)."""
    from mavhelm.tasks import pid, trackline
    from mavhelm.tuning import gains

    assert gains.FIR_TAPS == pid.FIR_TAPS
    assert gains.Course(None).turn_lag == trackline.TURN_LAG_S


SKID_IN_WIND = YawModel(gain=1.02, time_constant=0.19, delay=0.05, rate_limit=98.6, rms=7.62,
                        accel_limit=173.0, latency=0.04)
"""The real SITL motorboat-skid's fit at 5 m/s in the stock wind (2026-12-02): its model
predicted the stiff line loop would swing 1.5 m after a U-turn; it flies 0.18-0.25 m."""
SLOW = YawModel(gain=1.0, time_constant=0.6, delay=0.25, rate_limit=40.0, rms=0.3,
                accel_limit=128.0)
"""A vehicle slower than any the stiff line loop was measured on (lag 0.85 s)."""


def test_the_line_loop_is_the_measured_one_unless_the_vehicle_is_slower_than_any_measured():
    """The tune keeps LINE_PID asking 4.5 deg/s of turn per degree (KP scaled to the
    MaxTurnRate it writes, no KD) whatever its model predicts of it, except on a vehicle whose
    lag is beyond those it was measured on: there the line loop is searched on the model."""
    skid, _, _ = design(SKID_IN_WIND, max_rudder=20.0, app_tick=10.0, course=Course(5.0),
                        baseline=default_gains())
    assert skid.line_kd == 0.0
    assert skid.line_kp * skid.max_turn_rate / 20.0 == pytest.approx(4.5, rel=0.01)
    slow, prediction, _ = design(SLOW, max_rudder=20.0, app_tick=10.0, course=Course(2.0),
                                 baseline=default_gains())
    assert (slow.line_kp, slow.line_kd) == (slow.yaw_kp, slow.yaw_kd)
    assert prediction.turn_swing is not None and prediction.turn_swing < 0.5


def test_the_tunes_line_loop_is_the_helms_default() -> None:
    """``tuning`` imports only core: its restatement of LINE_PID's default, and the loop it
    keeps (asked turn rate per degree), are the helm's defaults at the default MaxTurnRate."""
    from mavhelm.companion.bridge.config import IMAVLINK_SCHEMA
    from mavhelm.tasks.pid import HelmGains
    from mavhelm.tuning import gains

    helm = HelmGains()
    rate = next(p.default for p in IMAVLINK_SCHEMA.params if p.name == "MaxTurnRate")
    assert (gains.DEFAULT_LINE_KP, 0.0) == (helm.line_kp, helm.line_kd)
    assert gains.LINE_LOOP_GAIN == pytest.approx(helm.line_kp * rate / helm.max_rudder)
