"""LimitBox, LimitAltitude, HoldingPattern, SteerThenDriveXYPattern, VariableHeading: parameters
and behaviour on hand-made NavState sequences (no bus, no helm)."""

from __future__ import annotations

import math
from collections.abc import Callable

import pytest

from mavhelm.core.mission import Block
from mavhelm.tasks.base import NavState, Task
from mavhelm.tasks.holding import HoldingPattern
from mavhelm.tasks.limit_altitude import LimitAltitude
from mavhelm.tasks.limit_box import LimitBox
from mavhelm.tasks.registry import build_task
from mavhelm.tasks.steer_then_drive import SteerThenDriveXYPattern
from mavhelm.tasks.variable_heading import VariableHeading
from tests.support.task_rig import refusal

# tblock (blocks in t.moos at line 60, entries on 61, 62, ...), nav_at, msg: conftest.py
TBlock = Callable[..., Block]
NavAt = Callable[..., NavState]

BOX = (("XMin", "-50"), ("XMax", "50"), ("YMin", "-20"), ("YMax", "80"))


def started(tblock: TBlock, kind: str, *pairs: tuple[str, str], at: float = 0.0) -> Task:
    task = build_task(tblock(kind, ("InitialState", "ON"), *pairs))
    task.start(at)
    task.take_notifications()
    return task


def flags(task: Task, name: str) -> list[float | str]:
    return [v for n, v in task.take_notifications() if n == name]


def run(task: Task, nav: NavState, t: float) -> tuple[dict | None, dict[str, list]]:
    votes = task.step(nav, t)
    out: dict[str, list] = {}
    for n, v in task.take_notifications():
        out.setdefault(n, []).append(v)
    return votes, out


# ---- LimitBox --------------------------------------------------------------------------------


def test_limit_box_parameters_and_needs(tblock: TBlock) -> None:
    t = started(tblock, "LimitBox", *BOX, ("EventFlag", "OutOfBox"))
    assert isinstance(t, LimitBox)
    assert (t.x_min, t.x_max, t.y_min, t.y_max) == (-50.0, 50.0, -20.0, 80.0)
    assert (t.depth_max, t.ignore_time, t.timeout) == (None, 0.0, None), "TimeOut NEVER"
    assert t.needs() == {"NAV_X", "NAV_Y"}
    deep = started(tblock, "LimitBox", *BOX, ("EventFlag", "E"), ("DepthMax", "20"))
    assert deep.needs() == {"NAV_X", "NAV_Y", "NAV_DEPTH"}


@pytest.mark.parametrize(
    ("pairs", "expected"),
    [
        ((("XMin", "10"), ("XMax", "5"), ("YMin", "0"), ("YMax", "1"), ("EventFlag", "E")),
         "t.moos:62: XMin = 10 must be less than XMax = 5: the box would be empty"),
        ((("YMax", "3"), ("XMin", "0"), ("XMax", "1"), ("YMin", "3"), ("EventFlag", "E")),
         "t.moos:64: YMin = 3 must be less than YMax = 3: the box would be empty"),
        ((("XMin", "0"), ("XMax", "1"), ("YMin", "0"), ("EventFlag", "E")),
         "t.moos:60: LimitBox task LimitBox needs YMax"),
        ((*BOX, ("EventFlag", "E"), ("DepthMax", "-3")),
         "t.moos:66: DepthMax must be a number in (0, 11000], got -3"),
        ((*BOX, ("EventFlag", "E"), ("IgnoreTime", "nan")),
         "t.moos:66: IgnoreTime must be a finite number, got 'nan'"),
        ((*BOX, ("EventFlag", "E"), ("Thrust", "50")),
         "t.moos:66: unknown setting 'Thrust' for a LimitBox task"),
        (BOX, "t.moos:60: LimitBox task LimitBox needs an EventFlag"),
    ],
)
def test_limit_box_refusals(tblock: TBlock, pairs: tuple[tuple[str, str], ...],
                            expected: str) -> None:
    assert refusal(tblock, "LimitBox", *pairs).startswith(expected)


