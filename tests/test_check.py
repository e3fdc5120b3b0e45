"""``mavhelm check``: the checklist's decisions from observations, and the command against
``mavhelm sim`` over TCP."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.bridge import BridgeConfig
from mavhelm.companion.check import Observed, checklist
from mavhelm.core.geodesy import Origin

ROOT = Path(__file__).resolve().parents[1]
ORIGIN = Origin(56.412, -5.476)


def ready(**changes) -> Observed:
    seen = Observed(connected=True, heard=set(BridgeConfig().streams), gps_fix=6,
                    position=ORIGIN.to_global(40.0, 30.0),
                    ekf_flags=mavlink.EKF_POS_HORIZ_ABS,
                    params={"WP_SPEED": 2.0, "MAV_GCS_SYSID": 255.0, "SERVO9_FUNCTION": 0.0},
                    heartbeat=mavlink.MAVLink_heartbeat_message(
                        mavlink.MAV_TYPE_SURFACE_BOAT, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                        0x41, 0, 4, 3))
    for key, value in changes.items():
        setattr(seen, key, value)
    return seen


def statuses(lines) -> list[str]:
    return [line.status for line in lines]


def test_a_ready_boat_passes():
    lines = checklist(ready(), BridgeConfig(), ORIGIN)
    assert "FAIL" not in statuses(lines), [str(line) for line in lines]
    assert str(lines[-1]) == "  ok  to hand over: arm, then select GUIDED"
    assert "  ok  the vehicle is 50 m from the mission's origin" in [str(x) for x in lines]


def test_each_problem_is_a_fail_with_its_remedy():
    config = BridgeConfig(actuation="rc_override", engage_channel=7, system_id=1)
    cases = {
        "streams not arriving: ATTITUDE": ready(heard=set(BridgeConfig().streams) - {"ATTITUDE"}),
        "no 3D GPS fix yet (fix type 1)": ready(gps_fix=1),
        "EKF has no position yet": ready(ekf_flags=0),
        "152.8 km from the mission's origin": ready(position=ORIGIN.to_global(0.0, 152_842.0)),
        "MAV_GCS_SYSID is 255 but SystemID is 1": ready(),
    }
    for words, seen in cases.items():
        lines = [str(line) for line in checklist(seen, config, ORIGIN)
                 if line.status == "FAIL"]
        assert any(words in line for line in lines), (words, lines)


def test_no_connection_and_no_heartbeat_stop_the_list_early():
    lines = checklist(Observed(link_error="Connection refused"), BridgeConfig(), None)
    assert [str(x) for x in lines] == [
        "FAIL  no connection to tcp:127.0.0.1:5760: Connection refused (is the autopilot "
        "powered, the address and baud right?)"]
    lines = checklist(Observed(connected=True), BridgeConfig(), None)
    assert statuses(lines) == ["ok", "FAIL"] and "no HEARTBEAT from system 1" in str(lines[1])


def test_mavhelm_check_against_the_simulator(tmp_path):
    from tests.support.interop_helpers import SimProcess

    demo = ROOT / "examples" / "demo.moos"
    sim = SimProcess("--fast-start", "--speedup", "5", "--mission", str(demo))
    far = SimProcess("--fast-start", "--speedup", "5")
    try:
        good = subprocess.run(
            [sys.executable, "-m", "mavhelm.cli", "check", str(demo), "--connect",
             f"tcp:127.0.0.1:{sim.ports[1]}", "--listen", "6"],
            capture_output=True, text=True, timeout=120)
        bad = subprocess.run(
            [sys.executable, "-m", "mavhelm.cli", "check", str(demo), "--connect",
             f"tcp:127.0.0.1:{far.ports[1]}", "--listen", "6"],
            capture_output=True, text=True, timeout=120)
    finally:
        sim.close()
        far.close()
    assert good.returncode == 0, good.stdout + good.stderr
    assert good.stdout.splitlines()[-1] == "mavhelm check: ready"
    assert "  ok  autopilot: ArduPilot boat, MANUAL, disarmed" in good.stdout
    assert bad.returncode == 1
    assert "km from the mission's origin: wrong mission, or wrong LatOrigin/LongOrigin?" \
        in bad.stdout
