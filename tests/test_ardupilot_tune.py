"""``mavhelm tune`` end to end on the real ArduPilot SITL (motorboat, ×10), short version: the
manoeuvre flown in GUIDED inside its box, the gains written into a copy of the mission, and
that mission then flown with them. Needs ``MAVHELM_ARDUPILOT``."""

from __future__ import annotations

import sys
import time

import pytest

from mavhelm.core.mission import load_mission
from tests.support.ardupilot import (
    CompanionProcess,
    RealOperator,
    truth_track,
    wait_line,
    wait_watching,
)
from tests.support.mission import mission_text
from tests.support.processes import ConsoleProcess

pytestmark = pytest.mark.slow

SPEEDUP = 10
STREAM_HZ = 4
HAND_OVER_WALL_S = 60.0
BOX = "--box=-60,-60,60,60"
MARGIN = 5.0
USER = mission_text("""
    Task = TrackLine
    {
        Name       = Out
        P1         = 0, 0
        P2         = 0, 60
        Thrust     = 80
        TimeOut    = 120
        FinishFlag = EndMission
    }
""", imavlink={"OnlineModes": "GUIDED", "MaxTurnRate": 45}, helm={"AppTick": 10},
    overall_timeout=200)


def test_tune_on_the_real_sitl_writes_gains_that_then_fly(real_sitl, tmp_path) -> None:
    sitl = real_sitl(model="motorboat", speedup=SPEEDUP)
    mission = tmp_path / "user.moos"
    mission.write_text(USER)
    tuned = tmp_path / "tuned.moos"
    with RealOperator(sitl.ports.serial0).wait_first_heartbeat(STREAM_HZ) as op:
        sitl.wait_listening(sitl.ports.serial1)
        tune = ConsoleProcess([sys.executable, "-m", "mavhelm.cli", "tune", str(mission),
                               "--connect", f"tcp:127.0.0.1:{sitl.ports.serial1}",
                               "--clock", "autopilot", BOX, "--confirm-open-water",
                               "--margin", f"{MARGIN:g}", "--step-seconds", "4",
                               "--time-limit", "120", "--write", str(tuned)],
                              cwd=tmp_path, log_path=tmp_path / "tune.log")
        try:
            wait_line(op, tune, "hand over in GUIDED")  # type: ignore[arg-type]
            started = time.monotonic()
            op.hand_over("GUIDED", timeout_s=HAND_OVER_WALL_S, retry_s=1.0 / sitl.speedup)
            wait_watching(op, None, lambda: not tune.running(), 120.0, "the tune to end")
        finally:
            code = tune.stop()
        console = tune.output(60)
        print(console)
        assert code == 0, console
        assert tune.find("YAW_PID_KP") and tune.find("wrote")
        track = truth_track(op, since_wall=started)
        assert track
        # truth is north/east from the first sample, taken at the origin (the SITL's home)
        worst = max(max(abs(n), abs(e)) - 60.0 for _, n, e, _ in track)
        print(f"furthest outside the box: {max(worst, 0.0):.2f} m")
        assert worst <= MARGIN
        helm = load_mission(tuned).process("pHelm")
        assert helm is not None and helm.entry("YAW_PID_KD") is not None
        assert helm.entry("LINE_PID_KP") is not None and helm.entry("LINE_PID_KD") is not None
        assert op.mode == "HOLD"

        comp = CompanionProcess(tuned, sitl.ports.serial1, tmp_path / "flown")
        try:
            wait_line(op, comp, "helm offline")
            op.hand_over("GUIDED", timeout_s=HAND_OVER_WALL_S, retry_s=1.0 / sitl.speedup)
            wait_line(op, comp, "helm ONLINE")
            wait_line(op, comp, "MISSION ENDED", timeout_s=120.0)
        finally:
            comp.stop()
        flown = comp.output(80)
        print(flown)
        assert "Out" in flown and not comp.find_all("timeout"), flown
