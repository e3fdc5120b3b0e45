"""A malformed mission is refused by the real command with file:line and one reason; nothing starts.

The companion is pointed at a TCP port where nothing listens: if validation let the mission
through, it would try to connect and fail differently (a connection error, not exit code 2).
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

GOOD_TASKS = """
    Task = GoToWayPoint
    {
        Name = Leg1
        Location = 10, 20
        Radius = 5
    }
    Task = OverallTimeOut
    {
        TimeOut = 100
        FinishFlag = EndMission
    }
    Task = EndMission
    {
        StartFlag = EndMission
    }
"""


def mission(helm_body: str) -> str:
    return textwrap.dedent("""\
        LatOrigin = 56.0
        LongOrigin = -5.0
        ProcessConfig = pNav
        {
            X = GPS @ 2.0
            Y = GPS @ 2.0
            Yaw = INS @ 1.0
        }
        ProcessConfig = pHelm
        {
        """) + helm_body + "}\n"


CASES = {
    "unclosed brace": (mission(GOOD_TASKS).rstrip().rstrip("}"), 9, "never closed"),
    "unknown task type": (mission(GOOD_TASKS.replace("GoToWayPoint", "GoToWayPiont")), 12,
                          "GoToWayPiont"),
    "missing required parameter": (mission(GOOD_TASKS.replace("Location = 10, 20", "")), 12,
                                   "Location"),
    "bad number": (mission(GOOD_TASKS.replace("Radius = 5", "Radius = five")), 16, "Radius"),
    "no EndMission": (mission(GOOD_TASKS.split("    Task = EndMission")[0]), 9, "EndMission"),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_malformed_mission_is_refused_with_file_line_and_reason(tmp_path, case):
    text, line, word = CASES[case]
    path = tmp_path / "bad.moos"
    path.write_text(text)
    proc = subprocess.run(
        [sys.executable, "-m", "mavhelm.cli", "run", str(path),
         "--connect", "tcp:127.0.0.1:9", "--log-dir", str(tmp_path / "logs")],
        capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2, proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert lines[0].startswith(f"mavhelm: {path}:{line}: "), lines[0]
    assert word in lines[0]
    assert not (tmp_path / "logs").exists() or not any((tmp_path / "logs").iterdir())


def test_good_mission_passes_validation_and_then_tries_the_link(tmp_path):
    """The control case: the same mission, well formed, gets past validation to the link."""
    path = tmp_path / "good.moos"
    path.write_text(mission(GOOD_TASKS))
    from mavhelm.core.bus import Bus
    from mavhelm.core.clock import SimClock
    from mavhelm.core.mission import load_mission
    from mavhelm.nav.navigator import Navigator
    from mavhelm.tasks.helm import Helm

    loaded = load_mission(path)
    bus = Bus(SimClock())
    assert Helm.from_mission(bus, loaded) is not None
    assert Navigator.from_mission(bus, loaded) is not None


def test_an_unreachable_autopilot_is_waited_for_with_one_clear_line(tmp_path):
    """The companion may start first (a serial autopilot still booting, ArduPilot SITL's late
    SERIAL1): it keeps ticking and says once what it waits for, then stops on SIGTERM."""
    path = tmp_path / "good.moos"
    path.write_text(mission(GOOD_TASKS))
    proc = subprocess.Popen(
        [sys.executable, "-m", "mavhelm.cli", "run", str(path),
         "--connect", "tcp:127.0.0.1:9", "--log-dir", str(tmp_path / "logs")],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    lines = []
    try:
        assert proc.stdout is not None
        while not any("waiting for the autopilot" in line for line in lines):
            line = proc.stdout.readline()
            assert line, f"exited early: {proc.wait()} {proc.stderr.read() if proc.stderr else ''}"
            lines.append(line)
    finally:
        proc.terminate()
        out, err = proc.communicate(timeout=60)
    lines += out.splitlines()
    assert proc.returncode == 0, err
    waiting = [line for line in lines if "waiting for the autopilot" in line]
    assert len(waiting) == 1
    assert waiting[0].rstrip().endswith("  waiting for the autopilot at tcp:127.0.0.1:9: "
                                        "Connection refused; retrying every 1-8 s")
    assert lines[-1].strip() == "mavhelm: stopped"
    assert "Traceback" not in err


def test_a_malformed_connect_address_is_refused_before_anything_starts(tmp_path):
    path = tmp_path / "good.moos"
    path.write_text(mission(GOOD_TASKS))
    proc = subprocess.run(
        [sys.executable, "-m", "mavhelm.cli", "run", str(path), "--connect", "tcp:nohost",
         "--log-dir", str(tmp_path / "logs")], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert proc.stderr.startswith("usage: mavhelm run ")
    assert proc.stderr.strip().splitlines()[-1] == (
        "mavhelm run: error: argument --connect: 'tcp:nohost': expected tcp:HOST:PORT")


def test_a_zero_app_tick_is_refused_where_it_is(tmp_path):
    path = tmp_path / "tick.moos"
    path.write_text(mission("    AppTick = 0\n" + GOOD_TASKS))
    proc = subprocess.run(
        [sys.executable, "-m", "mavhelm.cli", "run", str(path),
         "--connect", "tcp:127.0.0.1:9", "--log-dir", str(tmp_path / "logs")],
        capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2
    assert proc.stderr.strip() == f"mavhelm: {path}:11: AppTick must be a number in [1, 50], got 0"
