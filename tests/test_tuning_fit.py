"""The pure half of ``mavhelm tune``: the fits recover a known vehicle, the gains follow the
model, and writing them changes only the tuned values of a mission."""

from __future__ import annotations

import numpy as np
import pytest

from mavhelm.core.mission import parse_mission
from mavhelm.tuning.gains import KD_RATIOS, design, predict
from mavhelm.tuning.identify import Recording, identify
from mavhelm.tuning.manoeuvre import Box
from mavhelm.tuning.model import FitError, Series, fit_speed, fit_yaw, simulate_lag
from mavhelm.tuning.write import rewrite

T = np.arange(0.0, 60.0, 0.1)
TURN = np.where((T // 6) % 2 == 0, 90.0, -90.0) * (T >= 5.0)
THRUST = np.where(T < 20.0, 40.0, 80.0)
SAMPLED = T + 0.03  # telemetry arrives between helm ticks


def vehicle(tau=0.6, delay=0.3, limit=40.0, noise=0.3):
    rate = simulate_lag(Series(T, TURN), SAMPLED, 1.0, tau, delay, limit)
    rate += np.random.default_rng(1).normal(0.0, noise, len(SAMPLED))
    speed = simulate_lag(Series(T, THRUST), SAMPLED, 0.025, 2.0, 0.2)
    def pairs(t, y):
        return list(zip(t, y, strict=True))
    return Recording(pairs(T, TURN), pairs(SAMPLED, rate), pairs(T, THRUST), pairs(SAMPLED, speed))


def test_the_fits_recover_a_known_vehicle():
    rec = vehicle()
    yaw = fit_yaw(Series.of(rec.turn_command), Series.of(rec.turn_rate))
    assert yaw.time_constant == pytest.approx(0.6, abs=0.15)
    assert yaw.delay == pytest.approx(0.3, abs=0.1)
    assert yaw.rate_limit == pytest.approx(40.0, abs=2.0)
    speed = fit_speed(Series.of(rec.thrust_command), Series.of(rec.speed))
    assert speed.speed_at(100.0) == pytest.approx(2.5, rel=0.05)
    assert speed.time_constant == pytest.approx(2.0, rel=0.1)


def test_a_recording_without_excitation_is_refused():
    flat = Series(T, np.zeros_like(T))
    with pytest.raises(FitError, match="never changed"):
        fit_yaw(flat, Series(SAMPLED, np.zeros_like(T)))
    with pytest.raises(FitError, match="too short"):
        fit_yaw(Series(T[:5], TURN[:5]), Series(SAMPLED[:5], TURN[:5]))


def test_gains_follow_the_model():
    tuning = identify(vehicle(), max_rudder=20.0, app_tick=10.0, cruise_thrust=80.0)
    # a good fit is trusted and searched (a poor one keeps the defaults: test_tuning_trust)
    assert tuning.trusted and not any("not trusted" in line for line in tuning.report())
    g = tuning.gains
    assert g.max_turn_rate == pytest.approx(40.0, abs=2.0)
    assert 0.0 <= g.yaw_kd <= KD_RATIOS[-1] * g.yaw_kp + 1e-3  # searched: test_tuning_design
    slow, _, _ = design(tuning.yaw.__class__(1.0, 0.6, 0.8, 40.0, 0.0), max_rudder=20.0,
                        app_tick=10.0)
    assert slow.loop_gain < g.loop_gain  # a longer delay gets a slower loop
    assert g.lead(4.0) > g.lead(2.0) >= 1.0  # a faster task gets a longer Lead
    p = predict(g, tuning.yaw, 2.0, max_rudder=20.0, app_tick=10.0)
    assert 0.5 < p.heading_settle < 8.0 and p.heading_overshoot < 5.0
    assert p.line_settle is not None and p.line_settle < 20.0
    assert any("YAW_PID_KP" in line for line in tuning.report())


MISSION = """// tune me
LatOrigin = 56.4
LongOrigin = -5.4
ProcessConfig = iMAVLink
{
    MaxTurnRate = 45   // the default
}
ProcessConfig = pHelm
{
    AppTick = 10
    YAW_PID_KP = 0.5
    Task = TrackLine
    {
        P2 = 0, 100
        Thrust = 50
    }
    Task = Survey
    {
        Center = 0, 50
        A = 80
        B = 40
        Spacing = 20
        Lead = 5
    }
}
"""


def test_rewrite_changes_only_the_tuned_values():
    out = rewrite(MISSION, "m.moos", yaw_kp=0.8, yaw_kd=0.3, max_turn_rate=60.0,
                  lead_for=lambda thrust: 2.0 if thrust == 50.0 else 3.5, line_kp=1.5,
                  line_kd=0.0)
    assert "MaxTurnRate = 60   // the default" in out
    assert "YAW_PID_KP = 0.8" in out and "YAW_PID_KD = 0.3" in out
    assert "LINE_PID_KP = 1.5" in out and "LINE_PID_KD = 0" in out
    mission = parse_mission(out, "m.moos")
    helm = mission.process("pHelm")
    assert helm is not None
    assert [t.get("Lead") for t in helm.tasks] == ["2", "3.5"]
    removed = set(MISSION.splitlines()) - set(out.splitlines())
    assert removed == {"    MaxTurnRate = 45   // the default", "    YAW_PID_KP = 0.5",
                       "        Lead = 5"}


@pytest.mark.parametrize("text", ["1,2,3", "0,0,inf,50", "0,0,10,50", "50,0,0,50", "a,b,c,d"])
def test_box_refusals(text):
    with pytest.raises(ValueError, match="--box"):
        Box.parse(text)
