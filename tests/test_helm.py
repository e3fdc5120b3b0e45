"""The Helm app on a bus with a simulated clock: online/offline, arbitration, flags, lockout."""

from __future__ import annotations

import math

import pytest

from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock
from mavhelm.core.mission import Block, Mission, MissionError
from mavhelm.tasks.base import NavState, Task, Votes
from mavhelm.tasks.helm import Helm
from mavhelm.tasks.registry import TASK_TYPES
from tests.support.helm_rig import FILE, Rig, Spec, one, safety, values


def south_north() -> tuple[Spec, list[Block]]:
    spec = Spec()
    tasks = [
        spec.task(
            "ConstantHeading",
            ("Priority", "3"),
            ("Name", "South"),
            ("Heading", "180"),
            ("TimeOut", "300"),
            ("InitialState", "OFF"),
            ("StartFlag", "MissionStart"),
            ("FinishFlag", "GoNorth"),
            ("LOGPID", "true"),
            ("Thrust", "50"),
        ),
        spec.task(
            "ConstantHeading",
            ("Priority", "3"),
            ("Name", "North"),
            ("Heading", "0"),
            ("TimeOut", "120"),
            ("InitialState", "OFF"),
            ("StartFlag", "GoNorth"),
            ("FinishFlag", "EndMission"),
            ("LOGPID", "true"),
            ("Thrust", "50"),
        ),
        *safety(spec),
    ]
    return spec, tasks


def test_offline_helm_posts_state_but_no_desired() -> None:
    spec, tasks = south_north()
    rig = Rig(tasks, spec)
    out = rig.tick(NAV_HEADING=90.0)
    assert one(out, "HELM_STATE") == "OFFLINE"
    assert not [m for m in out if m.name.startswith("DESIRED_")]
    assert not rig.helm.task("Overall").active, "the mission starts when the helm first goes online"


def test_south_north_flag_chaining() -> None:
    spec, tasks = south_north()
    rig = Rig(tasks, spec)
    out = rig.tick(HELM_ONLINE=1.0, NAV_HEADING=90.0)
    assert one(out, "HELM_STATE") == "ONLINE"
    assert one(out, "TASK_STARTED") == "Overall"
    assert one(out, "DESIRED_RUDDER") == 0.0 and one(out, "DESIRED_THRUST") == 0.0
    out = rig.tick(MissionStart=1.0, NAV_HEADING=90.0)
    assert one(out, "TASK_STARTED") == "South"
    assert one(out, "DESIRED_RUDDER") == 20.0, "heading 90 → 180: full starboard, clamped"
    assert one(out, "DESIRED_THRUST") == 50.0
    assert one(out, "HELM_RUDDER_OWNER") == "South"
    assert values(out, "South_YAW_PID")
    log = []
    for _ in range(302):
        log += rig.tick(NAV_HEADING=90.0)
    assert one(log, "TASK_ENDED") == "South:timeout"
    assert "timed out" in str(one(log, "GoNorth"))
    assert one(log, "TASK_STARTED") == "North"
    ended = [m for m in log if m.name == "TASK_ENDED"][0]
    started = [m for m in log if m.name == "TASK_STARTED"][0]
    assert ended.time == 1002.0 + 301.0, "South started at 1002 and ran its 300 s"
    assert started.time == ended.time, "North takes over in the tick South ends"
    handover = [m for m in log if m.time == ended.time]
    assert one(handover, "DESIRED_RUDDER") == -20.0 and one(handover, "DESIRED_THRUST") == 50.0
    assert one(handover, "HELM_RUDDER_OWNER") == "North", "no tick with nobody at the helm"
    out = rig.tick(NAV_HEADING=90.0)
    assert one(out, "DESIRED_RUDDER") == -20.0
    assert one(rig.tick(NAV_HEADING=90.0), "DESIRED_RUDDER") < 0
    log = []
    for _ in range(125):
        log += rig.tick(NAV_HEADING=90.0)
    assert values(log, "TASK_ENDED") == ["North:timeout"]
    assert one(log, "TASK_STARTED") == "Stop"
    assert one(log, "MISSION_ENDED") == "Stop"
    assert values(log, "HELM_RUDDER_OWNER")[-1] == "Stop"
    out = rig.tick(NAV_HEADING=90.0)
    assert one(out, "DESIRED_THRUST") == 0.0 and one(out, "DESIRED_RUDDER") == 0.0


