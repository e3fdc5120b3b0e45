"""The vehicle-model registry wired into the simulator: ``Simulator(model=...)``, ArduPilot's
``--defaults`` files over the parameter table, and ``mavhelm sim --model/--defaults``.

Each model is driven through the whole simulator (RC override → MANUAL → servo outputs →
physics) and compared with the same model stepped on its own from the same servo outputs, so
the simulator adds nothing of its own to the physics.
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.sitl import runner
from mavhelm.sitl.autopilot import ARDUPILOT_DEFAULTS, default_params
from mavhelm.sitl.boat import SimEnvironment
from mavhelm.sitl.models import DEFAULT_MODEL, HULL_MODELS, MODELS, SITL_MODELS, get_model
from mavhelm.sitl.simulator import DT
from tests.support.sitl_rig import Rig, command

M = mavlink

# The stock files' lines that matter here (Tools/autotest/default_params of the reference
# build), including motorboat.parm's malformed "SIM_TIDE_0.5", which ArduPilot skips.
ROVER_PARM = ("ATC_SPEED_P 0.1\nATC_STR_RAT_FF 0.75\nBATT_MONITOR 4\nCRUISE_SPEED 5\n"
              "CRUISE_THROTTLE 30\nMODE3 11\nRC1_MAX 2000\nRC1_MIN 1000\nRC3_MAX 2000\n"
              "RC3_MIN 1000\nSERVO1_MIN 1000\nSERVO1_MAX 2000\nSERVO3_MAX 2000\n"
              "SERVO3_MIN 1000\n# for brushed control\nWP_RADIUS 3\nWP_SPEED 5\n")
MOTORBOAT_PARM = "FRAME_CLASS 2\nSIM_TIDE_0.5\nSIM_WIND_SPD 3\nSIM_WIND_T 1\nSIM_WAVE_ENABLE 1\n"


def _stock(tmp_path: Path) -> str:
    (tmp_path / "rover.parm").write_text(ROVER_PARM)
    (tmp_path / "motorboat.parm").write_text(MOTORBOAT_PARM)
    return f"{tmp_path / 'rover.parm'},{tmp_path / 'motorboat.parm'}"


def _override(c, steer: int, throttle: int) -> None:
    c.mav.rc_channels_override_send(1, 1, steer, 0, throttle, 0, 0, 0, 0, 0)


@pytest.mark.parametrize("name", list(MODELS))
def test_each_model_steps_through_the_simulator(name):
    """Armed in MANUAL with the throttle stick up and a little steering, the simulated vehicle
    moves exactly as its model does from the same servo outputs."""
    model = get_model(name)
    r = Rig(model=name)
    try:
        c = r.connect(sysid=255)
        r.run(2.0)
        assert c.last("HEARTBEAT").type == model.mav_type
        assert (r.sim.params["SERVO1_FUNCTION"], r.sim.params["SERVO3_FUNCTION"]) == \
            model.servo_functions
        command(c, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        r.step()
        assert r.sim.armed
        _override(c, 1600, 1800)
        r.step()
        first = r.sim.autopilot.servo_outputs()
        r.run(1.5)  # the throttle output slews to the stick at MOT_SLEWRATE 100 %/s first
        _override(c, 1600, 1800)  # (an override lasts RC_OVERRIDE_TIME, 3 s)
        r.step()
        outputs = r.sim.autopilot.servo_outputs()
        assert first != outputs
        start, t0 = r.sim._state, r.sim.truth.t
        r.run(3.0)
        assert r.sim.autopilot.servo_outputs() == outputs  # MANUAL: constant sticks, outputs
        inputs = model.inputs_from_outputs(outputs, r.sim.autopilot.servo_map())
        env = SimEnvironment.from_params(r.sim.params, armed=True)
        state = start
        for _ in range(int(round((r.sim.truth.t - t0) / DT))):
            state = model.step(state, inputs, env, DT)
        alone = model.truth(state, r.sim.truth.t, env)
        tr = r.sim.truth
        assert tr.surge > 0.5
        assert (tr.x, tr.y, tr.heading, tr.surge) == pytest.approx(
            (alone.x, alone.y, alone.heading, alone.surge), rel=1e-9, abs=1e-9)
    finally:
        r.close()


def test_model_names_and_aliases():
    r = Rig(model="mavhelm-boat-rudder", ports=(0,))
    try:
        assert r.sim.model is HULL_MODELS["mavhelm-boat-rudder"]
        assert (r.sim.vehicle, r.sim.model.skid) == ("boat", False)
    finally:
        r.close()
    r = Rig(ports=(0,))
    try:
        assert r.sim.model.name == DEFAULT_MODEL == "mavhelm-boat"  # the default hull is unchanged
    finally:
        r.close()
    with pytest.raises(ValueError, match="unknown vehicle model 'boat'; known: motorboat"):
        Rig(model="boat")
    with pytest.raises(ValueError, match="unknown vehicle model 'mavhelm-rover-rudder'"):
        Rig(model="mavhelm-rover-rudder")


def test_defaults_files_are_applied_over_the_parameter_table(tmp_path):
    """rover.parm + motorboat.parm as the SITL reads them: values override the table, names the
    table lacks are added, the malformed tide line is skipped, the environment follows, and a
    --param-style ``params`` still wins."""
    r = Rig(model="motorboat", defaults=_stock(tmp_path), params={"WP_RADIUS": 4.0})
    try:
        p = r.sim.params
        assert (p["WP_SPEED"], p["CRUISE_SPEED"], p["CRUISE_THROTTLE"], p["ATC_SPEED_P"]) == \
            (5.0, 5.0, 30.0, 0.1)
        assert (p["SERVO1_MIN"], p["SERVO3_MAX"], p["BATT_MONITOR"], p["MODE3"]) == \
            (1000, 2000, 4, 11)
        assert p["WP_RADIUS"] == 4.0
        assert [e.line for e in r.sim.defaults_skipped] == [2]
        assert (r.sim.env.SIM_WIND_SPD, r.sim.env.SIM_WAVE_ENABLE) == (3.0, 1)
        c = r.connect()
        r.run(1.0)
        for name, value in (("WP_SPEED", 5.0), ("SIM_WAVE_ENABLE", 1.0), ("BATT_MONITOR", 4.0)):
            c.mav.param_request_read_send(1, 1, name.encode(), -1)
            r.step()
            got = [m for m in c.of("PARAM_VALUE") if m.param_id == name]
            assert got and got[-1].param_value == pytest.approx(value), name
    finally:
        r.close()


def test_sitl_models_start_from_ardupilot_defaults(tmp_path):
    """A SITL model's table starts, as the real SITL's, from ArduPilot's own defaults, with the
    files on top: the gains the stock files leave out are the firmware's (ATC_STR_RAT_P 0.2,
    not the 1.5 tuned to mavhelm's rudder hull). mavhelm's own hulls keep their tuned values."""
    for name in SITL_MODELS:
        r = Rig(model=name, ports=(0,))
        try:
            p = r.sim.params
            assert {k: p[k] for k in ARDUPILOT_DEFAULTS} == ARDUPILOT_DEFAULTS, name
            assert (p["SIM_WIND_T"], p["MOT_SLEWRATE"]) == (0.0, 100.0), name
            assert (p["SERVO1_FUNCTION"], p["SERVO3_FUNCTION"]) == \
                get_model(name).servo_functions
        finally:
            r.close()
    r = Rig(model="motorboat", defaults=_stock(tmp_path))
    try:
        p = r.sim.params
        assert (p["ATC_SPEED_P"], p["ATC_STR_RAT_FF"], p["CRUISE_THROTTLE"]) == (0.1, 0.75, 30.0)
        assert (p["ATC_STR_RAT_P"], p["ATC_STR_RAT_I"], p["ATC_STR_RAT_IMAX"], p["ATC_SPEED_I"],
                p["ATC_SPEED_IMAX"]) == (0.2, 0.2, 1.0, 0.2, 1.0)
        assert p["SIM_WIND_T"] == 1.0  # motorboat.parm's
    finally:
        r.close()
    for name, hull in HULL_MODELS.items():
        r = Rig(model=name, ports=(0,))
        try:
            own = default_params(hull.vehicle == "boat", hull.skid)
            assert {k: r.sim.params[k] for k in ARDUPILOT_DEFAULTS} == \
                {k: own[k] for k in ARDUPILOT_DEFAULTS}
            assert r.sim.params["ATC_STR_RAT_P"] != ARDUPILOT_DEFAULTS["ATC_STR_RAT_P"]
        finally:
            r.close()


@pytest.mark.slow
def test_ardupilot_defaults_are_the_firmwares(real_sitl, tmp_path):
    """The real SITL started with an empty defaults file answers ARDUPILOT_DEFAULTS, and every
    other name of the simulator's table it has with the table's value (FRAME_CLASS apart: the
    stock files set it; GPS1_RATE_MS is the simulator's own)."""
    from tests.support.ardupilot import connect_tcp

    empty = tmp_path / "empty.parm"
    empty.write_text("")
    sitl = real_sitl(model="motorboat", speedup=5, defaults=[str(empty)])
    conn = connect_tcp(sitl.ports.serial0, source_system=255, source_component=190)
    try:
        want = default_params(boat=True, skid=False, firmware=True)
        for name in sorted(want):
            if name in ("FRAME_CLASS", "GPS1_RATE_MS"):
                continue
            got = _read_param(conn, name, timeout=3.0)
            assert got == pytest.approx(want[name], rel=1e-6), name
    finally:
        conn.close()


def test_stock_waves_rock_the_motorboat_only_while_armed(tmp_path):
    r = Rig(model="motorboat", defaults=_stock(tmp_path))
    try:
        c = r.connect()
        r.run(3.0)
        assert (r.sim.truth.roll, r.sim.truth.pitch) == (0.0, 0.0)
        command(c, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        r.step()
        tilt = 0.0
        for _ in range(100):
            r.step()
            tilt = max(tilt, abs(r.sim.truth.roll), abs(r.sim.truth.pitch))
        assert tilt > 2.0
        att = c.last("ATTITUDE")
        assert max(abs(att.roll), abs(att.pitch)) > math.radians(0.5)
    finally:
        r.close()


def _parse(*argv: str) -> argparse.Namespace:
    p = argparse.ArgumentParser()
    runner.add_arguments(p)
    return p.parse_args(list(argv))


def test_runner_model_options(capsys, tmp_path):
    a = _parse("--model", "motorboat-skid", "--defaults", "a.parm,b.parm")
    assert (a.model, a.defaults) == ("motorboat-skid", "a.parm,b.parm")
    assert _parse().model == DEFAULT_MODEL and _parse().defaults is None
    for argv in (("--model", "boat"), ("--vehicle", "rover"), ("--variant", "skid")):
        with pytest.raises(SystemExit):
            _parse(*argv)
    assert runner.run(_parse("--model", "rover", "--defaults",
                             str(tmp_path / "missing.parm"))) == 2
    assert "missing.parm: no such file" in capsys.readouterr().err


def _stock_dir() -> Path:
    from tests.support.ardupilot import ardupilot_binary

    binary = ardupilot_binary()
    if binary is None or not (binary.parent / "params" / "motorboat.parm").is_file():
        pytest.skip("ArduPilot's stock parameter files come with the real SITL: set "
                    "MAVHELM_ARDUPILOT=../shared/ardupilot/ardurover")
    return binary.parent / "params"


def _read_param(conn: mavutil.mavfile, name: str, timeout: float = 10.0) -> float | None:
    conn.mav.param_request_read_send(1, 1, name.encode(), -1)
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        m = conn.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.5)
        if m is not None and m.param_id == name:
            return float(m.param_value)
    return None


@pytest.mark.parametrize("stock", [False, True], ids=["copied-lines", "stock-files"])
def test_mavhelm_sim_model_and_defaults_answer_the_files_parameters(stock, tmp_path):
    """The command itself, as a ground station meets it: ``mavhelm sim --model motorboat
    --defaults rover.parm,motorboat.parm`` is a boat with steering and throttle that answers the
    files' values, and says which line it skipped."""
    from tests.support.interop_helpers import SimProcess

    if stock:
        d = _stock_dir()
        files = f"{d / 'rover.parm'},{d / 'motorboat.parm'}"
    else:
        files = _stock(tmp_path)
    with SimProcess("--model", "motorboat", "--defaults", files, "--fast-start") as sim:
        assert "mavhelm sim: motorboat at" in sim.output.text()
        assert "motorboat.parm:2: 'SIM_TIDE_0.5' has no value" in sim.output.text()
        conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{sim.ports[0]}", source_system=255,
                                          source_component=190, dialect="ardupilotmega")
        try:
            hb = conn.recv_match(type="HEARTBEAT", blocking=True, timeout=10)
            assert hb is not None and hb.type == M.MAV_TYPE_SURFACE_BOAT
            for name, value in (("WP_SPEED", 5.0), ("CRUISE_SPEED", 5.0),
                                ("WP_RADIUS", 3.0), ("ATC_STR_RAT_FF", 0.75),
                                ("CRUISE_THROTTLE", 30.0), ("SIM_WIND_SPD", 3.0),
                                ("SIM_WAVE_ENABLE", 1.0), ("SERVO1_FUNCTION", 26.0),
                                ("SERVO3_FUNCTION", 70.0), ("FRAME_CLASS", 2.0)):
                got = _read_param(conn, name)
                assert got == pytest.approx(value), name
        finally:
            conn.close()