def test_limit_box_fires_on_leaving_repeats_every_10_s_and_never_ends(
    tblock: TBlock, nav_at: NavAt
) -> None:
    t = started(tblock, "LimitBox", *BOX, ("EventFlag", "OutOfBox, Recall"), ("Name", "Fence"))
    votes, out = run(t, nav_at(1.0, x=0.0, y=0.0), 1.0)
    assert votes is None and out == {"Fence_INSIDE": [1.0]}
    assert run(t, nav_at(2.0, x=49.0, y=79.0), 2.0) == (None, {})
    votes, out = run(t, nav_at(3.0, x=52.5, y=0.0), 3.0)
    assert votes is None
    assert out["Fence_INSIDE"] == [0.0]
    assert out["OutOfBox"] == ["X 52.5 m is 2.5 m beyond XMax 50"]
    assert out["Recall"] == out["OutOfBox"], "every EventFlag is posted"
    # still outside: quiet until 10 s after the last event, then again
    fired = []
    for k in range(1, 25):
        now = 3.0 + 0.5 * k
        _, out = run(t, nav_at(now, x=55.0, y=-25.0), now)
        if "OutOfBox" in out:
            fired.append((now, out["OutOfBox"][0]))
    assert [f[0] for f in fired] == [13.0]
    assert fired[0][1] == ("X 55.0 m is 5.0 m beyond XMax 50; "
                           "Y -25.0 m is 5.0 m beyond YMin -20")
    # back inside re-arms: the next excursion fires at once
    _, out = run(t, nav_at(16.0, x=0.0, y=0.0), 16.0)
    assert out == {"Fence_INSIDE": [1.0]}
    _, out = run(t, nav_at(17.0, x=-60.0, y=0.0), 17.0)
    assert out["OutOfBox"] == ["X -60.0 m is 10.0 m beyond XMin -50"]
    assert t.active and t.end_cause is None, "an event does not end the task"
    assert t.step(nav_at(1e5, x=-60.0, y=0.0), 1e5) is None and t.active, "TimeOut NEVER"


def test_limit_box_depth(tblock: TBlock, nav_at: NavAt) -> None:
    t = started(tblock, "LimitBox", *BOX, ("EventFlag", "E"), ("DepthMax", "20"))
    assert flags(t, "E") == []
    t.step(nav_at(1.0, x=0.0, y=0.0, depth=19.0), 1.0)
    assert flags(t, "E") == []
    t.step(nav_at(2.0, x=0.0, y=0.0, depth=23.25), 2.0)
    assert flags(t, "E") == ["depth 23.2 m is 3.2 m beyond DepthMax 20"]


def test_limit_box_ignore_time_counts_from_activation(tblock: TBlock, nav_at: NavAt) -> None:
    t = started(tblock, "LimitBox", *BOX, ("EventFlag", "E"), ("IgnoreTime", "5"), at=100.0)
    for now in (100.5, 102.0, 104.9):
        _, out = run(t, nav_at(now, x=0.0, y=100.0), now)
        assert "E" not in out, f"event at {now} inside IgnoreTime"
    _, out = run(t, nav_at(105.0, x=0.0, y=100.0), 105.0)
    assert out["E"] == ["Y 100.0 m is 20.0 m beyond YMax 80"], "outside at the end: fires"


def test_limit_box_starves_without_navigation(tblock: TBlock, nav_at: NavAt) -> None:
    t = started(tblock, "LimitBox", *BOX, ("EventFlag", "E"), ("FinishFlag", "NavDead"),
                ("Name", "Fence"))
    nav = nav_at(1.0, x=0.0, y=0.0)
    t.step(nav, 1.0)
    t.take_notifications()
    assert t.step(nav, 11.0) is None and t.active
    t.step(nav, 11.5)
    assert t.end_cause == "starved"
    out = dict(t.take_notifications())
    assert out["Fence_ERROR"] == "task Fence starved: no NAV_X, NAV_Y for 10 s"
    assert "NavDead" in out and "E" not in out


def test_limit_box_without_x_starves_from_activation(tblock: TBlock, nav_at: NavAt) -> None:
    t = started(tblock, "LimitBox", *BOX, ("EventFlag", "E"), at=0.0)
    for now in (1.0, 5.0, 10.0):
        assert t.step(nav_at(now, y=0.0), now) is None and t.active
    t.step(nav_at(10.5, y=0.0), 10.5)
    assert t.end_cause == "starved"
    assert "no NAV_X for 10 s" in str(dict(t.take_notifications())["LimitBox_ERROR"])


