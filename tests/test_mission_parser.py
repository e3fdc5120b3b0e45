from pathlib import Path

import pytest

from mavhelm.core.mission import (
    MissionError,
    load_mission,
    load_tasks,
    parse_mission,
    parse_tasks,
)

MISSION = """\
// harbour test
ServerHost = localhost
LatOrigin  = 43.825300   // degrees
LongOrigin = -70.330400

ProcessConfig = pNav
{
   AppTick = 10
   X = GPS @ 2.0 , EKF @ 2.5 ,LSQ @ 5.0 ,
}

ProcessConfig = pHelm {
   AppTick = 4
   YAW_PID_KP = 0.5
   Task = ConstantHeading
   {
      Priority = 3
      Name = South
      Heading = 180
      FinishFlag = GoNorth  // flag names keep their case
   }
   TaskFile = lib/survey.hoof
   Task = OverallTimeOut {
      TimeOut = 3600
   }
}

Task = EndMission
{
   Priority = 0
}
"""

HOOF = """\
// a library mission
Task = GoToWayPoint
{
   Location = 200, 400, 0
   Radius = 5
}
Task = Timer {
   TimeOut = 30
}
"""


def write(tmp_path: Path, text: str, name: str = "m.moos") -> Path:
    path = tmp_path / name
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


@pytest.fixture
def mission_path(tmp_path: Path) -> Path:
    write(tmp_path, HOOF, "lib/survey.hoof")
    return write(tmp_path, MISSION)


def test_globals_keep_case_of_values_and_strip_comments(mission_path: Path) -> None:
    m = load_mission(mission_path)
    assert m.globals.kind == "Global"
    assert m.globals.get("serverhost") == "localhost"
    assert m.globals.require("LATORIGIN").as_float() == pytest.approx(43.8253)
    assert m.globals.entry("LongOrigin").line == 4
    assert m.path == str(mission_path)


def test_processes_hold_their_entries_with_lines(mission_path: Path) -> None:
    m = load_mission(mission_path)
    assert set(m.processes) == {"pNav", "pHelm"}
    nav = m.process("PNAV")
    assert nav is not None and nav.line == 6 and nav.kind == "ProcessConfig"
    x = nav.entry("x")
    assert x is not None
    assert x.value == "GPS @ 2.0 , EKF @ 2.5 ,LSQ @ 5.0 ,"
    assert (x.file, x.line) == (str(mission_path), 9)
    helm = m.process("pHelm")
    assert helm is not None
    assert helm.get("taskfile") == "lib/survey.hoof"
    assert helm.get_float("Yaw_Pid_Kp", 0.0) == 0.5


def test_tasks_in_order_of_appearance_including_task_file(mission_path: Path) -> None:
    m = load_mission(mission_path)
    assert [t.name for t in m.tasks] == [
        "ConstantHeading",
        "GoToWayPoint",
        "Timer",
        "OverallTimeOut",
        "EndMission",
    ]
    assert all(t.kind == "Task" for t in m.tasks)
    heading = m.tasks[0]
    assert heading.get("finishflag") == "GoNorth"
    assert heading.get("Name") == "South"
    waypoint = m.tasks[1]
    assert waypoint.file == str(mission_path.parent / "lib/survey.hoof")
    assert waypoint.line == 2
    assert waypoint.get("location") == "200, 400, 0"
    assert m.tasks[3].get("TimeOut") == "3600"
    helm = m.process("pHelm")
    assert helm is not None
    assert [t.name for t in helm.tasks] == [
        "ConstantHeading",
        "GoToWayPoint",
        "Timer",
        "OverallTimeOut",
    ]


def test_load_tasks_reads_a_hoof_file(tmp_path: Path) -> None:
    tasks = load_tasks(write(tmp_path, HOOF, "a.hoof"))
    assert [(t.name, t.line) for t in tasks] == [("GoToWayPoint", 2), ("Timer", 7)]
    assert tasks[1].get_float("timeout", 0) == 30


def test_crlf_and_brace_on_next_line_after_comment(tmp_path: Path) -> None:
    text = "ProcessConfig = pHelm // the helm\r\n// brace follows\r\n{\r\n  A = 1\r\n}\r\n"
    m = parse_mission(text, "x.moos")
    helm = m.process("pHelm")
    assert helm is not None and helm.get("a") == "1"


