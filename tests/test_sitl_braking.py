"""How `mavhelm sim --model motorboat` brakes under its autopilot, against the real SITL.

The script (tests/support/braking.py): armed in GUIDED, drive straight at 1.6 m/s, then at 4 m/s,
with a refreshed SET_POSITION_TARGET_LOCAL_NED velocity, and stop each way ArduPilot stops a boat:

- ``timeout``: the target is no longer refreshed; after 3 s "target not received last 3secs,
  stopping" and the boat loiters at its stopping point (ModeGuided::update → start_loiter →
  ModeLoiter: the desired speed slews to zero at ATC_DECEL_MAX/ATC_ACCEL_MAX, 1 m/s², and the
  speed controller follows it with reverse thrust, AR_AttitudeControl::get_throttle_out_stop),
- ``hold``: HOLD (ModeHold::update: throttle and steering zero; the hull coasts).

The sim-only test always runs: the simulator (stock ``--defaults rover.parm,motorboat.parm``,
calm; as the real SITL it starts from ArduPilot's own parameter defaults, so the controller
gains the files leave out are the firmware's) must give the real SITL's figures, written below
as constants. The differential test runs
the real binary (``--speedup 10``, about 13 s of wall time; skipped without MAVHELM_ARDUPILOT)
and the simulator through the same script and compares them. Times are autopilot seconds.
Run with -s to see the table.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest

from tests.support.braking import (
    CALM,
    CASES,
    HOME,
    figures,
    label,
    print_table,
    sim_rig,
    write_stock_parms,
)
from tests.support.braking import run_braking as _run
from tests.support.sides import RealSide, SimSide

# The real ArduRover 4.8-dev SITL (../shared/ardupilot/ardurover, --model motorboat, --defaults
# rover.parm,motorboat.parm + SIM_WIND_SPD 0, SIM_WAVE_ENABLE 0, --speedup 10), measured with
# this script (benchmarks/bench_braking.py); runs agree within 0.07 m/s and 0.06 s. Speeds
# from SIMSTATE positions; times from the time-out text or the HOLD command. (HOLD's throttle
# reaches 1500 µs 0.2-0.26 s after the command from 4 m/s, slewed by MOT_SLEWRATE 100 %/s; that
# time includes the command's trip to the binary, so it is checked loosely below.)
REAL: dict[str, dict[str, float]] = {
    "timeout from 1.6 m/s": {
        "speed 1 s after m/s": 0.64, "t to 0.3 m/s s": 1.26, "t to < 0.1 m/s s": 1.36,
        "t to stay |v| < 0.1 s": 2.70, "least speed m/s": -0.41,
        "min throttle servo us": 1473},
    "hold from 1.6 m/s": {
        "speed 1 s after m/s": 1.18, "speed 3 s after m/s": 0.72,
        "min throttle servo us": 1500},
    "timeout from 4 m/s": {
        "speed 1 s after m/s": 3.19, "speed 3 s after m/s": 0.93, "t to 0.3 m/s s": 3.56,
        "t to < 0.1 m/s s": 3.76, "t to stay |v| < 0.1 s": 5.10, "least speed m/s": -0.37,
        "min throttle servo us": 1478},
    "hold from 4 m/s": {
        "speed 1 s after m/s": 2.11, "speed 3 s after m/s": 1.04,
        "min throttle servo us": 1500},
}

# Tolerances: speeds within 0.15 m/s and stop times within 20 %.
SPEED_TOL = 0.15
TIME_REL_TOL = 0.20
SERVO_TOL = 12.0            # µs of the least throttle output (1 % throttle is 5 µs)


def _tolerance(key: str, real: float) -> float:
    if key.startswith("t to"):
        return TIME_REL_TOL * real
    if key.startswith("min throttle"):
        return SERVO_TOL
    return SPEED_TOL


def _check(stops, reference: dict[str, dict[str, float]]) -> list[str]:
    bad = []
    for stop in stops:
        got = figures(stop)
        for key, want in reference[label(stop)].items():
            tol = _tolerance(key, want)
            if not abs(got[key] - want) <= tol:
                bad.append(f"{label(stop)}: {key} {got[key]:.2f}, real {want:.2f} (±{tol:.2f})")
    return bad


def _real_stops(real_sitl) -> list:
    """The braking script on a fresh real SITL (motorboat, ×10, calm)."""
    t0 = time.monotonic()
    sitl = real_sitl(model="motorboat", speedup=10, home=HOME, params=CALM)
    side = RealSide(sitl, companion=False)
    try:
        real = _run(side, CASES)
    finally:
        side.close()
    print(f"\nreal ArduPilot SITL braking script: {time.monotonic() - t0:.1f} s wall")
    return real


def _sim_stops(params_dir: Path):
    rig = sim_rig(params_dir)
    try:
        return _run(SimSide(rig, 0.02, companion=False))
    finally:
        rig.close()


@pytest.fixture(scope="module")
def sim_stops(tmp_path_factory):
    t0 = time.monotonic()
    stops = _sim_stops(write_stock_parms(tmp_path_factory.mktemp("parm")))
    print(f"\nmavhelm sim braking script: {time.monotonic() - t0:.1f} s wall")
    return stops


def test_sim_brakes_as_the_real_sitl_measured(sim_stops) -> None:
    """The real SITL's figures (constants above), held by the simulator without the binary."""
    print_table(None, sim_stops)
    assert [label(s) for s in sim_stops] == list(REAL)
    bad = _check(sim_stops, REAL)
    assert not bad, "\n".join(bad)