# ---- LimitAltitude ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("pairs", "expected"),
    [
        ((("EventFlag", "E"),), "t.moos:60: LimitAltitude task LimitAltitude needs MinAltitude"),
        ((("EventFlag", "E"), ("MinAltitude", "0")),
         "t.moos:62: MinAltitude must be a number in (0, 11000], got 0"),
        ((("EventFlag", "E"), ("MinAltitude", "two")),
         "t.moos:62: MinAltitude expects a number in (0, 11000], got 'two'"),
        ((("EventFlag", "E"), ("MinAltitudes", "2")),
         "t.moos:62: unknown setting 'MinAltitudes' for a LimitAltitude task "
         "(did you mean MinAltitude?"),
        ((("MinAltitude", "2"),), "t.moos:60: LimitAltitude task LimitAltitude needs an "
                                  "EventFlag"),
    ],
)
def test_limit_altitude_refusals(tblock: TBlock, pairs: tuple[tuple[str, str], ...],
                                 expected: str) -> None:
    assert refusal(tblock, "LimitAltitude", *pairs).startswith(expected)


def test_limit_altitude_fires_when_shallow_and_never_ends(tblock: TBlock, msg) -> None:
    t = started(tblock, "LimitAltitude", ("MinAltitude", "2"), ("EventFlag", "Shoal"),
                ("IgnoreTime", "3"))
    assert isinstance(t, LimitAltitude)
    assert t.needs() == {"NAV_ALTITUDE"} and t.timeout is None
    nav = NavState()

    def at(now: float, altitude: float) -> list:
        nav.update(msg("NAV_ALTITUDE", altitude, now))
        assert t.step(nav, now) is None, "votes nothing"
        return flags(t, "Shoal")

    assert at(1.0, 1.0) == [], "inside IgnoreTime"
    assert at(3.0, 1.5) == ["altitude 1.5 m is 0.5 m below MinAltitude 2"]
    assert at(8.0, 1.2) == []
    assert at(13.0, 1.1) == ["altitude 1.1 m is 0.9 m below MinAltitude 2"]
    assert at(14.0, 2.0) == [], "exactly MinAltitude is enough water"
    assert at(15.0, 0.4) == ["altitude 0.4 m is 1.6 m below MinAltitude 2"], "re-armed"
    assert t.active


def test_limit_altitude_starves_when_the_sounder_dies(tblock: TBlock, msg) -> None:
    t = started(tblock, "LimitAltitude", ("MinAltitude", "2"), ("EventFlag", "Shoal"),
                ("FinishFlag", "SounderDead"))
    nav = NavState()
    nav.update(msg("NAV_ALTITUDE", 8.0, 1.0))
    t.step(nav, 1.0)
    t.step(nav, 11.2)
    assert t.end_cause == "starved"
    assert "no NAV_ALTITUDE for 10 s" in str(dict(t.take_notifications())["SounderDead"])


# ---- HoldingPattern --------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("pairs", "expected"),
    [
        ((), "t.moos:60: HoldingPattern task HoldingPattern needs Location (keep station) or "
             "at least one of Rudder, Thrust, Elevator"),
        ((("Location", "0,0"),), "t.moos:60: HoldingPattern task HoldingPattern keeps station "
                                 "at Location and needs Thrust"),
        ((("Location", "0,0"), ("Thrust", "-20")),
         "t.moos:62: Thrust must be > 0 to drive back to the station, got -20"),
        ((("Location", "0,0"), ("Thrust", "30"), ("Rudder", "10")),
         "t.moos:63: Rudder is for a HoldingPattern without Location"),
        ((("Thrust", "0"), ("Radius", "3")), "t.moos:62: Radius is for keeping station: "
                                             "give Location too"),
        ((("Location", "0,0"), ("Thrust", "30"), ("Radius", "0")),
         "t.moos:63: Radius must be a number in [0.1, 10000], got 0"),
        ((("Location", "0,0"), ("Thrust", "30"), ("Hysteresis", "-1")),
         "t.moos:63: Hysteresis must be a number in [0, 1000], got -1"),
    ],
)
def test_holding_pattern_refusals(tblock: TBlock, pairs: tuple[tuple[str, str], ...],
                                  expected: str) -> None:
    assert refusal(tblock, "HoldingPattern", *pairs).startswith(expected)


