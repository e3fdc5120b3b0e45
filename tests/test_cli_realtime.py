"""The commands a user runs, on wall-clock time: ``mavhelm sim`` and ``mavhelm run`` as two
processes over TCP, and an operator's ground station (a third connection) handing over.

This is the vehicle's path with nothing simulated but the vehicle: real sockets, real clock,
the installed console commands. It takes about 20 s.
"""

from __future__ import annotations

import re
import signal
import subprocess
import sys
import time

import pytest

from mavhelm.companion.alog import read_alog
from mavhelm.demo.groundstation import GroundStation
from tests.support.mission import mission_text

pytestmark = pytest.mark.slow

TASKS = """
    Task = Timer
    {
        Name = Wait
        TimeOut = 2
        FinishFlag = Go
    }
    Task = ConstantHeading
    {
        Name = East
        Heading = 90
        Thrust = 60
        TimeOut = 6
        StartFlag = Go
        FinishFlag = EndMission
    }
"""


def command(*args: str) -> list[str]:
    return [sys.executable, "-m", "mavhelm.cli", *args]


def test_mavhelm_run_drives_mavhelm_sim_in_real_time(tmp_path):
    sim = subprocess.Popen(command("sim", "--fast-start", "--port", "0,0,0",
                                   "--home", "56.4120,-5.4760,0"),
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    companion = None
    gcs = None
    try:
        banner = sim.stdout.readline()
        ports = [int(p) for p in re.findall(r"tcp:127\.0\.0\.1:(\d+)", banner)]
        assert len(ports) == 3, banner
        mission = tmp_path / "east.moos"
        mission.write_text(mission_text(TASKS, imavlink={"Connect": f"tcp:127.0.0.1:{ports[0]}"},
                                         overall_timeout=60, end_name="AllStop"))
        companion = subprocess.Popen(command("run", str(mission), "--log-dir", str(tmp_path)),
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        gcs = GroundStation.connect(f"tcp:127.0.0.1:{ports[1]}")
        deadline = time.monotonic() + 30.0
        next_try = 0.0
        start = time.monotonic()
        while time.monotonic() < deadline and not (gcs.armed and gcs.mode == "GUIDED"):
            now = time.monotonic() - start
            gcs.tick(now)
            if now >= next_try:
                next_try = now + 1.0
                if not gcs.armed:
                    gcs.arm()
                else:
                    gcs.set_mode("GUIDED")
            time.sleep(0.05)
        assert gcs.armed and gcs.mode == "GUIDED", gcs.statustexts
        alogs = []
        ended = False
        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline and not ended:
            gcs.tick(time.monotonic() - start)
            time.sleep(0.2)
            alogs = list(tmp_path.glob("east_*.alog"))
            ended = bool(alogs) and any(m.name == "MISSION_ENDED" for m in read_alog(alogs[0]))
        assert ended, "the mission did not reach EndMission in real time"
        companion.send_signal(signal.SIGINT)
        out, err = companion.communicate(timeout=30)
        assert companion.returncode == 0, err
        assert "mavhelm: stopped" in out
        log = read_alog(alogs[0])
        started = [m.string for m in log if m.name == "TASK_STARTED"]
        assert started.index("Wait") < started.index("East") < started.index("AllStop")
        east = [m for m in log if m.name == "TASK_STARTED" and m.string == "East"][0]
        thrust = [m.double for m in log if m.name == "DESIRED_THRUST" and m.time > east.time]
        assert 60.0 in thrust, "the ConstantHeading task should have driven at 60 % thrust"
        headings = [m.double for m in log if m.name == "NAV_HEADING" and m.time > east.time + 4]
        assert headings and all(abs(h - 90.0) < 30.0 for h in headings), headings[-5:]
    finally:
        if gcs is not None:
            gcs.close()
        for proc in (companion, sim):
            if proc is not None and proc.poll() is None:
                proc.send_signal(signal.SIGINT)
                try:
                    proc.communicate(timeout=30)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.communicate()