def arbitration_rig(p_a: str, p_b: str) -> Rig:
    spec = Spec()
    tasks = [
        spec.task(
            "ConstantHeading",
            ("Name", "A"),
            ("Heading", "100"),
            ("Priority", p_a),
            ("InitialState", "ON"),
            ("Thrust", "30"),
        ),
        spec.task(
            "ConstantHeading",
            ("Name", "B"),
            ("Heading", "80"),
            ("Priority", p_b),
            ("InitialState", "ON"),
            ("Thrust", "70"),
            ("TimeOut", "NEVER"),
        ),
        *safety(spec),
    ]
    return Rig(tasks, spec)


def test_lower_priority_number_wins() -> None:
    rig = arbitration_rig("3", "2")
    out = rig.tick(HELM_ONLINE=1.0, NAV_HEADING=90.0)
    assert one(out, "HELM_RUDDER_OWNER") == "B"
    assert one(out, "DESIRED_RUDDER") < 0 and one(out, "DESIRED_THRUST") == 70.0


def test_tie_goes_to_first_task_in_mission_order() -> None:
    rig = arbitration_rig("2", "2")
    out = rig.tick(HELM_ONLINE=1.0, NAV_HEADING=90.0)
    assert one(out, "HELM_RUDDER_OWNER") == "A"
    assert one(out, "DESIRED_RUDDER") > 0 and one(out, "DESIRED_THRUST") == 30.0


def test_outranked_task_resumes_when_the_winner_ends() -> None:
    rig = arbitration_rig("3", "2")
    rig.tick(HELM_ONLINE=1.0, NAV_HEADING=90.0)
    for _ in range(100):
        rig.tick(NAV_HEADING=90.0)
    out = rig.tick(NAV_HEADING=90.0)
    assert one(out, "TASK_ENDED") == "A:timeout"
    rig.helm.task("B").end("complete", "DONE")
    out = rig.tick(NAV_HEADING=90.0)
    assert one(out, "DESIRED_RUDDER") == 0.0 and one(out, "HELM_RUDDER_OWNER") == "none"


def test_owner_posted_only_on_change() -> None:
    rig = arbitration_rig("3", "2")
    rig.tick(HELM_ONLINE=1.0, NAV_HEADING=90.0)
    out = rig.tick(NAV_HEADING=90.0)
    assert values(out, "HELM_RUDDER_OWNER") == []
    assert values(out, "HELM_STATE") == []


def test_going_offline_stops_desired_in_the_same_tick() -> None:
    rig = arbitration_rig("3", "2")
    assert values(rig.tick(HELM_ONLINE=1.0, NAV_HEADING=90.0), "DESIRED_RUDDER")
    out = rig.tick(HELM_ONLINE=0.0, NAV_HEADING=90.0)
    assert not [m for m in out if m.name.startswith("DESIRED_")]
    assert one(out, "HELM_STATE") == "OFFLINE"
    assert one(out, "HELM_RUDDER_OWNER") == "none"
    out = rig.tick(HELM_ONLINE=1.0, NAV_HEADING=90.0)
    assert one(out, "HELM_STATE") == "ONLINE" and one(out, "HELM_RUDDER_OWNER") == "B"
    assert values(out, "TASK_STARTED") == [], "coming back online does not restart the mission"


def test_tasks_do_not_time_out_or_starve_while_offline_but_start_flags_are_heard() -> None:
    spec, tasks = south_north()
    rig = Rig(tasks, spec)
    rig.tick(HELM_ONLINE=1.0, NAV_HEADING=90.0)
    rig.tick(HELM_ONLINE=0.0)
    out = rig.tick(MissionStart="go")
    assert one(out, "TASK_STARTED") == "South", "a start flag is heard offline"
    log = []
    for _ in range(30):
        log += rig.tick()
    assert values(log, "TASK_ENDED") == [], "no starvation checks while offline"
    out = rig.tick(HELM_ONLINE=1.0)
    assert values(out, "TASK_ENDED") == ["South:starved", "North:starved"], (
        "North, woken by South's FinishFlag, finds the heading already stale"
    )
    assert "NAV_HEADING" in str(one(out, "South_ERROR"))
    assert one(out, "GoNorth") == one(out, "South_ERROR")
    assert one(out, "MISSION_ENDED") == "Stop"