def test_holding_pattern_cuts_thrust_inside_and_drives_back_beyond_hysteresis(
    tblock: TBlock, nav_at: NavAt
) -> None:
    t = started(tblock, "HoldingPattern", ("Location", "100,0"), ("Thrust", "40"),
                ("Radius", "5"), ("Hysteresis", "2"), ("Name", "Wait"))
    assert isinstance(t, HoldingPattern)
    assert t.needs() == {"NAV_X", "NAV_Y", "NAV_HEADING"} and t.timeout == 100.0
    seen = []
    for now, x in ((1.0, 0.0), (2.0, 94.0), (3.0, 96.0), (4.0, 101.0), (5.0, 106.5),
                   (6.0, 107.0), (7.0, 107.5), (8.0, 103.0), (9.0, 105.5)):
        votes, out = run(t, nav_at(now, x=x, y=0.0, heading=90.0), now)
        assert votes is not None
        seen.append((x, votes["THRUST"], out.get("Wait_ON_STATION")))
    assert seen == [
        (0.0, 40.0, [0.0]),      # far: drive in
        (94.0, 40.0, None),      # 6 m out: still driving
        (96.0, 0.0, [1.0]),      # inside Radius: cut thrust, drift
        (101.0, 0.0, None),
        (106.5, 0.0, None),      # beyond Radius but within Radius + Hysteresis: keep drifting
        (107.0, 0.0, None),      # exactly 7 m: still drifting
        (107.5, 40.0, [0.0]),    # beyond 7 m: drive back
        (103.0, 0.0, [1.0]),     # inside Radius again
        (105.5, 0.0, None),
    ]


def test_holding_pattern_steers_toward_the_station(tblock: TBlock, nav_at: NavAt) -> None:
    t = started(tblock, "HoldingPattern", ("Location", "0,-100"), ("Thrust", "40"))
    votes = t.step(nav_at(1.0, x=0.0, y=0.0, heading=90.0), 1.0)
    assert votes is not None and votes["RUDDER"] > 0, "station due south, heading east: turn CW"
    inside = t.step(nav_at(2.0, x=0.0, y=-98.0, heading=90.0), 2.0)
    assert inside == {"RUDDER": 0.0, "THRUST": 0.0}, "drifting holds both, so nothing lower drives"
    assert t.active, "never completes by itself"


def test_holding_pattern_open_loop_is_the_original_task(tblock: TBlock) -> None:
    t = started(tblock, "HoldingPattern", ("Rudder", "15"), ("Thrust", "20"), ("TimeOut", "30"))
    assert t.needs() == set(), "needs no navigation: never starves"
    assert t.step(NavState(), 29.0) == {"RUDDER": 15.0, "THRUST": 20.0}
    wait = started(tblock, "HoldingPattern", ("Thrust", "0"))
    assert wait.step(NavState(), 1.0) == {"THRUST": 0.0}
    t.step(NavState(), 30.5)
    assert t.end_cause == "timeout"


# ---- SteerThenDriveXYPattern -----------------------------------------------------------------


