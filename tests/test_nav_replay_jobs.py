"""``mavhelm nav replay --fault``: the fault runs replayed in parallel processes report exactly
what they report one after another, in the same order."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np

from mavhelm.companion.alog import format_line
from mavhelm.core.bus import Message
from tests.support.mission import EKF_GPS_COMPASS

MISSION = "ProcessConfig = pNav\n{" + EKF_GPS_COMPASS + "}\n"


def _write_log(path: Path, seconds: float = 90.0) -> None:
    """A boat on a 50 m circle at 2 m/s: compass at 10 Hz, GPS (2 m noise) at 1 Hz, truth."""
    rng = np.random.default_rng(3)
    messages = []
    for k in range(int(seconds * 10)):
        t = 100.0 + 0.1 * k
        a = 2.0 / 50.0 * (t - 100.0)
        x, y = 50.0 * math.cos(a), 50.0 * math.sin(a)
        messages += [Message("INS_YAW", a, t, "iMAVLink"), Message("TRUTH_X", x, t, "sim"),
                     Message("TRUTH_Y", y, t, "sim")]
        if k % 10 == 0:
            messages += [Message("GPS_X", x + rng.normal(0, 2.0), t, "iMAVLink"),
                         Message("GPS_Y", y + rng.normal(0, 2.0), t, "iMAVLink")]
    path.write_text("".join(format_line(m, 100.0) + "\n" for m in messages))


def _replay(tmp_path: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "mavhelm.cli", "nav", "replay",
                           str(tmp_path / "m.moos"), str(tmp_path / "run.alog"), "--no-nav-log",
                           "--fault", "all", *extra], capture_output=True, text=True, check=False)


def _report(text: str) -> list[str]:
    return [line for line in text.splitlines() if not line.startswith("replay took")]


def test_parallel_fault_runs_report_as_one_after_another(tmp_path: Path) -> None:
    (tmp_path / "m.moos").write_text(MISSION)
    _write_log(tmp_path / "run.alog")
    one = _replay(tmp_path, "--jobs", "1")
    two = _replay(tmp_path, "--jobs", "2")
    assert one.returncode == 0 and two.returncode == 0, one.stdout + one.stderr + two.stderr
    faults = [line for line in _report(two.stdout) if line.startswith("== fault ")]
    assert faults == ["== fault heading_wander ==", "== fault heading_drift ==",
                      "== fault heading_offset ==", "== fault heading_jumps ==",
                      "== fault heading_stuck ==", "== fault gps_glitches ==",
                      "== fault heading_reversed =="]
    assert _report(two.stdout) == _report(one.stdout)
    assert two.stdout.count("replay took") == 8
    assert "NAV" in two.stdout and "position: RMS" in two.stdout


def test_jobs_below_one_is_refused(tmp_path: Path) -> None:
    (tmp_path / "m.moos").write_text(MISSION)
    _write_log(tmp_path / "run.alog", seconds=5.0)
    done = _replay(tmp_path, "--jobs", "0")
    assert done.returncode == 2
    assert "--jobs must be at least 1" in done.stdout


def test_faults_only_leaves_the_recorded_run_out_and_reports_the_rest_the_same(
        tmp_path: Path) -> None:
    (tmp_path / "m.moos").write_text(MISSION)
    _write_log(tmp_path / "run.alog", seconds=30.0)
    every = _replay(tmp_path, "--jobs", "1")
    only = _replay(tmp_path, "--jobs", "2", "--faults-only")
    assert every.returncode == 0 and only.returncode == 0, only.stdout + only.stderr
    assert only.stdout.count("replay took") == 7  # the seven faults, not the recording
    every_lines = _report(every.stdout)
    faults = every_lines[every_lines.index("== fault heading_wander ==") - 1:]
    assert _report(only.stdout) == faults  # each fault's report as before, the first headed too

def test_faults_only_needs_a_fault_and_a_bad_mission_is_said_as_itself(tmp_path: Path) -> None:
    (tmp_path / "m.moos").write_text(MISSION)
    _write_log(tmp_path / "run.alog", seconds=5.0)
    alone = subprocess.run([sys.executable, "-m", "mavhelm.cli", "nav", "replay",
                            str(tmp_path / "m.moos"), str(tmp_path / "run.alog"),
                            "--faults-only"], capture_output=True, text=True, check=False)
    assert alone.returncode == 2 and "--faults-only needs --fault" in alone.stdout
    (tmp_path / "m.moos").write_text(MISSION.replace("}", "    EKF_NOT_A_SETTING = 1\n}"))
    bad = _replay(tmp_path, "--faults-only")
    assert bad.returncode != 0
    assert "EKF_NOT_A_SETTING" in bad.stdout + bad.stderr
    assert "run failed" not in bad.stdout


def test_fault_all_says_so_when_the_mission_declares_no_sensor_to_make_faults_on(
        tmp_path: Path) -> None:
    routes_only = "ProcessConfig = pNav\n{\n    X = GPS @ 2\n    Y = GPS @ 2\n}\n"
    (tmp_path / "m.moos").write_text(routes_only)
    _write_log(tmp_path / "run.alog", seconds=5.0)
    done = _replay(tmp_path)
    assert done.returncode == 0, done.stdout + done.stderr
    assert "no fault of the library applies to this mission's pNav" in done.stdout
    assert "== fault" not in done.stdout and done.stdout.count("replay took") == 1
    (tmp_path / "m.moos").write_text(MISSION)
    assert "no fault of the library applies" not in _replay(tmp_path, "--jobs", "1").stdout
