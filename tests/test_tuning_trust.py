"""A turn-rate model that leaves much of the response unexplained does not choose gains: the
tune keeps the defaults and says why (``mavhelm.tuning.identify.TRUSTED_FIT_RMS``)."""

from __future__ import annotations

from dataclasses import replace

from mavhelm.tuning.gains import Course, Gains, design
from mavhelm.tuning.identify import TRUSTED_FIT_RMS, identify
from mavhelm.tuning.model import YawModel
from tests.test_tuning_fit import vehicle

DEFAULTS = Gains(0.75, 0.2, 90.0, 1.5, 0.0)


def test_a_poor_fit_keeps_the_defaults_and_says_so():
    tuning = identify(vehicle(noise=3.0 * TRUSTED_FIT_RMS), max_rudder=20.0, app_tick=10.0,
                      cruise_thrust=80.0, baseline=DEFAULTS)
    assert tuning.yaw.rms > TRUSTED_FIT_RMS and not tuning.trusted
    assert replace(tuning.gains, loop_gain=0.0) == DEFAULTS
    assert tuning.prediction == tuning.baseline_prediction
    assert any("not trusted, the defaults kept" in line for line in tuning.report())


def test_design_without_search_predicts_the_baseline():
    yaw = YawModel(1.0, 0.13, 0.1, 100.0, 12.0, 165.0)
    gains, prediction, reference = design(yaw, max_rudder=20.0, app_tick=10.0,
                                          course=Course(5.0, 0.5, 0.25), baseline=DEFAULTS,
                                          search=False)
    assert replace(gains, loop_gain=0.0) == DEFAULTS and prediction == reference
    assert prediction.turn_swing is not None