@pytest.mark.parametrize(
    ("pairs", "expected"),
    [
        ((("Thrust", "50"),), "t.moos:60: SteerThenDriveXYPattern task SteerThenDriveXYPattern "
                              "needs at least one Location"),
        ((("Location", "0,0"),), "t.moos:60: SteerThenDriveXYPattern task "
                                 "SteerThenDriveXYPattern needs Thrust"),
        ((("Location", "0,0"), ("Location", "5"), ("Thrust", "50")),
         "t.moos:62: Location expects x,y or x,y,z in metres, got '5'"),
        ((("Location", "0,0"), ("Thrust", "0")), "t.moos:62: Thrust must be a number in "
                                                 "(0, 100], got 0"),
        ((("Location", "0,0"), ("Location", "0,9"), ("Thrust", "50"), ("Repeat", "1.5")),
         "t.moos:64: Repeat must be a whole number in [0, 1000] or FOREVER, got 1.5"),
        ((("Location", "0,0"), ("Thrust", "50"), ("Repeat", "2")),
         "t.moos:63: Repeat needs at least two Locations"),
        ((("Location", "0,0"), ("Location", "3,0"), ("Thrust", "50")),
         "t.moos:62: Location 3,0 is 3 m from the one before it (line 61), within Radius 5 m"),
        ((("Location", "0,0"), ("Location", "30,0"), ("Location", "2,1"), ("Thrust", "50"),
          ("Repeat", "FOREVER")),
         "t.moos:61: Location 0,0 is 2.24 m from the one before it (line 63), within Radius"),
        ((("Location", "0,0"), ("Thrust", "50"), ("HeadingTolerance", "45")),
         "t.moos:63: OuterYawLimit = 40 must exceed HeadingTolerance = 45"),
        ((("Location", "0,0"), ("OuterYawLimit", "5"), ("Thrust", "50")),
         "t.moos:62: OuterYawLimit = 5 must exceed HeadingTolerance = 10"),
    ],
)
def test_steer_then_drive_refusals(tblock: TBlock, pairs: tuple[tuple[str, str], ...],
                                   expected: str) -> None:
    assert refusal(tblock, "SteerThenDriveXYPattern", *pairs).startswith(expected)


def test_steer_then_drive_turns_on_the_spot_then_drives(tblock: TBlock, nav_at: NavAt) -> None:
    t = build_task(tblock("SteerThenDriveXYPattern", ("Location", "0,100"),
                          ("Location", "100,100"), ("Thrust", "60"), ("Name", "Grid")))
    assert isinstance(t, SteerThenDriveXYPattern) and t.initial_on
    assert t.locations == [(0.0, 100.0, None), (100.0, 100.0, None)]
    assert (t.radius, t.repeat, t.heading_tolerance, t.outer_yaw_limit) == (5.0, 0, 10.0, 40.0)
    assert t.needs() == {"NAV_X", "NAV_Y", "NAV_HEADING"}
    t.start(0.0)
    assert dict(t.take_notifications())["Grid_WAYPOINT"] == 0.0
    # pointing south, the first waypoint due north: turn on the spot
    trace = []
    for k, heading in enumerate((180.0, 120.0, 60.0, 15.0, 9.0, 20.0, 35.0, 50.0, 30.0, 5.0)):
        now = 1.0 + k
        votes, out = run(t, nav_at(now, x=0.0, y=0.0, heading=heading), now)
        assert votes is not None
        trace.append((heading, round(votes["THRUST"], 6), out.get("Grid_PHASE")))
    assert trace == [
        (180.0, 0.0, ["TURN"]),
        (120.0, 0.0, None),
        (60.0, 0.0, None),
        (15.0, 0.0, None),        # 15° off: still turning
        (9.0, 60.0, ["DRIVE"]),   # below HeadingTolerance: drive
        (20.0, 40.0, None),       # tapering between 10° and 40°
        (35.0, 10.0, None),
        (50.0, 0.0, ["TURN"]),    # beyond OuterYawLimit: stop and turn again
        (30.0, 0.0, None),        # turning until below 10° again, no taper
        (5.0, 60.0, ["DRIVE"]),
    ]
    votes = t.step(nav_at(20.0, x=0.0, y=0.0, heading=180.0), 20.0)
    assert votes is not None and votes["RUDDER"] != 0.0