def test_starvation_while_online() -> None:
    spec = Spec()
    tasks = [
        spec.task(
            "GoToWayPoint",
            ("Name", "WP"),
            ("Location", "0,500"),
            ("InitialState", "ON"),
            ("FinishFlag", "Home"),
            ("Thrust", "80"),
        ),
        *safety(spec),
    ]
    rig = Rig(tasks, spec)
    out = rig.tick(HELM_ONLINE=1.0, NAV_X=0.0, NAV_Y=0.0, NAV_YAW=0.0)
    assert one(out, "DESIRED_THRUST") == 80.0
    log = []
    for _ in range(10):
        log += rig.tick(NAV_YAW=0.0, NAV_Y=0.0)
    assert values(log, "TASK_ENDED") == []
    out = rig.tick(NAV_YAW=0.0, NAV_Y=0.0)
    assert one(out, "TASK_ENDED") == "WP:starved"
    assert "NAV_X" in str(one(out, "WP_ERROR"))
    assert one(out, "Home") == one(out, "WP_ERROR")
    assert one(out, "DESIRED_THRUST") == 0.0, "a starved task's vote is gone the same tick"


def test_waypoint_completion_posts_finish_flag_and_chains() -> None:
    spec = Spec()
    tasks = [
        spec.task(
            "GoToWayPoint",
            ("Name", "WP"),
            ("Location", "0,10"),
            ("InitialState", "ON"),
            ("FinishFlag", "Arrived"),
            ("Thrust", "80"),
        ),
        spec.task(
            "Timer",
            ("Name", "Wait"),
            ("StartFlag", "Arrived"),
            ("TimeOut", "3"),
            ("FinishFlag", "EndMission"),
        ),
        *safety(spec),
    ]
    rig = Rig(tasks, spec)
    rig.tick(HELM_ONLINE=1.0, NAV_X=0.0, NAV_Y=0.0, NAV_HEADING=0.0)
    out = rig.tick(NAV_X=0.0, NAV_Y=6.0, NAV_HEADING=0.0)
    assert one(out, "TASK_ENDED") == "WP:complete" and one(out, "Arrived") == "DONE"
    assert one(out, "TASK_STARTED") == "Wait"
    log = []
    for _ in range(4):
        log += rig.tick()
    assert values(log, "TASK_ENDED") == ["Wait:timeout"]
    assert values(log, "MISSION_ENDED") == ["Stop"]
    assert [m.time for m in log if m.name == "TASK_ENDED"] == [1006.0], "Wait ran over its 3 s"


def test_end_mission_locks_out_everyone() -> None:
    rig = arbitration_rig("1", "2")
    rig.tick(HELM_ONLINE=1.0, NAV_HEADING=90.0)
    out = rig.tick(EndMission="now", NAV_HEADING=90.0)
    assert one(out, "MISSION_ENDED") == "Stop"
    assert one(out, "HELM_RUDDER_OWNER") == "Stop"
    assert one(out, "DESIRED_RUDDER") == 0.0 and one(out, "DESIRED_THRUST") == 0.0
    log = []
    for _ in range(200):
        log += rig.tick(NAV_HEADING=90.0)
    assert values(log, "TASK_ENDED") == [], "locked-out tasks are not even run"
    assert set(values(log, "DESIRED_THRUST")) == {0.0}
    assert values(log, "MISSION_ENDED") == []


def test_overall_timeout_ends_the_mission() -> None:
    spec = Spec()
    tasks = [
        spec.task(
            "ConstantHeading",
            ("Name", "H"),
            ("Heading", "0"),
            ("InitialState", "ON"),
            ("TimeOut", "NEVER"),
            ("Thrust", "40"),
        ),
        *safety(spec, timeout="20"),
    ]
    rig = Rig(tasks, spec)
    rig.tick(HELM_ONLINE=1.0, NAV_HEADING=0.0)
    log = []
    for _ in range(22):
        log += rig.tick(NAV_HEADING=0.0)
    assert values(log, "TASK_ENDED") == ["Overall:timeout"]
    assert values(log, "MISSION_ENDED") == ["Stop"]
    assert values(log, "DESIRED_THRUST")[-1] == 0.0
    assert 40.0 in values(log, "DESIRED_THRUST")


