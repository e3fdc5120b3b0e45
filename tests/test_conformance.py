"""`mavhelm sim` against the real ArduPilot Rover SITL: the same scenarios on both sides.

The scenario (tests/support/conformance.py) runs once per side per module: the real binary at
``--speedup 10`` (about 8 s of wall time; skipped without MAVHELM_ARDUPILOT) and the simulator
in lockstep (about 2 s). The main one drives the motorboat through the protocol; the turn-rate
one holds the ``rover`` (stock rover.parm) on a SET_ATTITUDE_TARGET turn for 8 s. Any
difference beyond tolerance that docs/sim-differences.md does not list fails. The sim-only
tests pin the measured facts so they hold without the binary too. Run with -s to see the
observations and timings.
"""

from __future__ import annotations

import time
from typing import Any

import pytest

from mavhelm.sitl.flat_earth import Origin
from tests.support.conformance import (
    DIFFERENCES_DOC,
    Difference,
    accepted_differences,
    compare,
    run_scenario,
    run_turn_rate_scenario,
    unaccepted,
)
from tests.support.sides import RealSide, SimSide

HOME = (56.4120, -5.4760, 0, 90)
CALM = {"SIM_WIND_SPD": 0, "SIM_WAVE_ENABLE": 0}


@pytest.fixture(scope="module")
def sim_obs() -> dict[str, Any]:
    from tests.support.sitl_rig import Rig

    t0 = time.monotonic()
    rig = Rig(model="mavhelm-boat-rudder", fast_start=False, home=Origin(HOME[0], HOME[1]),
              start_heading=HOME[3], wait_for_client=True)
    try:
        obs = run_scenario(SimSide(rig))
    finally:
        rig.close()
    print(f"\nmavhelm sim scenario: {time.monotonic() - t0:.1f} s wall")
    return obs


@pytest.fixture(scope="module")
def real_obs(tmp_path_factory) -> dict[str, Any]:
    from tests.support.ardupilot import SKIP_REASON, RealSitl, ardupilot_binary

    binary = ardupilot_binary()
    if binary is None:
        pytest.skip(SKIP_REASON)
    t0 = time.monotonic()
    with RealSitl(tmp_path_factory.mktemp("conformance"), binary=binary, model="motorboat",
                  speedup=10, home=HOME, params=CALM) as sitl:
        side = RealSide(sitl)
        try:
            obs = run_scenario(side)
        finally:
            side.close()
    print(f"\nreal ArduPilot SITL scenario: {time.monotonic() - t0:.1f} s wall")
    return obs


TURN_HOME = (56.4120, -5.4760, 0, 90)


@pytest.fixture(scope="module")
def sim_turn() -> dict[str, Any]:
    from mavhelm.sitl.parm_file import parse_parm
    from tests.support.braking import ROVER_PARM
    from tests.support.sitl_rig import Rig

    rig = Rig(model="rover", defaults=parse_parm(ROVER_PARM, "rover.parm"),
              fast_start=False, home=Origin(TURN_HOME[0], TURN_HOME[1]),
              start_heading=TURN_HOME[3], wait_for_client=True)
    try:
        return run_turn_rate_scenario(SimSide(rig))
    finally:
        rig.close()


@pytest.fixture(scope="module")
def real_turn(tmp_path_factory) -> dict[str, Any]:
    from tests.support.ardupilot import SKIP_REASON, RealSitl, ardupilot_binary

    binary = ardupilot_binary()
    if binary is None:
        pytest.skip(SKIP_REASON)
    with RealSitl(tmp_path_factory.mktemp("turn"), binary=binary, model="rover", speedup=10,
                  home=TURN_HOME) as sitl:
        side = RealSide(sitl)
        try:
            return run_turn_rate_scenario(side)
        finally:
            side.close()


@pytest.mark.slow
def test_rover_turn_rate_as_the_real_sitl(real_turn, sim_turn) -> None:
    """SET_ATTITUDE_TARGET 0.3 rad/s, thrust 0.5, 8 s: the rover's yaw rate and speed within
    10 % of the real SITL's (steering scaled down above MOT_SPD_SCA_BASE, I-term held below)."""
    print(f"\n  real {real_turn}\n  sim  {sim_turn}")
    assert real_turn["turn.engaged"] and sim_turn["turn.engaged"]
    bad = compare(real_turn, sim_turn)
    assert not bad, "\n".join(str(d) for d in bad)


def test_sim_alone_keeps_the_measured_turn_rate(sim_turn) -> None:
    """The real rover's figures as measured (Rover 4.8-dev, rover.parm): yaw rate mean 14.4,
    peak 16.9, settled 16.7 deg/s; speed mean 2.09, settled 2.47 m/s."""
    assert not compare({"turn.engaged": True, "turn.rate_mean": 14.4, "turn.rate_peak": 16.9,
                        "turn.rate_settled": 16.7, "turn.speed_mean": 2.09,
                        "turn.speed_settled": 2.47}, sim_turn)