def test_timeout_stop_is_reverse_thrust_then_released(sim_stops) -> None:
    """ArduPilot's controlled stop: reverse thrust while the desired speed slews down, the
    throttle released (exactly 1500 µs) once stopped, and the boat then stays stopped."""
    for stop in (s for s in sim_stops if s.how == "timeout"):
        after = [pwm for t, pwm in stop.servos if t >= stop.t0]
        assert min(after) < 1490, label(stop)
        tail = [pwm for t, pwm in stop.servos if t >= stop.t0 + 6.0]
        assert tail and all(pwm == 1500 for pwm in tail), label(stop)
        f = figures(stop)
        assert f["t to stay |v| < 0.1 s"] < 6.0, label(stop)
        # as the real boat, it runs a little astern before the controller settles (the
        # integrator wound up braking keeps pulling until the stop is declared)
        assert -0.7 < f["least speed m/s"] < -0.1, label(stop)


def test_hold_only_releases_the_throttle(sim_stops) -> None:
    """HOLD sets throttle and steering to zero: no reverse thrust, the hull coasts. The output
    gets there slewed at MOT_SLEWRATE 100 %/s: from 4 m/s (about 16 % throttle) in ~0.16 s,
    never below 1500 µs on the way."""
    for stop in (s for s in sim_stops if s.how == "hold"):
        after = [pwm for t, pwm in stop.servos if t >= stop.t0 + 0.3]
        assert after and all(pwm == 1500 for pwm in after), label(stop)
        assert min(pwm for t, pwm in stop.servos if t >= stop.t0) == 1500, label(stop)
        assert figures(stop)["speed 3 s after m/s"] > 0.5
    fast = next(s for s in sim_stops if label(s) == "hold from 4 m/s")
    ramp = [pwm for t, pwm in fast.servos if fast.t0 <= t <= fast.t0 + 0.1]
    assert ramp and max(ramp) > 1520, "the throttle dropped at once: not slewed"
    assert 0.1 <= figures(fast)["t to min servo s"] <= 0.3


def _measured(real: list) -> dict[str, dict[str, float]]:
    """A real run's figures, those pinned in ``REAL``."""
    return {label(s): {k: v for k, v in figures(s).items() if k in REAL[label(s)]}
            for s in real}


def _mean(a: float, b: float) -> float:
    """Two runs' figure averaged; a figure one run did not reach (nan) is the other's."""
    finite = [x for x in (a, b) if math.isfinite(x)]
    return sum(finite) / len(finite) if finite else math.nan


@pytest.mark.slow
def test_sim_brakes_as_the_real_sitl(real_sitl, sim_stops) -> None:
    """The real binary and the simulator through the same script: figures within tolerance."""
    real = _real_stops(real_sitl)
    if _check(real, REAL):
        # The binary at ×10 wall speed now and then moves again late in a stop (CI runs saw
        # the boat above 0.1 m/s at the 8 s record's end, from 4 m/s and from 1.6 m/s, after
        # it had stopped; alone and under two CPU burners it gave the pinned figures 14 times
        # of 14). "t to stay" now asks for STAY_S stopped, not the record's end; should a
        # run still drift, one fresh measurement, every check below unchanged.
        print("\nthe real SITL's first run drifted from its pinned figures:\n"
              + "\n".join(_check(real, REAL)) + "\nits texts: "
              + "; ".join(f"{t:.1f} {text}" for s in real for t, text in s.texts)
              + "\nmeasured again on a fresh SITL")
        real = _real_stops(real_sitl)
    print_table(real, sim_stops)
    measured = _measured(real)
    bad = _check(sim_stops, measured)
    if bad:
        # One run of the binary at ×10 under a loaded machine moves by up to 0.1 m/s (CI saw
        # 2.20 m/s 1 s after a HOLD from 4 m/s, 2.12-2.14 alone, 2.11 pinned) and the
        # simulator sits 0.06 below: the reference is then the mean of two fresh runs.
        print("\nthe simulator is at the edge of one real run:\n" + "\n".join(bad)
              + "\nthe real SITL measured once more, the two runs averaged")
        real = _real_stops(real_sitl)
        print_table(real, sim_stops)
        again = _measured(real)
        measured = {case: {k: _mean(v, again[case][k]) for k, v in keys.items()}
                    for case, keys in measured.items()}
        bad = _check(sim_stops, measured)
    assert not bad, "\n".join(bad)
    # and the real SITL still gives the figures pinned above
    drift = _check(real, REAL)
    assert not drift, "the real SITL no longer gives the pinned figures:\n" + "\n".join(drift)


def test_stopped_means_held_stopped_for_a_while_not_to_the_records_end() -> None:
    """The "t to stay" figure: the braking's end once the speed has stayed under 0.1 m/s for
    STAY_S; a move after that (the loiter's own) does not undo it, a pause shorter does."""
    from tests.support.braking import STAY_S, _settled

    def series(moving: list[tuple[float, float]]) -> list[tuple[float, float]]:
        return [(k * 0.02, 0.5 if any(a <= k * 0.02 < b for a, b in moving) else 0.0)
                for k in range(400)]

    assert _settled(series([(0.0, 2.7)]), 0.0, 0.1) == pytest.approx(2.68)
    assert _settled(series([(0.0, 2.7), (2.7 + STAY_S + 0.5, 7.0)]), 0.0, 0.1) \
        == pytest.approx(2.68)
    assert _settled(series([(0.0, 2.7), (2.7 + STAY_S - 0.5, 4.5)]), 0.0, 0.1) \
        == pytest.approx(4.48)
    assert math.isnan(_settled(series([(0.0, 7.5)]), 0.0, 0.1))