def test_desired_values_are_clamped_to_helm_limits() -> None:
    spec = Spec()
    tasks = [
        spec.task(
            "ConstantHeading",
            ("Name", "H"),
            ("Heading", "180"),
            ("InitialState", "ON"),
            ("Thrust", "90"),
        ),
        *safety(spec),
    ]
    rig = Rig(tasks, spec, ("MAXRUDDER", "15"), ("MAXTHRUST", "60"))
    out = rig.tick(HELM_ONLINE=1.0, NAV_HEADING=0.0)
    assert one(out, "DESIRED_RUDDER") == 15.0 and one(out, "DESIRED_THRUST") == 60.0


def test_subscriptions_cover_online_flags_and_needs() -> None:
    spec, tasks = south_north()
    rig = Rig(tasks, spec)
    subs = rig.helm.subscriptions()
    assert {
        "HELM_ONLINE",
        "MissionStart",
        "GoNorth",
        "EndMission",
        "NAV_HEADING",
        "NAV_YAW",
    } <= subs


def test_online_requires_exactly_one() -> None:
    rig = arbitration_rig("3", "2")
    out = rig.tick(HELM_ONLINE="1", NAV_HEADING=90.0)
    assert one(out, "HELM_STATE") == "OFFLINE"
    assert not values(out, "DESIRED_RUDDER")


# ---- refusals -------------------------------------------------------------------------------


def _refuse(tasks: list[Block], spec: Spec) -> MissionError:
    with pytest.raises(MissionError) as err:
        Helm(Bus(SimClock()), spec.block("ProcessConfig", "pHelm"), tasks)
    return err.value


def test_mission_without_end_mission_is_refused_at_the_helm_block() -> None:
    spec = Spec()
    tasks = safety(spec)[:1]
    err = _refuse(tasks, spec)
    assert "EndMission" in str(err) and str(err).startswith(f"{FILE}:{spec.line - 3}:")


def test_mission_without_overall_timeout_is_refused() -> None:
    spec = Spec()
    err = _refuse(safety(spec)[1:], spec)
    assert "OverallTimeOut" in str(err) and str(err).startswith(f"{FILE}:")


def test_unknown_task_type_is_refused_at_its_block() -> None:
    spec = Spec()
    bad = spec.task("Orbitt", ("Name", "O"))
    err = _refuse([bad, *safety(spec)], spec)
    assert str(err).startswith(f"{FILE}:{bad.line}:") and "ConstantHeading" in str(err)


def test_duplicate_task_names_are_refused() -> None:
    spec = Spec()
    a = spec.task("Timer", ("Name", "T"), ("InitialState", "ON"))
    b = spec.task("Timer", ("Name", "T"), ("InitialState", "ON"))
    err = _refuse([a, b, *safety(spec)], spec)
    assert str(err).startswith(f"{FILE}:{b.line}:") and f"{FILE}:{a.line}" in str(err)


def test_bad_task_parameter_propagates_located_error() -> None:
    spec = Spec()
    bad = spec.task("ConstantHeading", ("Name", "H"), ("Heading", "north"), ("InitialState", "ON"))
    err = _refuse([bad, *safety(spec)], spec)
    assert str(err).startswith(f"{FILE}:{bad.line + 2}:") and "Heading expects a number" in str(err)


def test_from_mission() -> None:
    spec = Spec()
    helm_block = spec.block("ProcessConfig", "pHelm", ("YAW_PID_KP", "1.0"))
    tasks = safety(spec)
    mission = Mission(FILE, Block("Globals", "", FILE, 1), {"pHelm": helm_block}, tasks)
    helm = Helm.from_mission(Bus(SimClock()), mission)
    assert [t.name for t in helm.tasks] == ["Overall", "Stop"]
    assert helm.gains.yaw_kp == 1.0
    # YAW_PID set and no LINE_PID: the one heading loop of the original pHelm, lines included
    assert (helm.gains.line_kp, helm.gains.line_kd) == (1.0, 0.2)
    with pytest.raises(MissionError, match="no ProcessConfig = pHelm"):
        Helm.from_mission(Bus(SimClock()), Mission(FILE, Block("Globals", "", FILE, 1), {}, tasks))


