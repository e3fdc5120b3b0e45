"""``mavhelm demo``: the run's files are written and say what happened."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from mavhelm.cli import main
from mavhelm.companion.alog import read_alog

pytestmark = pytest.mark.slow

DEMO = Path(__file__).resolve().parent.parent / "examples" / "demo.moos"


def test_demo_command_writes_log_plot_track_and_summary(tmp_path, capsys):
    assert main(["demo", str(DEMO), "--out", str(tmp_path), "--fast-start"]) == 0
    printed = capsys.readouterr().out
    (run_dir,) = list(tmp_path.iterdir())
    assert {p.name for p in run_dir.iterdir()} == {"mission.alog", "track.png", "track.csv",
                                                   "summary.txt"}
    assert (run_dir / "track.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    summary = (run_dir / "summary.txt").read_text()
    assert summary.strip() in printed
    order = re.findall(r"^\s*\d+\.\s+(\S+)", summary, flags=re.MULTILINE)
    assert order == ["InitialDelay", "MissionClock", "South", "North", "Home", "AllStop"]
    assert "Mission ended by AllStop" in summary
    log = read_alog(run_dir / "mission.alog")
    names = {m.name for m in log}
    assert {"GPS_X", "NAV_X", "DESIRED_RUDDER", "TASK_STARTED", "MISSION_ENDED"} <= names
    track = (run_dir / "track.csv").read_text().splitlines()
    assert track[0] == "t,x,y,heading,surge,yaw_rate" and len(track) > 1000


def test_demo_of_a_malformed_mission_starts_nothing(tmp_path, capsys):
    bad = tmp_path / "bad.moos"
    bad.write_text("ProcessConfig = pHelm\n{\n")
    assert main(["demo", str(bad), "--out", str(tmp_path / "runs")]) == 2
    assert f"{bad}:1:" in capsys.readouterr().err
    assert not (tmp_path / "runs").exists()


def test_the_demo_runs_on_an_ardupilot_sitl_model():
    """``model=`` puts the companion on ArduPilot's SITL motorboat (steering + throttle):
    handed over in GUIDED, the helm drives it away under way."""
    from mavhelm.demo.harness import SimulatedRun

    with SimulatedRun.start(DEMO, model="motorboat") as run:
        assert run.sim.model.name == "motorboat"
        assert (run.sim.params["SERVO1_FUNCTION"], run.sim.params["SERVO3_FUNCTION"]) == (26, 70)
        run.hand_over()
        run.run_for(30.0)
        assert run.sim.mode == "GUIDED" and run.sim.truth.surge > 1.0
        assert max(abs(run.sim.truth.x), abs(run.sim.truth.y)) > 20.0