@pytest.mark.slow
def test_sim_answers_as_the_real_sitl(real_obs, sim_obs) -> None:
    accepted = accepted_differences()
    diffs = compare(real_obs, sim_obs)
    for d in diffs:
        ok = not unaccepted([d], accepted)
        print(f"  {'accepted' if ok else 'DIFFERENT'}: {d}")
    compared = sorted(set(real_obs) | set(sim_obs))
    print(f"  {len(compared)} observations compared, {len(diffs)} differ")
    assert len(compared) > 100, "the scenario observed too little to mean anything"
    bad = unaccepted(diffs, accepted)
    assert not bad, ("differences not listed in docs/sim-differences.md:\n"
                     + "\n".join(str(d) for d in bad))


def test_accepted_differences_are_read_and_give_reasons() -> None:
    accepted = accepted_differences()
    assert accepted, f"no accepted-difference rows found in {DIFFERENCES_DOC}"
    for key, reason in accepted.items():
        assert len(reason) > 40, f"{key}: the reason is missing or too short"


def test_compare_finds_differences_beyond_tolerance() -> None:
    real = {"param:WP_SPEED": 5.0, "text_at:X": 10.0, "gps.fix_type": 6,
            "guided.position_reached": True, "only.real": 1}
    sim = {"param:WP_SPEED": 5.00001, "text_at:X": 11.5, "gps.fix_type": 3,
           "guided.position_reached": 1, "only.sim": None}
    diffs = {d.key for d in compare(real, sim)}
    assert diffs == {"gps.fix_type", "guided.position_reached", "only.real"}
    assert {d.key for d in compare(real, dict(sim, **{"text_at:X": 11.7}))} >= {"text_at:X"}
    found = [Difference("text_at:Calibrating barometer", None, 0.0), Difference("x.y", 1, 2)]
    assert [d.key for d in unaccepted(found, {"text_at:Calibrating*": "r"})] == ["x.y"]


def test_sim_alone_keeps_the_measured_answers(sim_obs) -> None:
    """The real SITL's answers as measured (Rover 4.8-dev), held by the simulator even where
    the binary is absent."""
    o = sim_obs
    assert o["guided.timeout_text"] == "target not received last 3secs, stopping"
    assert o["guided.timeout_after.attitude"] == pytest.approx(3.0, abs=0.2)
    assert o["guided.timeout_after.velocity"] == pytest.approx(3.0, abs=0.2)
    assert o["param:GUID_TIMEOUT"] is None and o["param:NO_SUCH_PARAM"] is None
    assert o["param:SYSID_THISMAV"] is None and o["param:MAV_SYSID"] == 1  # 4.8's name
    for name, value in (("WP_SPEED", 5), ("CRUISE_SPEED", 5), ("WP_RADIUS", 3),
                        ("ATC_STR_RAT_FF", 0.75), ("ATC_SPEED_P", 0.1), ("TURN_RADIUS", 0.9),
                        ("SERIAL1_PROTOCOL", 2), ("SERIAL2_PROTOCOL", 2),
                        ("SIM_WIND_DIR", 180), ("SIM_WAVE_LENGTH", 10)):
        assert o[f"param:{name}"] == pytest.approx(value, rel=1e-6), name
    assert o["heartbeats.sequence"][:2] == [(16, 65, 2), (0, 65, 4)]
    assert (4, 1, 3) == o["mode.set_mode_msg.heartbeat"]          # HOLD: STANDBY
    assert (0, 193, 5) in o["heartbeats.sequence"]                # EKF failsafe: CRITICAL
    assert o["gps.fix_type"] == 6 and o["gps.eph"] == 121 and o["gps.epv"] == 200
    assert o["sys_status.early_health"] == "0x311810f"
    assert o["startup.prearm_healthy_at"] == pytest.approx(24.0, abs=0.6)
    assert o["arm.refusal.texts"] == ["Arm: Accels inconsistent", "Arm: Gyros inconsistent"]
    assert o["guided.accel_texts"] == ["Ignoring SET_POSITION_TARGET_LOCAL_NED; set ACC_IG",
                                       "NORE in mask"]
    assert o["servo.texts"] == ["ServoRelayEvent: Channel 1 is already in use"]
    assert o["startup.boot_text_count"] == 23
    for text, at in (("EKF3 IMU1 initialised", 4.4), ("AHRS: EKF3 active", 6.1),
                     ("Set HOME to 56.41200 -5.476000 at 0.00m", 9.9),
                     ("EKF3 IMU1 origin set", 19.9), ("EKF3 IMU0 is using GPS", 41.9)):
        assert o[f"text_at:{text}"] == pytest.approx(at, abs=0.25), text
