"""The simulator's GPS receiver and EKF stand-in, driven directly with plain numbers."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as M

from mavhelm.sitl.autopilot import Estimate, Timeline
from mavhelm.sitl.estimator import EKF_YAW_OFFSET_DEG, GPS_DETECTED_AT, Estimator
from mavhelm.sitl.truth import Truth

DT = 0.02
TL = Timeline.fast()  # initialised 0.2, GPS fix 0.5, origin 1.0, EKF using GPS 2.0
START = Truth(t=0.0, x=0.0, y=0.0, heading=90.0)


def window(kind: str, start: float, end: float, **params: float):
    """A faults(kind, t) callable with one fault of kind active in [start, end)."""
    fault = SimpleNamespace(params=params)
    return lambda k, t: [fault] if k == kind and start <= t < end else []


def drive(e: Estimator, est: Estimate, t0: float, t1: float, *, noise: float = 0.0,
          dr_time: float = 10.0, speed: float = 1.0):
    """Run the estimator from t0 to t1 on a vehicle heading east at speed along y = 0; the
    EKF origin exists from TL.ekf_origin on. Yields t after each sub-step."""
    n0, n1 = round(t0 / DT), round(t1 / DT)
    for n in range(n0 + 1, n1 + 1):
        t = n * DT
        e.record(t, speed * t, 0.0, speed, 0.0)
        e.update_gps(t, START, noise)
        e.update(est, t, DT, heading=math.pi / 2, yaw_rate=0.0, surge=speed, sway=None,
                 compass_bias=0.0, have_origin=t >= TL.ekf_origin, dr_time=dr_time)
        yield t


def test_zero_noise_gives_the_exact_true_position():
    e = Estimator(0.0, 0.2, np.random.default_rng(1), TL)
    est = Estimate(heading=90.0)
    for t in drive(e, est, 0.0, 5.0):
        g = e.gps
        if t < TL.map(GPS_DETECTED_AT):
            assert g is None  # receiver not detected yet (fix_type 0)
        elif t < TL.gps_fix:  # detected, no fix yet
            assert g is not None and g.fix == 1
        elif t >= TL.gps_fix and g is not None and g.t == t:
            assert (g.fix, g.x, g.y, g.vx, g.vy) == (3, pytest.approx(t), 0.0, 1.0, 0.0)
    assert e.has_fix and e.ever_fix
    assert est.position_ok and est.x == pytest.approx(5.0, abs=0.05)
    flags, var = e.ekf_flags(5.0, est, e.has_fix)
    assert flags & M.EKF_POS_HORIZ_ABS and var == 0.02


def test_noise_is_drawn_even_without_a_fix():
    """Every sample draws the same numbers, so an outage never shifts later noise."""
    def run(faults):
        e = Estimator(0.0, 0.2, np.random.default_rng(7), TL, faults=faults)
        est = Estimate()
        for _ in drive(e, est, 0.0, 6.0, noise=0.4):
            pass
        return e.gps.x, e.gps.y

    assert run(window("gps_outage", 2.0, 4.0)) == run(None)


def test_dead_reckons_for_sim_ekf_dr_time_then_loses_absolute_position():
    e = Estimator(0.0, 0.2, np.random.default_rng(1), TL,
                  faults=window("gps_outage", 5.0, 20.0))
    est = Estimate(heading=90.0)
    ok_until = None
    x_at: dict[float, float] = {}
    for t in drive(e, est, 0.0, 19.9, dr_time=8.0):
        x_at[round(t, 2)] = est.x
        if t >= 5.25:
            assert not e.has_fix and e.gps.fix == 1
            if est.position_ok:
                ok_until = t
    # dead reckoning on heading and speed moves the estimate with the vehicle
    # (on the EKF's heading, which carries the real SITL's +0.45° yaw offset)
    assert x_at[12.0] - x_at[6.0] == pytest.approx(
        6.0 * math.cos(math.radians(EKF_YAW_OFFSET_DEG)), abs=1e-6)
    last_fix = e.last_fix_t
    assert last_fix is not None and 4.7 < last_fix < 5.0 + 1e-6
    assert ok_until == pytest.approx(last_fix + 8.0 - DT, abs=DT / 2)
    assert (e.gps.x, e.gps.y) == pytest.approx((last_fix, 0.0))  # held, as a receiver does
    flags, _ = e.ekf_flags(19.9, est, e.has_fix)
    assert flags & M.EKF_CONST_POS_MODE and not flags & M.EKF_POS_HORIZ_ABS
    for _ in drive(e, est, 19.9, 20.4, dr_time=8.0):
        pass
    # the filter had given up: it resets onto the first new fix
    assert est.position_ok and est.x == pytest.approx(20.4, abs=0.05)


def test_gps_latency_reports_where_the_vehicle_was():
    e = Estimator(0.0, 0.2, np.random.default_rng(1), TL,
                  faults=window("sensor_latency", 3.0, 4.0, sensor="gps", delay=0.5))
    est = Estimate(heading=90.0)
    for t in drive(e, est, 0.0, 4.0):
        g = e.gps
        if 3.0 <= t < 4.0 and g is not None and g.t == t:
            assert g.x == pytest.approx(t - 0.5)


def test_a_jump_is_gated_as_a_glitch_then_accepted():
    e = Estimator(0.0, 0.2, np.random.default_rng(1), TL,
                  faults=window("gps_jump", 5.0, 30.0, dx=50.0))
    est = Estimate(heading=90.0)
    for _ in drive(e, est, 0.0, 6.0):
        pass
    assert e.glitch_since is not None and est.x == pytest.approx(6.0, abs=0.1)
    flags, var = e.ekf_flags(6.0, est, e.has_fix)
    assert flags & M.EKF_GPS_GLITCHING and var == 1.0
    for _ in drive(e, est, 6.0, 12.0):
        pass
    assert e.glitch_since is None and est.x == pytest.approx(62.0, abs=0.1)