def test_steer_then_drive_turns_again_at_each_waypoint_and_completes(
    tblock: TBlock, nav_at: NavAt
) -> None:
    t = started(tblock, "SteerThenDriveXYPattern", ("Location", "0,100"),
                ("Location", "100,100"), ("Thrust", "60"), ("Repeat", "1"),
                ("FinishFlag", "Done"), ("Name", "Grid"))
    votes, out = run(t, nav_at(1.0, x=0.0, y=90.0, heading=0.0), 1.0)
    assert votes is not None and votes["THRUST"] == 60.0 and out["Grid_PHASE"] == ["DRIVE"]
    votes, out = run(t, nav_at(2.0, x=0.0, y=97.0, heading=0.0), 2.0)
    assert out["Grid_WAYPOINT"] == [1.0] and out["Grid_PHASE"] == ["TURN"]
    assert votes is not None and votes["THRUST"] == 0.0 and votes["RUDDER"] > 0, \
        "next waypoint due east: pivot clockwise"
    # at the second point: back to the first, second pass
    _, out = run(t, nav_at(3.0, x=98.0, y=100.0, heading=90.0), 3.0)
    assert out["Grid_WAYPOINT"] == [0.0], "Repeat = 1: a second pass"
    _, out = run(t, nav_at(4.0, x=0.0, y=101.0, heading=270.0), 4.0)
    assert out["Grid_WAYPOINT"] == [1.0] and t.active
    assert t.step(nav_at(5.0, x=101.0, y=99.0, heading=90.0), 5.0) is None
    assert t.end_cause == "complete"
    assert ("Done", "DONE") in t.take_notifications()


def test_steer_then_drive_starting_on_a_point_and_forever(tblock: TBlock, nav_at: NavAt) -> None:
    t = started(tblock, "SteerThenDriveXYPattern", ("Location", "0,0"), ("Location", "0,50"),
                ("Thrust", "60"))
    votes = t.step(nav_at(1.0, x=0.0, y=0.0, heading=0.0), 1.0)
    assert votes == {"RUDDER": 0.0, "THRUST": 60.0}, "on the first point: heads for the next"
    t2 = started(tblock, "SteerThenDriveXYPattern", ("Location", "0,0"), ("Thrust", "60"))
    assert t2.step(nav_at(1.0, x=0.0, y=0.0, heading=0.0), 1.0) is None
    assert t2.end_cause == "complete"
    patrol = started(tblock, "SteerThenDriveXYPattern", ("Location", "0,0"),
                     ("Location", "0,50"), ("Thrust", "60"), ("Repeat", "FOREVER"),
                     ("TimeOut", "NEVER"))
    assert patrol.repeat is None
    for k in range(40):
        y = 50.0 if k % 2 else 0.0
        patrol.step(nav_at(1.0 + k, x=0.0, y=y, heading=0.0), 1.0 + k)
    assert patrol.active and patrol.leg == 40


# ---- VariableHeading -------------------------------------------------------------------------


class HeadingRig:
    """A started VariableHeading fed as the helm feeds it: NavState update, then offer."""

    def __init__(self, task: Task, msg) -> None:
        assert isinstance(task, VariableHeading)
        self.task = task
        self.msg = msg
        self.nav = NavState()

    def hear(self, name: str, value: float | str, t: float) -> None:
        m = self.msg(name, value, t)
        self.nav.update(m)
        self.task.offer(m, t)

    def step(self, t: float, heading: float | None = None):
        if heading is not None:
            self.hear("NAV_HEADING", heading, t)
        return run(self.task, self.nav, t)


@pytest.mark.parametrize(
    ("pairs", "expected"),
    [
        ((("HeadingVariable", "2FAST"),),
         "t.moos:61: HeadingVariable expects a variable name such as VARIABLE_HEADING, "
         "got '2FAST'"),
        ((("HeadingVariable", "MY HEADING"),), "t.moos:61: HeadingVariable expects a variable"),
        ((("Thrust", "150"),), "t.moos:61: Thrust must be a number in [-100, 100], got 150"),
    ],
)
def test_variable_heading_refusals(tblock: TBlock, pairs: tuple[tuple[str, str], ...],
                                   expected: str) -> None:
    assert refusal(tblock, "VariableHeading", *pairs).startswith(expected)


def test_variable_heading_follows_the_variable(tblock: TBlock, msg) -> None:
    rig = HeadingRig(started(tblock, "VariableHeading", ("Thrust", "50")), msg)
    assert rig.task.needs() == {"NAV_HEADING", "VARIABLE_HEADING"}
    votes, _ = rig.step(1.0, heading=0.0)
    assert votes is None, "no heading yet: no vote"
    rig.hear("VARIABLE_HEADING", 90.0, 1.5)
    votes, _ = rig.step(2.0, heading=0.0)
    assert votes is not None and votes["RUDDER"] > 0 and votes["THRUST"] == 50.0
    rig.hear("VARIABLE_HEADING", -90.0, 2.5)
    assert rig.task.goal == 270.0
    votes, _ = rig.step(3.0, heading=0.0)
    assert votes is not None and votes["RUDDER"] < 0, "270 is to port of north"


