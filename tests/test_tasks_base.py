"""The Task base: Table 1 properties, refusals with file:line, completion causes."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from mavhelm.core.bus import Message
from mavhelm.core.mission import Block, MissionError
from mavhelm.tasks.base import NavState, State, Task
from mavhelm.tasks.heading import ConstantHeading
from mavhelm.tasks.registry import build_task, known_types, task_class

# tblock, msg: fixtures in conftest.py
SOURCE = "south.moos"

TBlock = Callable[..., Block]
Msg = Callable[[str, float | str, float], Message]
HeadingTask = Callable[..., ConstantHeading]


@pytest.fixture
def heading_task(tblock: TBlock) -> HeadingTask:
    """``heading_task(*(key, value))``: a ConstantHeading to 180 in south.moos, block at line 30,
    so the first extra setting sits at line 32."""

    def make(*pairs: tuple[str, str]) -> ConstantHeading:
        task = build_task(tblock("ConstantHeading", ("Heading", "180"), *pairs,
                                 file=SOURCE, line=30))
        assert isinstance(task, ConstantHeading)
        return task

    return make


def test_table1_properties_are_read(heading_task: HeadingTask) -> None:
    t = heading_task(
        ("Name", "South"),
        ("StartFlag", "MissionStart, Go"),
        ("FinishFlag", "GoNorth"),
        ("EventFlag", "E1,E2"),
        ("TimeOut", "300"),
        ("InitialState", "off"),
        ("Priority", "2"),
        ("LOGPID", "true"),
    )
    assert t.name == "South"
    assert t.start_flags == ["MissionStart", "Go"]
    assert t.finish_flags == ["GoNorth"]
    assert t.event_flags == ["E1", "E2"]
    assert (t.timeout, t.initial_on, t.priority, t.log_pid) == (300.0, False, 2, True)


def test_defaults_priority_3_timeout_100(heading_task: HeadingTask) -> None:
    t = heading_task(("InitialState", "ON"))
    assert (t.priority, t.timeout, t.name) == (3, 100.0, "ConstantHeading")


def test_timeout_never_and_case_insensitive_keys(heading_task: HeadingTask) -> None:
    t = heading_task(("timeout", "never"), ("INITIALSTATE", "ON"))
    assert t.timeout is None


def test_registry_is_case_insensitive_and_accepts_timeout_alias() -> None:
    assert task_class("gotowaypoint") is task_class("GoToWayPoint")
    assert task_class("TimeOut") is task_class("Timer")
    assert "TimeOut" in known_types() and "EndMission" in known_types()


@pytest.mark.parametrize(
    ("pairs", "line", "expected"),
    [
        ((("Heding", "90"),), 32,
         "unknown setting 'Heding' for a ConstantHeading task (did you mean Heading? known: Name,"),
        ((("Priority", "0"),), 32, "Priority must be a whole number in [1, 1000], got 0"),
        ((("Priority", "1.5"),), 32, "Priority must be a whole number"),
        ((("TimeOut", "soon"),), 32, "TimeOut expects a number"),
        ((("TimeOut", "-5"),), 32, "TimeOut must be a number in (0, 604800], got -5"),
        ((("InitialState", "maybe"),), 32, "InitialState expects one of ON, OFF, got 'maybe'"),
        ((("StartFlag", "A,,B"),), 32, "comma-separated"),
        ((("LOGPID", "sure"),), 32, "LOGPID expects true or false"),
        ((("Thrust", "150"),), 32, "Thrust must be a number in [-100, 100], got 150"),
        ((("Name", "Leg 7"),), 32, "Name must be one word"),
    ],
)
def test_bad_parameters_are_refused_at_their_line(
    pairs: tuple[tuple[str, str], ...], line: int, expected: str, heading_task: HeadingTask
) -> None:
    with pytest.raises(MissionError) as err:
        heading_task(*pairs, ("InitialState", "ON"))
    assert expected in str(err.value)
    assert str(err.value).startswith(f"south.moos:{line}:")


def test_unknown_parameter_message_lists_known_ones(heading_task: HeadingTask) -> None:
    with pytest.raises(MissionError, match="known: .*Thrust, Heading"):
        heading_task(("Speed", "2"))


def test_missing_required_parameter_is_located_at_the_block(tblock: TBlock) -> None:
    with pytest.raises(MissionError) as err:
        build_task(tblock("ConstantHeading", ("InitialState", "ON"), file=SOURCE, line=40))
    assert str(err.value).startswith("south.moos:40:")
    assert "needs Heading" in str(err.value)


def test_off_task_without_start_flag_can_never_run(heading_task: HeadingTask) -> None:
    with pytest.raises(MissionError, match="can never run"):
        heading_task(("InitialState", "OFF"))


def test_unknown_task_type_lists_the_known_ones(tblock: TBlock) -> None:
    with pytest.raises(MissionError) as err:
        build_task(tblock("GoToWaypiont", ("Location", "1,2"), file=SOURCE, line=50))
    assert str(err.value).startswith("south.moos:50:")
    assert "GoToWayPoint" in str(err.value) and "OverallTimeOut" in str(err.value)


def test_start_flag_wakes_idle_task_whatever_its_value(heading_task: HeadingTask, msg: Msg) -> None:
    t = heading_task(("StartFlag", "Go"), ("Name", "S"))
    t.offer(msg("Other", 1.0, 0.0), 0.0)
    assert t.state is State.IDLE
    t.offer(msg("Go", "anything", 1.0), 2.0)
    assert t.state is State.ACTIVE and t.start_time == 2.0
    assert t.take_notifications() == [("TASK_STARTED", "S")]


def test_finished_task_is_not_restarted_by_its_start_flag(
    heading_task: HeadingTask, msg: Msg
) -> None:
    t = heading_task(("StartFlag", "Go"), ("Name", "S"))
    t.offer(msg("Go", 1.0, 0.0), 0.0)
    t.end("timeout", "x")
    t.offer(msg("Go", 1.0, 5.0), 5.0)
    assert t.state is State.DONE


def test_timeout_ends_with_finish_flags_carrying_the_reason(
    heading_task: HeadingTask, msg: Msg
) -> None:
    t = heading_task(("StartFlag", "Go"), ("Name", "S"), ("TimeOut", "10"), ("FinishFlag", "A,B"))
    nav = NavState()
    t.start(0.0)
    t.take_notifications()
    nav.update(msg("NAV_HEADING", 180.0, 10.0))
    assert t.step(nav, 10.0) is not None, "at exactly TimeOut the task still runs"
    assert t.step(nav, 10.5) is None
    assert t.end_cause == "timeout"
    out = t.take_notifications()
    assert out[0] == ("TASK_ENDED", "S:timeout")
    assert [name for name, _ in out[1:]] == ["A", "B"]
    assert "timed out after 10 s" in str(out[1][1])


def test_starvation_posts_error_and_finish_flags(heading_task: HeadingTask, msg: Msg) -> None:
    t = heading_task(("StartFlag", "Go"), ("Name", "S"), ("FinishFlag", "Next"))
    nav = NavState()
    t.start(0.0)
    nav.update(msg("NAV_HEADING", 180.0, 1.0))
    assert t.step(nav, 11.0) is not None
    assert t.step(nav, 11.5) is None
    assert t.end_cause == "starved"
    out = dict(t.take_notifications())
    assert out["TASK_ENDED"] == "S:starved"
    assert "NAV_HEADING" in str(out["S_ERROR"]) and "\n" not in str(out["S_ERROR"])
    assert out["Next"] == out["S_ERROR"]


def test_never_heard_variable_starves_ten_seconds_after_activation(
    heading_task: HeadingTask
) -> None:
    t = heading_task(("StartFlag", "Go"), ("Name", "S"))
    nav = NavState()
    t.start(100.0)
    assert t.step(nav, 110.0) is None and t.active, "no data yet: wait, do not vote"
    t.step(nav, 110.1)
    assert t.end_cause == "starved"


def test_nav_yaw_feeds_heading(msg: Msg) -> None:
    nav = NavState()
    nav.update(msg("NAV_YAW", -1.5707963267948966, 3.0))
    assert nav.heading == pytest.approx(90.0)
    assert nav.time("NAV_HEADING") == 3.0


def test_event_posts_event_flags_and_keeps_running(heading_task: HeadingTask) -> None:
    t = heading_task(("InitialState", "ON"), ("EventFlag", "Ev1,Ev2"))
    t.start(0.0)
    t.take_notifications()
    t.event("too deep")
    assert t.take_notifications() == [("TASK_EVENT", f"{t.name}: too deep"), ("Ev1", "too deep"),
                                      ("Ev2", "too deep")], "said to the operator, then flagged"
    assert t.active


class _Custom(Task):
    keyword = "Custom"


def test_base_hooks_are_inert(tblock: TBlock) -> None:
    t = _Custom(tblock("Custom", ("InitialState", "ON"), file=SOURCE, line=30))
    t.start(0.0)
    assert t.needs() == set()
    assert t.step(NavState(), 50.0) is None and t.active


def test_initially_on_task_ignores_its_start_flag(heading_task: HeadingTask, msg: Msg) -> None:
    t = heading_task(("InitialState", "ON"), ("StartFlag", "Go"))
    t.offer(msg("Go", 1.0, 0.0), 0.0)
    assert t.state is State.IDLE, "ON tasks start with the mission, not on a flag"


def test_initial_state_defaults_to_on_unless_a_start_flag_is_given(
    heading_task: HeadingTask
) -> None:
    assert heading_task().initial_on is True
    assert heading_task(("StartFlag", "Go")).initial_on is False
    assert heading_task(("StartFlag", "Go"), ("InitialState", "ON")).initial_on is True