def test_controller_history_is_dropped_after_an_offline_gap() -> None:
    spec = Spec()
    tasks = [
        spec.task(
            "ConstantHeading",
            ("Name", "H"),
            ("Heading", "10"),
            ("InitialState", "ON"),
            ("TimeOut", "NEVER"),
        ),
        *safety(spec),
    ]
    rig = Rig(tasks, spec, ("YAW_PID_KI", "0.1"), ("YAW_PID_INTEGRAL_LIMIT", "5"))
    rig.tick(HELM_ONLINE=1.0, NAV_HEADING=0.0)
    rig.tick(NAV_HEADING=0.0)
    assert rig.helm.task("H").yaw_pid.i > 0
    rig.tick(HELM_ONLINE=0.0, NAV_HEADING=0.0)
    rig.tick(60.0, NAV_HEADING=0.0)
    out = rig.tick(HELM_ONLINE=1.0, NAV_HEADING=0.0)
    assert rig.helm.task("H").yaw_pid.i == 0.0, "no 60 s of integral from the offline gap"
    assert one(out, "DESIRED_RUDDER") == pytest.approx(7.5)  # YAW_PID_KP 0.75 × 10°


def test_end_mission_started_mid_tick_overrides_votes_already_cast() -> None:
    spec = Spec()
    tasks = [
        spec.task(
            "ConstantHeading",
            ("Name", "H"),
            ("Heading", "90"),
            ("Priority", "1"),
            ("Thrust", "70"),
            ("TimeOut", "NEVER"),
        ),
        spec.task("Timer", ("Name", "T"), ("TimeOut", "2"), ("FinishFlag", "EndMission")),
        *safety(spec),
    ]
    rig = Rig(tasks, spec)
    assert one(rig.tick(HELM_ONLINE=1.0, NAV_HEADING=90.0), "DESIRED_THRUST") == 70.0
    rig.tick(NAV_HEADING=90.0)
    assert one(rig.tick(NAV_HEADING=90.0), "DESIRED_THRUST") == 70.0
    out = rig.tick(NAV_HEADING=90.0)
    assert one(out, "TASK_ENDED") == "T:timeout" and one(out, "MISSION_ENDED") == "Stop"
    assert one(out, "DESIRED_THRUST") == 0.0, "H voted before EndMission woke: its vote is void"
    assert one(out, "HELM_RUDDER_OWNER") == "Stop"


class _Pump(Task):
    """An auxiliary-actuator task, registered only for these tests."""

    keyword = "Pump"

    def update(self, nav: NavState, now: float) -> Votes | None:
        return {"PUMP": 250.0}


