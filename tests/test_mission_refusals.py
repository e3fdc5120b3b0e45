"""Every dangerous or crashing input found by mutating the demo mission is refused at load,
with its exact ``file:line: reason`` — before anything starts and before any link opens."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from mavhelm.companion.companion import Plan
from mavhelm.core.clock import SimClock
from mavhelm.core.mission import MissionError
from mavhelm.core.moos import FOREIGN

DEMO = (Path(__file__).resolve().parents[1] / "examples" / "demo.moos").read_text().splitlines()
HELM_KNOWN = ("known: AppTick, TaskFile, YAW_PID_KP, YAW_PID_KD, YAW_PID_KI, "
              "YAW_PID_INTEGRAL_LIMIT, LINE_PID_KP, LINE_PID_KD, LINE_PID_KI, "
              "LINE_PID_INTEGRAL_LIMIT, Z_TO_PITCH_PID_KP, Z_TO_PITCH_PID_KD, Z_TO_PITCH_PID_KI, "
              "Z_TO_PITCH_PID_INTEGRAL_LIMIT, PITCH_PID_KP, PITCH_PID_KD, PITCH_PID_KI, "
              "PITCH_PID_INTEGRAL_LIMIT, MAXRUDDER, MAXTHRUST, MAXELEVATOR, MAXPITCH, Allow)")


def _span(where: str, lines: list[str]) -> tuple[int, int]:
    """Line indexes (open brace, end) of a block of the demo: globals, a process or a task."""
    if where == "globals":
        return 0, next(i for i, line in enumerate(lines) if "ProcessConfig" in line) - 1
    if where.startswith("task:"):
        name = next(i for i, line in enumerate(lines)
                    if re.match(rf"\s*Name\s*=\s*{where[5:]}\b", line))
        start = max(i for i in range(name) if "{" in lines[i])
        return start, next(i for i in range(name, len(lines)) if "}" in lines[i])
    head = next(i for i, line in enumerate(lines)
                if re.match(rf"ProcessConfig\s*=\s*{where}\b", line))
    end = next(i for i in range(head + 2, len(lines))
               if lines[i].startswith("}") or "Task" in lines[i])
    return head + 1, end


def mutated(where: str, text: str, tmp_path: Path) -> tuple[Path, int]:
    """The demo with ``text`` replacing the same key in that block, or inserted at its top;
    returns the file and the (1-based) line of the mutation."""
    lines = list(DEMO)
    lo, hi = _span(where, lines)
    key = text.split("=")[0].strip().lower()
    line = None
    for i in range(lo, hi):
        m = re.match(r"\s*([A-Za-z_]+)\s*=", lines[i])
        if m and m.group(1).lower() == key and key != "stream":
            lines[i], line = "    " + text, i + 1
            break
    if line is None:
        lines.insert(lo + 1, "    " + text)
        line = lo + 2
    path = tmp_path / "mission.moos"
    path.write_text("\n".join(lines) + "\n")
    return path, line


FOUND = [
    # values that drove the boat at full thrust, held full rudder or never ended the mission
    ("pHelm", "MAXTHRUST = nan", "MAXTHRUST must be a finite number, got 'nan'"),
    ("task:AllStop", "EndThrust = nan", "EndThrust must be a finite number, got 'nan'"),
    ("task:South", "Thrust = nan", "Thrust must be a finite number, got 'nan'"),
    ("task:South", "Heading = nan", "Heading must be a finite number, got 'nan'"),
    ("task:South", "Heading = inf", "Heading must be a finite number, got 'inf'"),
    ("pHelm", "MAXRUDDER = nan", "MAXRUDDER must be a finite number, got 'nan'"),
    ("iMAVLink", "MaxTurnRate = nan", "MaxTurnRate must be a finite number, got 'nan'"),
    ("iMAVLink", "MaxTurnRate = inf", "MaxTurnRate must be a finite number, got 'inf'"),
    ("iMAVLink", "MaxTurnRate = -45", "MaxTurnRate must be a number in (0, 360], got -45"),
    ("iMAVLink", "MaxTurnRate = 0", "MaxTurnRate must be a number in (0, 360], got 0"),
    ("iMAVLink", "MaxTurnRate = 1e308", "MaxTurnRate must be a number in (0, 360], got 1e308"),
    ("pHelm", "AppTick = nan", "AppTick must be a finite number, got 'nan'"),
    ("pHelm", "AppTick = inf", "AppTick must be a finite number, got 'inf'"),
    ("pHelm", "AppTick = 1e9", "AppTick must be a number in [1, 50], got 1e9"),
    ("pHelm", "AppTick = 1e-320", "AppTick must be a number in [1, 50], got 1e-320"),
    ("iMAVLink", "LinkTimeOut = inf", "LinkTimeOut must be a finite number, got 'inf'"),
    ("iMAVLink", "LinkTimeOut = 0", "LinkTimeOut must be a number in [1, 60], got 0"),
    ("iMAVLink", "LinkTimeOut = -1", "LinkTimeOut must be a number in [1, 60], got -1"),
    ("iMAVLink", "LinkTimeOut = nan", "LinkTimeOut must be a finite number, got 'nan'"),
    ("task:MissionClock", "TimeOut = nan", "TimeOut must be a finite number, got 'nan'"),
    ("task:MissionClock", "TimeOut = inf", "TimeOut must be a finite number, got 'inf'"),
    ("task:Home", "Radius = nan", "Radius must be a finite number, got 'nan'"),
    ("task:Home", "Radius = inf", "Radius must be a finite number, got 'inf'"),
    ("task:Home", "Location = nan,nan",
     "Location must be x,y[,z] in finite metres within ±100000, got 'nan,nan'"),
    ("globals", "LatOrigin = 256", "LatOrigin must be a number in [-90, 90], got 256"),
    ("globals", "LatOrigin = -100", "LatOrigin must be a number in [-90, 90], got -100"),
    ("globals", "LatOrigin = nan", "LatOrigin must be a finite number, got 'nan'"),
    ("globals", "LongOrigin = 256", "LongOrigin must be a number in [-180, 180], got 256"),
    ("globals", "LongOrigin = nan", "LongOrigin must be a finite number, got 'nan'"),
    ("pHelm", "YAW_PID_KP = nan", "YAW_PID_KP must be a finite number, got 'nan'"),
    ("pHelm", "YAW_PID_KD = inf", "YAW_PID_KD must be a finite number, got 'inf'"),
    ("pHelm", "YAW_PID_KI = -inf", "YAW_PID_KI must be a finite number, got '-inf'"),
    ("pHelm", "YAW_PID_INTEGRAL_LIMIT = nan",
     "YAW_PID_INTEGRAL_LIMIT must be a finite number, got 'nan'"),
    ("pHelm", "LINE_PID_KP = nan", "LINE_PID_KP must be a finite number, got 'nan'"),
    ("pHelm", "LINE_PID_KD = -1", "LINE_PID_KD must be a number in [0, 1000], got -1"),
    # values that ended in a traceback
    ("iMAVLink", "Baud = nan", "Baud must be a finite number, got 'nan'"),
    ("iMAVLink", "SystemID = 1e999", "SystemID must be a finite number, got '1e999'"),
    ("iMAVLink", "ComponentID = inf", "ComponentID must be a finite number, got 'inf'"),
    ("iMAVLink", "TargetSystem = nan", "TargetSystem must be a finite number, got 'nan'"),
    ("iMAVLink", "Stream = GPS_RAW_INT@nan",
     "Stream GPS_RAW_INT rate must be a finite number, got 'nan'"),
    ("iMAVLink", "Stream = ATTITUDE@1e-300",
     "Stream ATTITUDE rate must be 0 (off) or at least 0.1 Hz, got 1e-300"),
    ("iMAVLink", "SystemID = 300", "SystemID must be a whole number in [1, 255], got 300"),
    # typos and settings of features that do not exist yet
    ("pHelm", "MAXRUDER = 5",
     f"unknown setting 'MAXRUDER' for pHelm (did you mean MAXRUDDER? {HELM_KNOWN}"),
    ("pHelm", "AppTik = 1",
     f"unknown setting 'AppTik' for pHelm (did you mean AppTick? {HELM_KNOWN}"),
    ("pNav", "EKF_LAG = 9", "EKF_LAG must be a number in [0, 4], got 9"),
    ("pNav", "EKF_LAG = nan", "EKF_LAG must be a finite number, got 'nan'"),
    ("pNav", "SENSOR_XY = GPS->gps @ 0,0,nan ~ 3",
     "SENSOR_XY lever arm must be a finite number, got 'nan'"),
    ("pNav", "SENSOR_XY = GPS->gps @ 0,0,0 ~ -3",
     "SENSOR_XY noise must be a number in [0.01, 10000], got -3"),
    ("pNav", "SENSOR_XY = GPS gps @ 0,0,0 ~ 3",
     "SENSOR_XY expects SOURCE -> name @ x,y,z[,twist deg] ~ noise (m), got "
     "'GPS gps @ 0,0,0 ~ 3'"),
    ("pNav", "SENSOR_XY = GPS->gps @ 0,0,0 ~ 3, 4",
     "SENSOR_XY: at most 1 noise value(s) (m), got 2"),
    ("pNav", "LSQTimeOut = inf", "LSQTimeOut must be a finite number, got 'inf'"),
    ("pNav", "BEACON = 1 @ 5,nan,0", "BEACON position must be a finite number, got 'nan'"),
    ("pNav", "FIXEDDEPTH = 0", "FIXEDDEPTH expects value @ sigma (m), got '0'"),
    ("iMAVLink", "Actuation = rc_override_please",
     "Actuation expects one of guided, rc_override, got 'rc_override_please'"),
]


@pytest.mark.parametrize(("where", "text", "reason"), FOUND,
                         ids=[f"{w}:{t}" for w, t, _ in FOUND])
def test_a_found_input_is_refused_with_its_file_line_and_reason(where, text, reason, tmp_path):
    path, line = mutated(where, text, tmp_path)
    with pytest.raises(MissionError) as err:
        Plan.from_mission(path, SimClock())
    assert str(err.value) == f"{path}:{line}: {reason}"


def test_the_unmutated_demo_loads(tmp_path):
    path = tmp_path / "demo.moos"
    path.write_text("\n".join(DEMO) + "\n")
    plan = Plan.from_mission(path, SimClock())
    assert [t.name for t in plan.helm.tasks][:2] == ["InitialDelay", "South"]


def test_an_unknown_process_block_is_refused(tmp_path):
    path = tmp_path / "m.moos"
    path.write_text("\n".join(DEMO) + "\nProcessConfig = pHlem\n{\n  AppTick = 5\n}\n")
    with pytest.raises(MissionError) as err:
        Plan.from_mission(path, SimClock())
    line = len(DEMO) + 1
    assert str(err.value) == (f"{path}:{line}: unknown ProcessConfig = pHlem "
                              "(known: iMAVLink, pNav, pHelm, pLogger, iSerial_<label>, and "
                              "the MOOS processes mavhelm does not run: "
                              f"{', '.join(p.name for p in FOREIGN)})")


def test_a_setting_given_twice_is_refused_at_the_second(tmp_path):
    path, line = mutated("task:South", "Thrust = 10", tmp_path)
    text = path.read_text().splitlines()
    text.insert(line, "    Thrust = 90")
    path.write_text("\n".join(text) + "\n")
    with pytest.raises(MissionError) as err:
        Plan.from_mission(path, SimClock())
    assert str(err.value) == (f"{path}:{line + 1}: Thrust is already set at line {line}; "
                              "give each setting once")


def _with_task_file(tmp_path: Path, target: str) -> tuple[Path, int]:
    return mutated("pHelm", f"TaskFile = {target}", tmp_path)


@pytest.mark.parametrize(("target", "why"), [
    ("/dev/zero", "it is a device, not a regular file"),
    ("/dev/urandom", "it is a device, not a regular file"),
    ("/dev/null", "it is a device, not a regular file"),
])
def test_a_task_file_that_is_a_device_is_refused(target, why, tmp_path):
    path, line = _with_task_file(tmp_path, target)
    with pytest.raises(MissionError) as err:
        Plan.from_mission(path, SimClock())
    assert str(err.value) == f"{path}:{line}: cannot read TaskFile {target!r}: {why}"


def test_a_task_file_that_is_a_fifo_is_refused_without_hanging(tmp_path):
    fifo = tmp_path / "tasks.hoof"
    os.mkfifo(fifo)
    path, line = _with_task_file(tmp_path, str(fifo))
    with pytest.raises(MissionError) as err:
        Plan.from_mission(path, SimClock())
    assert str(err.value) == (f"{path}:{line}: cannot read TaskFile {str(fifo)!r}: "
                              "it is a pipe (FIFO), not a regular file")


def test_a_task_file_that_is_a_directory_or_too_big_or_the_mission_itself_is_refused(tmp_path):
    path, line = _with_task_file(tmp_path, str(tmp_path))
    with pytest.raises(MissionError, match=r"it is a directory, not a file$"):
        Plan.from_mission(path, SimClock())
    big = tmp_path / "big.hoof"
    big.write_text("// x\n" * 300_000)
    path, line = _with_task_file(tmp_path, str(big))
    with pytest.raises(MissionError) as err:
        Plan.from_mission(path, SimClock())
    assert str(err.value).endswith("it is larger than 1024 KiB")
    path, line = _with_task_file(tmp_path, "mission.moos")
    with pytest.raises(MissionError) as err:
        Plan.from_mission(path, SimClock())
    assert str(err.value) == (f"{path}:{line}: TaskFile names this mission file itself; "
                              "name a .hoof file of Task blocks")


def test_the_mission_path_itself_must_be_a_regular_file(tmp_path):
    with pytest.raises(MissionError) as err:
        Plan.from_mission(str(tmp_path), SimClock())
    assert str(err.value) == (f"{tmp_path}:0: cannot read mission file: "
                              "it is a directory, not a file")


def test_stdin_as_task_file_is_not_read(tmp_path):
    """``/dev/stdin`` on a pipe would block or swallow the terminal: refused, and the
    process neither hangs nor reads what is sent to it."""
    path, line = _with_task_file(tmp_path, "/dev/stdin")
    proc = subprocess.run(
        [sys.executable, "-m", "mavhelm.cli", "run", str(path), "--connect", "tcp:127.0.0.1:9",
         "--log-dir", str(tmp_path / "logs")],
        input="Task = Timer\n{\n}\n", capture_output=True, text=True, timeout=60)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.startswith(f"mavhelm: {path}:{line}: cannot read TaskFile '/dev/stdin': ")
    assert "not a regular file" in proc.stderr


def test_the_logger_block_is_checked_like_every_other(tmp_path):
    from mavhelm.companion.alog import log_dir
    from mavhelm.core.mission import load_mission

    path = tmp_path / "m.moos"
    path.write_text("\n".join(DEMO) + "\nProcessConfig = pLogger\n{\n  LogDir = /data/logs\n}\n")
    assert log_dir(load_mission(path)) == "/data/logs"
    path.write_text("\n".join(DEMO) + "\nProcessConfig = pLogger\n{\n  SyncLog = true\n}\n")
    with pytest.raises(MissionError) as err:
        Plan.from_mission(path, SimClock())
    assert str(err.value) == (f"{path}:{len(DEMO) + 3}: mavhelm writes no synchronous .slog; "
                              "remove SyncLog or set it false, got true")
