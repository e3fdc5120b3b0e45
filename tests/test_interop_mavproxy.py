"""MAVProxy, ArduPilot's own ground station, against ``mavhelm sim``.

Everything runs as it would by hand: ``mavhelm sim --fast-start`` in one process, MAVProxy in
another (headless: no terminal, its console fed through a stdin pipe), and the companion's link,
a plain pymavlink connection on another of the simulator's ports. MAVProxy arms the vehicle and
switches it to GUIDED with its own ``arm throttle`` and ``mode GUIDED`` commands; the companion's
link must see both in the autopilot's HEARTBEAT.

ArduPilot Rover accepts any mode while disarmed (Mode::enter skips its checks), so the test
arms first: GUIDED when armed needs a position estimate, which is what a real GCS meets.
"""

from __future__ import annotations

import subprocess
import sys
import threading

import pytest
from pymavlink import mavutil

from tests.support.interop_helpers import Companion, MavproxyProcess, SimProcess, armed, modes_of
from tests.support.mission import mission_text
from tests.support.waiting import wait_for

pytestmark = pytest.mark.slow

MANUAL, GUIDED = 0, 15
EKF_POS_HORIZ_ABS = mavutil.mavlink.EKF_POS_HORIZ_ABS


def _import_mavproxy() -> None:
    try:
        import MAVProxy.mavproxy  # noqa: F401
    except Exception as exc:  # noqa: BLE001 - fail loudly, never skip
        pytest.fail(f"MAVProxy cannot be imported here: {exc!r}. "
                    f"Install the test extras: pip install -e '.[test]'")


def test_mavproxy_mode_guided_is_seen_by_the_companion_link(tmp_path):
    _import_mavproxy()
    with SimProcess("--fast-start", "--home", "56.0,-3.0,45") as sim:
        assert len(sim.ports) == 3, sim.output.text()
        companion_port, gcs_port = sim.ports[0], sim.ports[1]  # 5760 and 5762 in SITL terms
        with Companion(companion_port) as companion:
            hb = companion.wait_for("HEARTBEAT", lambda m: m.custom_mode == MANUAL, 10,
                                    "the autopilot to initialise into MANUAL")
            assert hb.type == mavutil.mavlink.MAV_TYPE_SURFACE_BOAT
            assert hb.autopilot == mavutil.mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
            assert not armed(hb)
            # ready as ArduPilot means it: EKF has an absolute position (GUIDED when armed)
            companion.wait_for("EKF_STATUS_REPORT", lambda m: m.flags & EKF_POS_HORIZ_ABS, 10,
                               "the EKF to report an absolute horizontal position")

            with MavproxyProcess(f"tcp:127.0.0.1:{gcs_port}", tmp_path) as mavproxy:
                mavproxy.wait_for(r"Detected vehicle 1:1", 15)
                mavproxy.wait_for(r"Mode MANUAL", 10)

                at = mavproxy.mark()
                mavproxy.send("arm throttle")
                mavproxy.wait_for(r"COMPONENT_ARM_DISARM: ACCEPTED", 10, since=at)
                hb = companion.wait_for("HEARTBEAT", armed, 5, "an armed HEARTBEAT")
                assert hb.custom_mode == MANUAL  # arming alone does not change the mode

                at = mavproxy.mark()
                mavproxy.send("mode GUIDED")
                mavproxy.wait_for(r"DO_SET_MODE: ACCEPTED", 10, since=at)
                hb = companion.wait_for("HEARTBEAT", lambda m: m.custom_mode == GUIDED, 5,
                                        "HEARTBEAT custom_mode 15 (GUIDED)")
                assert armed(hb)
                assert hb.base_mode & mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
                assert hb.base_mode & mavutil.mavlink.MAV_MODE_FLAG_GUIDED_ENABLED
                modes = modes_of(companion.heartbeats)  # may start with INITIALISING (16)
                assert modes[modes.index(MANUAL):] == [MANUAL, GUIDED], modes

                # MAVProxy's own view agrees (its prompt and mode message follow the HEARTBEAT)
                mavproxy.wait_for(r"GUIDED>|Mode GUIDED", 5, since=at)

                at = mavproxy.mark()
                mavproxy.send("disarm")
                mavproxy.wait_for(r"COMPONENT_ARM_DISARM: ACCEPTED", 10, since=at)
                hb = companion.wait_for("HEARTBEAT", lambda m: not armed(m), 5,
                                        "a disarmed HEARTBEAT")
                assert hb.custom_mode == GUIDED


def reload_mission(name: str) -> str:
    """A Timer ``name`` and a Timer Home on the ground station's GoHome flag."""
    return mission_text(f"""
        Task = Timer
        {{
            Name = {name}
            TimeOut = 600
        }}
        Task = Timer
        {{
            Name = Home
            TimeOut = 600
            StartFlag = GoHome
        }}""", origin=(56.0, -3.0), imavlink={"RemoteFlag": "GoHome"})


def test_the_documented_mavproxy_lines_reload_the_helm_and_post_a_remote_flag(tmp_path):
    """README: `set target_component 191`, then `long USER_1 1` (RESTART_HELM) and
    `long USER_2 1` (the first RemoteFlag), typed into a real MAVProxy."""
    _import_mavproxy()
    mission = tmp_path / "reload.moos"
    mission.write_text(reload_mission("First"))
    with SimProcess("--fast-start") as sim:
        companion_port, gcs_port = sim.ports[1], sim.ports[0]
        proc = subprocess.Popen(
            [sys.executable, "-u", "-m", "mavhelm.cli", "run", str(mission), "--connect",
             f"tcp:127.0.0.1:{companion_port}", "--log-dir", str(tmp_path / "logs")],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        lines: list[str] = []
        reader = threading.Thread(target=lambda: lines.extend(iter(proc.stdout.readline, "")),
                                  daemon=True)
        reader.start()

        def wait_line(fragment: str, seconds: float) -> str:
            found = wait_for(lambda: [line for line in list(lines) if fragment in line],
                             seconds, f"{fragment!r} from the companion", lambda: lines[-10:])
            return found[-1]

        try:
            wait_line("link to tcp:127.0.0.1", 15)
            with MavproxyProcess(f"tcp:127.0.0.1:{gcs_port}", tmp_path) as mavproxy:
                mavproxy.wait_for(r"Detected vehicle 1:1", 15)
                mission.write_text(reload_mission("Second"))
                mavproxy.send("set target_component 191")
                mavproxy.send("long USER_1 1")
                line = wait_line("helm reloaded", 15)
                assert line.rstrip().endswith(f"helm reloaded: {mission}: 4 tasks")
                mavproxy.send("long USER_2 1")
                wait_line("flag GoHome posted by the ground station", 15)
        finally:
            proc.terminate()
            proc.wait(30)