def error_of(text: str, file: str = "bad.moos") -> MissionError:
    with pytest.raises(MissionError) as info:
        parse_mission(text, file)
    return info.value


@pytest.mark.parametrize(
    ("text", "line", "words"),
    [
        ("A = 1\nProcessConfig = pHelm\n{\n  B = 2\n", 2, "never closed"),
        ("ProcessConfig = pHelm\n{\nTask = Timer {\n  B = 2\n}\n", 1, "never closed"),
        ("ProcessConfig = pHelm\n{\nTask = Timer {\n  B = 2\n", 3, "never closed"),
        ("A = 1\n}\n", 2, "stray '}'"),
        ("ProcessConfig = p\n{\n  this is not a pair\n}\n", 3, "expected Key = Value"),
        ("ProcessConfig = a\n{\n}\n  {\n", 4, "'{' without a block header"),
        ("A = 1\n\n  {\n", 3, "unknown block A = 1"),
        ("Task = Timer { TimeOut = 3\n}\n", 1, "own lines"),
        ("{\nA = 1\n}\n", 1, "'{' without a block header"),
        ("ProcessConfig = a\n{\nProcessConfig = b\n{\n}\n}\n", 3, "nested ProcessConfig"),
        ("ProcessConfig = a\n{\n  = 3\n}\n", 3, "empty key"),
        ("ProcessConfig = pNav\n{\nTask = Timer\n{\n}\n}\n", 3, "pHelm"),
        ("Task = Timer\n{\nTask = Timer\n{\n}\n}\n", 3, "nested Task"),
        ("LatOrigin = 1\nhello world\n", 2, "ProcessConfig = Name or Task = Type"),
        ("Behavior = BHV_Waypoint\n{\n}\n", 2, "unknown block Behavior"),
        ("Behavior = BHV_Waypoint {\n}\n", 1, "unknown block Behavior"),
        ("ProcessConfig = pHelm\nA = 1\n", 1, "expected '{'"),
        ("ProcessConfig = pHelm\n", 1, "expected '{'"),
        ("ProcessConfig =\n{\n}\n", 1, "needs a process name"),
        ("ProcessConfig = a\n{\n}\nProcessConfig = A\n{\n}\n", 4, "already configured"),
        ("ProcessConfig = a\n{\n} trailing\n", 3, "alone on its line"),
    ],
)
def test_errors_are_located_and_say_what_was_expected(text: str, line: int, words: str) -> None:
    err = error_of(text)
    assert (err.file, err.line) == ("bad.moos", line)
    assert words in err.reason
    assert str(err).startswith(f"bad.moos:{line}: ")
    assert "\n" not in str(err)


def test_missing_task_file_is_an_error_at_the_task_file_line(tmp_path: Path) -> None:
    path = write(tmp_path, "ProcessConfig = pHelm\n{\n  AppTick = 4\n  TaskFile = nope.hoof\n}\n")
    with pytest.raises(MissionError) as info:
        load_mission(path)
    assert str(info.value).startswith(f"{path}:4: ")
    assert "nope.hoof" in info.value.reason


def test_error_inside_task_file_points_into_the_hoof(tmp_path: Path) -> None:
    write(tmp_path, "Task = Timer\n{\n  TimeOut = 3\n", "t.hoof")
    path = write(tmp_path, "ProcessConfig = pHelm\n{\n  TaskFile = t.hoof\n}\n")
    with pytest.raises(MissionError) as info:
        load_mission(path)
    assert info.value.file == str(tmp_path / "t.hoof")
    assert info.value.line == 1
    assert "never closed" in info.value.reason


def test_hoof_holds_only_tasks() -> None:
    with pytest.raises(MissionError) as info:
        parse_tasks("Task = Timer\n{\n}\nLatOrigin = 3\n", "x.hoof")
    assert str(info.value).startswith("x.hoof:4: ")
    with pytest.raises(MissionError) as info:
        parse_tasks("ProcessConfig = pHelm\n{\n}\n", "x.hoof")
    assert info.value.line == 1


def test_unreadable_mission_file_is_a_mission_error(tmp_path: Path) -> None:
    with pytest.raises(MissionError) as info:
        load_mission(tmp_path / "absent.moos")
    assert "absent.moos" in str(info.value)