def test_auxiliary_actuator_is_posted_and_zeroed_by_end_mission(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setitem(TASK_TYPES, "pump", _Pump)
    spec = Spec()
    tasks = [
        spec.task("Pump", ("Name", "P"), ("TimeOut", "NEVER")),
        spec.task("Timer", ("Name", "T"), ("TimeOut", "1"), ("FinishFlag", "EndMission")),
        *safety(spec),
    ]
    rig = Rig(tasks, spec)
    out = rig.tick(HELM_ONLINE=1.0)
    assert one(out, "DESIRED_PUMP") == 250.0, "auxiliary actuators are not clamped"
    rig.tick()
    out = rig.tick()
    assert one(out, "MISSION_ENDED") == "Stop"
    assert one(out, "DESIRED_PUMP") == 0.0, "EndMission locks the pump out in the same tick"
    assert one(rig.tick(), "DESIRED_PUMP") == 0.0


def test_declared_navigation_loss_stops_actuation_in_the_same_tick_then_starves():
    """pNav's NAV_X_SOURCE = NONE: the waypoint task holds at once; 10 s of silence starve it."""
    spec = Spec()
    tasks = [spec.task("GoToWayPoint", ("Name", "Leg"), ("Location", "0,500"), ("Thrust", "50"),
                       ("TimeOut", "NEVER"), ("FinishFlag", "EndMission")), *safety(spec)]
    rig = Rig(tasks, spec)
    rig.tick(HELM_ONLINE=1.0)
    out = rig.tick(NAV_X=0.0, NAV_Y=0.0, NAV_HEADING=0.0, NAV_X_SOURCE="GPS")
    assert one(out, "DESIRED_THRUST") == 50.0
    out = rig.tick(NAV_HEADING=0.0, NAV_X_SOURCE="NONE")
    assert one(out, "DESIRED_THRUST") == 0.0, "holding must take effect in the declaring tick"
    assert one(out, "DESIRED_RUDDER") == 0.0
    assert "NAV_X" in str(one(out, "Leg_WARNING"))
    assert one(rig.tick(NAV_HEADING=0.0), "DESIRED_THRUST") == 0.0
    # the source returns before starvation: the task drives again
    out = rig.tick(NAV_X=0.0, NAV_Y=1.0, NAV_HEADING=0.0, NAV_X_SOURCE="AP")
    assert one(out, "DESIRED_THRUST") == 50.0
    # lost for good: it starves 10 s after the last NAV_X
    rig.tick(NAV_HEADING=0.0, NAV_X_SOURCE="NONE")
    ended = []
    for _ in range(12):
        ended += values(rig.tick(NAV_HEADING=0.0), "TASK_ENDED")
    assert ended == ["Leg:starved"]


def test_yaw_source_loss_also_means_heading_loss():
    nav = NavState()
    nav.update(Message("NAV_YAW", 0.5, 1.0, "pNav"))
    nav.update(Message("NAV_YAW_SOURCE", "NONE", 2.0, "pNav"))
    assert nav.lost("NAV_HEADING") and nav.lost("NAV_YAW")
    nav.update(Message("NAV_YAW_SOURCE", "INS", 3.0, "pNav"))
    assert not nav.lost("NAV_HEADING")


class _Broken(Task):
    """A task whose arithmetic went wrong: it votes NaN thrust and infinite rudder."""

    keyword = "Broken"

    def update(self, nav: NavState, now: float) -> Votes | None:
        return {"THRUST": math.nan, "RUDDER": math.inf}


def test_a_non_finite_vote_becomes_zero_with_a_warning(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(TASK_TYPES, "broken", _Broken)
    spec = Spec()
    rig = Rig([spec.task("Broken", ("Name", "B"), ("TimeOut", "NEVER")), *safety(spec)], spec)
    out = rig.tick(HELM_ONLINE=1.0)
    assert one(out, "DESIRED_THRUST") == 0.0 and one(out, "DESIRED_RUDDER") == 0.0
    warnings = values(out, "HELM_WARNING")
    assert len(warnings) == 2 and all("task B voted" in str(w) for w in warnings)


def _leg_and_clock(clock_setting: str | None) -> tuple[Spec, list[Block]]:
    spec = Spec()
    pairs = [("Name", "Leg"), ("Heading", "90"), ("Thrust", "50"), ("TimeOut", "60")]
    if clock_setting is not None:
        pairs.append(("TimeOutClock", clock_setting))
    tasks = [spec.task("ConstantHeading", *pairs),
             spec.task("OverallTimeOut", ("Name", "Clock"), ("TimeOut", "150"),
                       ("FinishFlag", "EndMission")),
             spec.task("EndMission", ("Name", "Stop"), ("StartFlag", "EndMission"))]
    return spec, tasks


def _ended_at(clock_setting: str | None) -> dict[str, float]:
    """Drive 40 s online, 50 s in MANUAL (offline), then online until 200 s: when each task
    ended (the run measured on real ArduPilot that motivated TimeOutClock)."""
    spec, tasks = _leg_and_clock(clock_setting)
    rig = Rig(tasks, spec)
    ended: dict[str, float] = {}
    for tenth in range(2000):
        now = tenth / 10
        online = 1.0 if not 40.0 <= now < 90.0 else 0.0
        out = rig.tick(dt=0.1, HELM_ONLINE=online, NAV_HEADING=90.0)
        for m in out:
            if m.name == "TASK_ENDED":
                ended.setdefault(str(m.value).split(":")[0], now)
    return ended


def test_a_task_timeout_counts_only_online_time_and_the_mission_clock_counts_all():
    ended = _ended_at(None)  # the default: ONLINE for tasks, ALWAYS for OverallTimeOut
    assert 110.0 < ended["Leg"] < 110.5, "60 s of driving: 40 before MANUAL, 20 after"
    assert 150.0 < ended["Clock"] < 150.5, "the mission's limit counted the 50 s in MANUAL"


def test_timeout_clock_always_counts_the_time_in_manual():
    ended = _ended_at("ALWAYS")
    assert 90.0 <= ended["Leg"] < 90.5, "timed out in MANUAL: ended at the first online tick"