def test_variable_heading_own_variable_name(tblock: TBlock, msg) -> None:
    rig = HeadingRig(started(tblock, "VariableHeading", ("HeadingVariable", "PLUME_HEADING")),
                     msg)
    assert rig.task.needs() == {"NAV_HEADING", "PLUME_HEADING"}
    rig.hear("VARIABLE_HEADING", 90.0, 0.5)
    rig.hear("PLUME_HEADING", 10.0, 0.5)
    votes, _ = rig.step(1.0, heading=0.0)
    assert votes is not None and 0 < votes["RUDDER"] and "THRUST" not in votes
    assert rig.task.goal == 10.0


def test_variable_heading_ignores_bad_values_with_a_warning(tblock: TBlock, msg) -> None:
    rig = HeadingRig(started(tblock, "VariableHeading", ("Name", "Guest")), msg)
    rig.hear("VARIABLE_HEADING", math.nan, 0.5)
    _, out = rig.step(1.0, heading=0.0)
    assert out["Guest_WARNING"] == ["VARIABLE_HEADING = nan is not a heading in [-360, 360] "
                                    "degrees: ignored, holding nothing yet"]
    rig.hear("VARIABLE_HEADING", 45.0, 1.5)
    rig.hear("VARIABLE_HEADING", 400.0, 1.6)
    rig.hear("VARIABLE_HEADING", "east", 1.7)
    votes, out = rig.step(2.0, heading=0.0)
    assert rig.task.goal == 45.0 and votes is not None and votes["RUDDER"] > 0
    assert "Guest_WARNING" not in out, "at most one warning every 5 s"
    rig.hear("VARIABLE_HEADING", math.inf, 6.5)
    _, out = rig.step(7.0, heading=0.0)
    assert out["Guest_WARNING"] == ["VARIABLE_HEADING = inf is not a heading in [-360, 360] "
                                    "degrees: ignored, holding 45"]
    rig.hear("VARIABLE_HEADING", "east", 12.0)
    _, out = rig.step(12.0, heading=0.0)
    assert out["Guest_WARNING"][0].startswith("VARIABLE_HEADING = 'east' is not a heading")


def test_variable_heading_starves_when_silent_or_only_bad(tblock: TBlock, msg) -> None:
    rig = HeadingRig(started(tblock, "VariableHeading", ("FinishFlag", "GuestGone")), msg)
    rig.hear("VARIABLE_HEADING", 30.0, 0.5)
    for now in (1.0, 5.0, 10.5):
        votes, _ = rig.step(now, heading=0.0)
        assert votes is not None
    # only bad values since 0.5 s: they do not feed it
    rig.hear("VARIABLE_HEADING", math.nan, 9.0)
    votes, out = rig.step(10.6, heading=0.0)
    assert votes is None and rig.task.end_cause == "starved"
    assert out["VariableHeading_ERROR"] == ["task VariableHeading starved: no VARIABLE_HEADING "
                                            "for 10 s"]
    assert "GuestGone" in out
    silent = HeadingRig(started(tblock, "VariableHeading"), msg)
    for now in (1.0, 10.0):
        assert silent.step(now, heading=0.0)[0] is None and silent.task.active
    silent.step(10.1, heading=0.0)
    assert silent.task.end_cause == "starved", "never posted: starves 10 s after activation"


def test_new_types_are_registered(tblock: TBlock) -> None:
    from mavhelm.tasks.registry import TASK_TYPES, known_types

    for key, cls in (("limitbox", LimitBox), ("limitaltitude", LimitAltitude),
                     ("holdingpattern", HoldingPattern),
                     ("steerthendrivexypattern", SteerThenDriveXYPattern),
                     ("variableheading", VariableHeading)):
        assert TASK_TYPES[key] is cls
        assert cls.keyword in known_types()
