"""The vertical tasks (ConstantDepth, GoToDepth, ZPattern, LimitDepth, DiveTask) and the
depth-by-pitch controller of spec 1.4.2, on hand-made NavState sequences (no bus, no helm)."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest

from mavhelm.core.mission import Block, MissionError
from mavhelm.tasks.base import NavState, Task
from mavhelm.tasks.pid import HelmGains
from mavhelm.tasks.registry import build_task

TBlock = Callable[..., Block]


def started(tblock: TBlock, kind: str, *pairs: tuple[str, str],
            gains: HelmGains | None = None) -> Task:
    task = build_task(tblock(kind, ("InitialState", "ON"), *pairs), gains)
    task.start(0.0)
    task.take_notifications()
    return task


def nav(t: float, depth: float, pitch_deg: float = 0.0) -> NavState:
    from mavhelm.core.bus import Message
    n = NavState()
    n.update(Message("NAV_DEPTH", depth, t, "test"))
    n.update(Message("NAV_PITCH", math.radians(pitch_deg), t, "test"))
    return n


def test_depth_by_pitch_signs_and_limits() -> None:
    pid = HelmGains(z_to_pitch_kp=1.0, pitch_kp=2.0, max_pitch=10.0, max_elevator=30.0
                    ).depth_pid()
    # too shallow by 3 m, level: nose down 3 deg wanted, positive elevator dives
    assert pid.run(3.0, 0.0, 0.0, 0.0) == pytest.approx(6.0)
    assert pid.desired_pitch == pytest.approx(-3.0)
    # far too shallow: pitch limited to MAXPITCH, elevator to MAXELEVATOR
    assert pid.run(100.0, 1.0, 0.0, 1.0) == pytest.approx(20.0)
    assert pid.run(100.0, 2.0, 20.0, 2.0) == pytest.approx(30.0)
    # too deep: rise (negative elevator)
    assert pid.run(-2.0, 3.0, 0.0, 3.0) < 0
    # astern, nose up dives: the same elevator asks for the opposite pitch
    reverse = HelmGains(z_to_pitch_kp=1.0, pitch_kp=2.0).depth_pid(reversing=True)
    assert reverse.run(3.0, 0.0, 0.0, 0.0) == pytest.approx(6.0)
    assert reverse.desired_pitch == pytest.approx(3.0)


def test_constant_depth_votes_elevator_only_and_needs_depth_and_pitch(tblock: TBlock) -> None:
    t = started(tblock, "ConstantDepth", ("Depth", "50"))
    assert t.needs() == {"NAV_DEPTH", "NAV_PITCH"}
    votes = t.step(nav(1.0, 10.0), 1.0)
    assert votes is not None and set(votes) == {"ELEVATOR"} and votes["ELEVATOR"] > 0
    votes = t.step(nav(2.0, 60.0), 2.0)
    assert votes is not None and votes["ELEVATOR"] < 0
    assert t.active, "ConstantDepth ends only on its TimeOut"
    assert build_task(tblock("ConstantDepth", ("InitialState", "ON"))).depth == 0.2


def test_constant_depth_starves_without_depth(tblock: TBlock) -> None:
    t = started(tblock, "ConstantDepth", ("Depth", "5"))
    t.step(nav(1.0, 1.0), 1.0)
    t.step(nav(1.0, 1.0), 12.0)
    assert t.end_cause == "starved"


def test_goto_depth_spirals_down_and_completes_within_tolerance(tblock: TBlock) -> None:
    t = started(tblock, "GoToDepth", ("Depth", "20"), ("Tolerance", "1"), ("Rudder", "10"),
                ("Thrust", "40"))
    votes = t.step(nav(1.0, 5.0), 1.0)
    assert votes is not None and votes["RUDDER"] == 10 and votes["THRUST"] == 40
    assert votes["ELEVATOR"] > 0
    assert t.step(nav(2.0, 19.5), 2.0) is None
    assert t.end_cause == "complete"
    assert build_task(tblock("GoToDepth", ("InitialState", "ON"))).tolerance == 3.14


def test_zpattern_yoyo_and_square(tblock: TBlock) -> None:
    yoyo = started(tblock, "ZPattern", ("Pattern", "YOYO"), ("MinDepth", "5"),
                   ("MaxDepth", "15"))
    yoyo.step(nav(1.0, 0.0), 1.0)
    assert yoyo.goal == 5  # type: ignore[attr-defined]
    yoyo.step(nav(2.0, 5.1), 2.0)
    assert yoyo.goal == 15  # type: ignore[attr-defined]
    yoyo.step(nav(3.0, 14.9), 3.0)
    assert yoyo.goal == 5  # type: ignore[attr-defined]
    square = started(tblock, "ZPattern", ("Pattern", "SQUARE"), ("MinDepth", "5"),
                     ("MaxDepth", "15"), ("LevelTime", "10"), ("TimeOut", "NEVER"))
    square.step(nav(1.0, 5.0), 1.0)
    square.step(nav(5.0, 5.0), 5.0)
    assert square.goal == 5  # type: ignore[attr-defined]
    square.step(nav(11.0, 5.0), 11.0)
    assert square.goal == 15  # type: ignore[attr-defined]


def test_zpattern_refusals(tblock: TBlock) -> None:
    with pytest.raises(MissionError, match="t.moos:62: MaxDepth = 2 is shallower"):
        build_task(tblock("ZPattern", ("Pattern", "YOYO"), ("MaxDepth", "2"),
                          ("MinDepth", "4")))
    with pytest.raises(MissionError, match="Pattern"):
        build_task(tblock("ZPattern", ("MinDepth", "4")))


def test_limit_depth_rises_and_fires_when_too_deep(tblock: TBlock) -> None:
    t = started(tblock, "LimitDepth", ("MaximumDepth", "100"), ("EventFlag", "TooDeep"),
                gains=HelmGains(max_elevator=25.0))
    assert (t.priority, t.timeout) == (1, None)
    assert t.step(nav(1.0, 99.0), 1.0) is None
    votes = t.step(nav(2.0, 101.0), 2.0)
    assert votes == {"ELEVATOR": -25.0}
    posted = dict(t.take_notifications())
    assert "101.0 m is 1.0 m beyond MaximumDepth 100" in str(posted["TooDeep"])
    assert t.active, "a depth limit keeps running when it fires"
    assert t.step(nav(3.0, 99.0), 3.0) is None


def test_dive_task_modes(tblock: TBlock) -> None:
    normal = started(tblock, "DiveTask", ("Depth", "10"), ("Thrust", "30"))
    votes = normal.step(nav(1.0, 2.0), 1.0)
    assert votes is not None and votes["THRUST"] == 30 and votes["ELEVATOR"] > 0
    normal.step(nav(2.0, 10.5), 2.0)
    assert normal.end_cause == "complete"
    reverse = started(tblock, "DiveTask", ("Mode", "REVERSE"), ("Depth", "10"))
    votes = reverse.step(nav(1.0, 2.0), 1.0)
    assert votes is not None and votes["THRUST"] == -20
    assert reverse.depth_pid.desired_pitch > 0  # type: ignore[attr-defined]
    chuck = started(tblock, "DiveTask", ("Mode", "CHUCK"), ("Depth", "2"), ("Elevator", "5"))
    assert chuck.timeout == 60
    assert chuck.step(nav(1.0, 1.0, 5.0), 1.0)["ELEVATOR"] == 5  # type: ignore[index]
    assert chuck.step(nav(2.0, 2.5, 5.0), 2.0)["ELEVATOR"] == -5  # type: ignore[index]
    chuck.step(nav(3.0, 2.5, -1.0), 3.0)
    assert chuck.end_cause == "complete"


def test_the_helm_posts_the_depth_controllers_elevator_and_limit_depth_outranks_it() -> None:
    from tests.support.helm_rig import Rig, Spec, safety

    spec = Spec()
    tasks = [spec.task("ConstantDepth", ("Name", "Hold"), ("Depth", "20"), ("Priority", "3"),
                       ("TimeOut", "NEVER")),
             spec.task("LimitDepth", ("Name", "Limit"), ("MaximumDepth", "30")),
             *safety(spec)]
    rig = Rig(tasks, spec, ("PITCH_PID_KP", "2"), ("MAXELEVATOR", "25"))
    rig.tick(HELM_ONLINE=1.0)

    def elevator(depth: float) -> float:
        posts = rig.tick(NAV_DEPTH=depth, NAV_PITCH=0.0)
        return next(m.double for m in posts if m.name == "DESIRED_ELEVATOR")

    assert elevator(10.0) > 0, "too shallow: dive"
    assert elevator(25.0) < 0, "too deep for the task: rise"
    assert elevator(31.0) == -25.0, "beyond the limit: LimitDepth's full rise wins"
