"""Each task type's own behaviour and parameters."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from mavhelm.core.mission import Block, MissionError
from mavhelm.tasks.base import NavState
from mavhelm.tasks.end_mission import EndMission
from mavhelm.tasks.heading import ConstantHeading
from mavhelm.tasks.overall_timeout import OverallTimeOut
from mavhelm.tasks.registry import build_task
from mavhelm.tasks.timer import Timer
from mavhelm.tasks.waypoint import GoToWayPoint

# tblock (blocks in t.moos at line 60 by default), nav_at: fixtures in conftest.py
TBlock = Callable[..., Block]
NavAt = Callable[..., NavState]
Waypoint = Callable[..., GoToWayPoint]


@pytest.fixture
def waypoint(tblock: TBlock) -> Waypoint:
    """``waypoint(*(key, value))``: a started GoToWayPoint, initially ON, block at t.moos:60."""

    def make(*pairs: tuple[str, str]) -> GoToWayPoint:
        task = build_task(tblock("GoToWayPoint", ("InitialState", "ON"), *pairs))
        assert isinstance(task, GoToWayPoint)
        task.start(0.0)
        return task

    return make


def test_waypoint_parameters(waypoint: Waypoint) -> None:
    t = waypoint(("Location", "10, -20, 3"), ("Radius", "2"), ("Thrust", "40"))
    assert t.location == (10.0, -20.0, 3.0)
    assert (t.radius, t.thrust) == (2.0, 40.0)
    assert t.needs() == {"NAV_X", "NAV_Y", "NAV_HEADING"}
    assert waypoint(("Location", "1,2")).radius == 5.0


@pytest.mark.parametrize(
    ("pairs", "expected", "line"),
    [
        ((), "needs Location", 60),
        ((("Location", "1"),), "expects x,y", 62),
        ((("Location", "1,a"),), "expects x,y", 62),
        ((("Location", "1,2"), ("Radius", "0")),
         "Radius must be a number in [0.1, 10000], got 0", 63),
    ],
)
def test_waypoint_refusals(
    pairs: tuple[tuple[str, str], ...], expected: str, line: int, waypoint: Waypoint
) -> None:
    with pytest.raises(MissionError) as err:
        waypoint(*pairs)
    assert expected in str(err.value)
    assert str(err.value).startswith(f"t.moos:{line}:")


def test_waypoint_steers_toward_the_goal_clockwise_positive(
    waypoint: Waypoint, nav_at: NavAt
) -> None:
    t = waypoint(("Location", "100,0"), ("Thrust", "60"))
    votes = t.step(nav_at(1.0, x=0.0, y=0.0, heading=0.0), 1.0)
    assert votes is not None
    assert votes["RUDDER"] > 0, "goal due east of a north-pointing boat: turn to starboard"
    assert votes["THRUST"] == 60.0
    t2 = waypoint(("Location", "-100,0"))
    votes2 = t2.step(nav_at(1.0, x=0.0, y=0.0, heading=0.0), 1.0)
    assert votes2 is not None and votes2["RUDDER"] < 0
    assert "THRUST" not in votes2, "no Thrust given: leave thrust to other tasks"


def test_waypoint_bearing_across_north(waypoint: Waypoint, nav_at: NavAt) -> None:
    t = waypoint(("Location", "-1,100"))
    votes = t.step(nav_at(1.0, x=0.0, y=0.0, heading=10.0), 1.0)
    assert votes is not None
    assert -20.0 <= votes["RUDDER"] < 0, "goal at ~359°, heading 10°: small turn to port"


def test_waypoint_completes_inside_radius(waypoint: Waypoint, nav_at: NavAt) -> None:
    t = waypoint(("Location", "10,10"), ("Radius", "3"), ("FinishFlag", "Arrived"))
    assert t.step(nav_at(1.0, x=10.0, y=6.0, heading=0.0), 1.0) is not None
    assert t.active
    assert t.step(nav_at(2.0, x=10.0, y=8.0, heading=0.0), 2.0) is None
    assert t.end_cause == "complete"
    assert ("Arrived", "DONE") in t.take_notifications()


def test_constant_heading_holds_heading(tblock: TBlock, nav_at: NavAt) -> None:
    t = build_task(tblock("ConstantHeading", ("Heading", "-90"), ("InitialState", "ON")))
    assert isinstance(t, ConstantHeading) and t.heading == 270.0
    t.start(0.0)
    votes = t.step(nav_at(1.0, heading=0.0), 1.0)
    assert votes is not None and votes["RUDDER"] < 0
    votes = t.step(nav_at(2.0, heading=270.0), 2.0)
    assert votes is not None and votes["RUDDER"] > 0, "derivative of the swing pushes back"
    assert t.active, "ConstantHeading only ends by time-out"


def test_constant_heading_logpid_posts_controller_state(tblock: TBlock, nav_at: NavAt) -> None:
    t = build_task(
        tblock(
            "ConstantHeading",
            ("Heading", "10"),
            ("InitialState", "ON"),
            ("Name", "H"),
            ("LOGPID", "TRUE"),
        )
    )
    t.start(0.0)
    t.take_notifications()
    t.step(nav_at(1.0, heading=0.0), 1.0)
    out = dict(t.take_notifications())
    assert out["H_YAW_PID"].startswith("e=10.000,")


def test_timer_ends_by_its_timeout_without_votes(tblock: TBlock) -> None:
    for kind in ("Timer", "TimeOut"):
        t = build_task(tblock(kind, ("TimeOut", "5"), ("FinishFlag", "Go")))
        assert isinstance(t, Timer) and t.initial_on
        t.start(0.0)
        assert t.needs() == set()
        assert t.step(NavState(), 5.0) is None and t.active
        t.step(NavState(), 5.1)
        assert t.end_cause == "timeout"
        out = dict(t.take_notifications())
        assert "timed out after 5 s" in str(out["Go"])


def test_timer_refuses_never(tblock: TBlock) -> None:
    with pytest.raises(MissionError, match="never finish"):
        build_task(tblock("Timer", ("InitialState", "ON"), ("TimeOut", "NEVER")))


def test_overall_timeout_is_on_and_never_starves(tblock: TBlock) -> None:
    t = build_task(tblock("OverallTimeOut", ("TimeOut", "60"), ("FinishFlag", "EndMission")))
    assert isinstance(t, OverallTimeOut) and t.initial_on
    t.start(0.0)
    assert t.step(NavState(), 59.0) is None and t.active
    t.step(NavState(), 61.0)
    assert t.end_cause == "timeout"


@pytest.mark.parametrize(
    ("pairs", "expected"),
    [
        ((("FinishFlag", "EndMission"),), "needs TimeOut"),
        ((("TimeOut", "60"),), "needs a FinishFlag"),
        ((("TimeOut", "NEVER"), ("FinishFlag", "E")), "NEVER would never end"),
    ],
)
def test_overall_timeout_refusals(
    pairs: tuple[tuple[str, str], ...], expected: str, tblock: TBlock
) -> None:
    with pytest.raises(MissionError, match=expected):
        build_task(tblock("OverallTimeOut", *pairs))


def test_end_mission_votes_everything_at_priority_zero_forever(tblock: TBlock) -> None:
    t = build_task(
        tblock("EndMission", ("StartFlag", "EndMission"), ("EndThrust", "-10"), ("EndRudder", "5"))
    )
    assert isinstance(t, EndMission)
    assert (t.priority, t.timeout, t.needs()) == (0, None, set())
    t.start(0.0)
    votes = t.step(NavState(), 1e6)
    assert votes == {"RUDDER": 5.0, "THRUST": -10.0, "ELEVATOR": 0.0}
    assert t.active


@pytest.mark.parametrize(
    ("pairs", "expected"),
    [
        ((("Priority", "2"),), "always has priority 0"),
        ((("TimeOut", "30"),), "never times out"),
        ((("EndThrust", "stop"),), "expects a number"),
    ],
)
def test_end_mission_refusals(
    pairs: tuple[tuple[str, str], ...], expected: str, tblock: TBlock
) -> None:
    with pytest.raises(MissionError, match=expected):
        build_task(tblock("EndMission", ("StartFlag", "E"), *pairs))
