"""The track-following tasks (TrackLine, XYPattern, Orbit, Survey) and their geometry.

Geometry is checked with hypothesis properties; each task on hand-made NavState sequences and,
for closed-loop behaviour (completion, repeats, direction, leg order), on a kinematic boat: the
helm's rudder vote turns it at rudder / 20 × 45 deg/s (the GUIDED profile's defaults) while it
moves at a constant speed, optionally carried by a current.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import pytest
from hypothesis import given
from hypothesis import strategies as st

from mavhelm.core.mission import Block
from mavhelm.tasks.base import NavState, Task
from mavhelm.tasks.geometry import (
    bearing,
    carrot,
    distance,
    lawnmower,
    nearest,
    offset,
    polygon,
    side_length,
    track_position,
)
from mavhelm.tasks.orbit import Orbit
from mavhelm.tasks.registry import build_task, task_class
from mavhelm.tasks.survey import Survey
from mavhelm.tasks.trackline import XTE_LIMIT, XTE_TI_LEADS, LineFollower, TrackLine
from mavhelm.tasks.xypattern import XYPattern
from tests.support.task_rig import refusal

# tblock (blocks in t.moos at line 60, entries from line 61), nav_at: fixtures in conftest.py
TBlock = Callable[..., Block]
NavAt = Callable[..., NavState]

coord = st.floats(-1000.0, 1000.0, allow_nan=False)
point = st.tuples(coord, coord)
angle = st.floats(-720.0, 720.0, allow_nan=False)


def close(a: float, b: float, tol: float = 1e-6) -> bool:
    return abs(a - b) <= tol


def angle_diff(a: float, b: float) -> float:
    return (a - b + 180.0) % 360.0 - 180.0


# ---- geometry ------------------------------------------------------------------------------


def test_bearing_is_compass_clockwise_from_north() -> None:
    o = (0.0, 0.0)
    assert bearing(o, (0.0, 5.0)) == 0.0
    assert close(bearing(o, (5.0, 0.0)), 90.0)
    assert close(bearing(o, (0.0, -5.0)), 180.0)
    assert close(bearing(o, (-5.0, 0.0)), 270.0)
    assert close(bearing(o, (-1.0, 1.0)), 315.0)
    assert bearing(o, o) == 0.0


@given(point, angle, st.floats(0.01, 500.0))
def test_offset_then_bearing_round_trips(p, b, metres) -> None:
    q = offset(p, b, metres)
    assert close(distance(p, q), metres, 1e-6)
    assert abs(angle_diff(bearing(p, q), b)) < 1e-6


@given(point, point, point)
def test_track_position_rebuilds_the_point(p1, p2, p) -> None:
    length = distance(p1, p2)
    along, xte = track_position(p1, p2, p)
    if length < 1e-3:
        return
    ux, uy = (p2[0] - p1[0]) / length, (p2[1] - p1[1]) / length
    x = p1[0] + along * ux + xte * uy
    y = p1[1] + along * uy - xte * ux
    assert close(x, p[0], 1e-6) and close(y, p[1], 1e-6)


@given(point, angle, st.floats(1.0, 500.0), st.floats(-500.0, 500.0), st.floats(0.01, 100.0))
def test_cross_track_is_positive_to_starboard(p1, b, length, along, side) -> None:
    p2 = offset(p1, b, length)
    on_line = offset(p1, b, along)
    starboard = offset(on_line, b + 90.0, side)
    port = offset(on_line, b - 90.0, side)
    a1, x1 = track_position(p1, p2, starboard)
    a2, x2 = track_position(p1, p2, port)
    assert close(x1, side, 1e-6) and close(x2, -side, 1e-6)
    assert close(a1, along, 1e-6) and close(a2, along, 1e-6)


@given(point, angle, st.floats(1.0, 500.0), point, st.floats(1.0, 100.0))
def test_carrot_is_on_the_segment_lead_ahead_and_never_beyond_p2(p1, b, length, p, lead) -> None:
    p2 = offset(p1, b, length)
    along, _ = track_position(p1, p2, p)
    c = carrot(p1, p2, p, lead)
    c_along, c_xte = track_position(p1, p2, c)
    assert abs(c_xte) < 1e-6, "the carrot lies on the line"
    assert c_along <= length + 1e-6, "never beyond P2"
    assert close(c_along, min(along + lead, length), 1e-6)


def test_carrot_examples() -> None:
    p1, p2 = (0.0, 0.0), (0.0, 100.0)
    assert carrot(p1, p2, (10.0, 20.0), 5.0) == (0.0, 25.0)
    assert carrot(p1, p2, (-3.0, 98.0), 5.0) == (0.0, 100.0)
    assert carrot(p1, p2, (0.0, -30.0), 5.0) == (0.0, -25.0), "behind P1: onto the line's extension"
    assert carrot(p1, p1, (3.0, 3.0), 5.0) == p1, "a degenerate line's carrot is its end"


@given(point, st.floats(1.0, 500.0), st.floats(1.0, 200.0), st.floats(0.5, 50.0), angle)
def test_lawnmower_legs_alternate_and_join_one_spacing_apart(center, a, b, spacing, rotation
                                                              ) -> None:
    if spacing > b:
        spacing = b
    legs = lawnmower(center, a, b, spacing, rotation)
    assert len(legs) == math.floor(b / spacing + 1e-9) + 1
    for i, (start, end) in enumerate(legs):
        assert close(distance(start, end), a, 1e-6)
        expected = rotation if i % 2 == 0 else rotation + 180.0
        assert abs(angle_diff(bearing(start, end), expected)) < 1e-6, "legs alternate"
        for q in (start, end):  # inside the box, in its own axes
            along, across = track_position(center, offset(center, rotation, 1.0), q)
            assert abs(along) <= a / 2 + 1e-6 and abs(across) <= b / 2 + 1e-6
    for (_, end), (start, _) in zip(legs, legs[1:], strict=False):
        assert close(distance(end, start), spacing, 1e-6), "joins are one spacing long"
    if len(legs) > 1:  # each next leg is one spacing to starboard of the first's direction
        _, across = track_position(legs[0][0], legs[0][1], legs[1][0])
        assert close(across, spacing, 1e-6)


def test_lawnmower_example_box_centred() -> None:
    legs = lawnmower((0.0, 40.0), 50.0, 20.0, 10.0, 90.0)
    rounded = [tuple((round(x, 6), round(y, 6)) for x, y in leg) for leg in legs]
    assert rounded == [((-25.0, 50.0), (25.0, 50.0)), ((25.0, 40.0), (-25.0, 40.0)),
                       ((-25.0, 30.0), (25.0, 30.0))]
    legs = lawnmower((0.0, 0.0), 10.0, 25.0, 10.0, 0.0)
    assert [round(leg[0][0], 6) for leg in legs] == [-10.0, 0.0, 10.0], "centred across"


@given(point, st.floats(2.0, 10_000.0), st.integers(3, 360))
def test_polygon_vertices_on_the_circle_clockwise(center, radius, sides) -> None:
    vs = polygon(center, radius, sides)
    assert len(vs) == sides
    assert all(close(distance(center, v), radius, 1e-6 * radius) for v in vs)
    assert close(distance(vs[0], vs[1]), side_length(radius, sides), 1e-6 * radius)
    assert abs(angle_diff(bearing(center, vs[0]), 0.0)) < 1e-6
    assert abs(angle_diff(bearing(center, vs[1]), 360.0 / sides)) < 1e-6


def test_nearest_takes_the_first_on_a_tie() -> None:
    vs = polygon((0.0, 0.0), 10.0, 4)
    assert nearest(vs, (0.0, -30.0)) == 2
    assert nearest(vs, (0.0, 0.0)) == 0


# ---- a kinematic boat for closed-loop checks -------------------------------------------------


@dataclass
class Flight:
    task: Task
    track: list[tuple[float, float, float, float]] = field(default_factory=list)
    posts: list[tuple[float, str, float | str]] = field(default_factory=list)
    lines: list[tuple[tuple[float, float], tuple[float, float]]] = field(default_factory=list)

    def values(self, name: str) -> list[float | str]:
        return [v for _, n, v in self.posts if n == name]


def fly(task: Task, x: float = 0.0, y: float = 0.0, heading: float = 0.0, speed: float = 1.6,
        current: tuple[float, float] = (0.0, 0.0), seconds: float = 600.0,
        dt: float = 0.1) -> Flight:
    """Run a started task on a kinematic boat until it ends or ``seconds`` pass."""
    flight = Flight(task)
    now = 0.0
    while task.active and now < seconds:
        now = round(now + dt, 6)
        votes = task.step(_nav(now, x, y, heading), now)
        flight.posts += [(now, n, v) for n, v in task.take_notifications()]
        follower = getattr(task, "follower", None)
        if follower is not None and (not flight.lines or flight.lines[-1] !=
                                     (follower.p1, follower.p2)):
            flight.lines.append((follower.p1, follower.p2))
        rudder = votes["RUDDER"] if votes else 0.0
        heading = (heading + rudder / 20.0 * 45.0 * dt) % 360.0
        x += (speed * math.sin(math.radians(heading)) + current[0]) * dt
        y += (speed * math.cos(math.radians(heading)) + current[1]) * dt
        flight.track.append((now, x, y, heading))
    return flight


def _nav(t: float, x: float, y: float, heading: float) -> NavState:
    from mavhelm.core.bus import Message

    nav = NavState()
    for name, v in (("NAV_X", x), ("NAV_Y", y), ("NAV_HEADING", heading)):
        nav.update(Message(name, v, t, "test"))
    return nav


def make(tblock: TBlock, kind: str, *pairs: tuple[str, str]) -> Task:
    task = build_task(tblock(kind, ("InitialState", "ON"), ("Name", "T"), ("TimeOut", "NEVER"),
                             *pairs))
    task.start(0.0)
    task.take_notifications()
    return task


def test_the_four_are_registered_case_insensitively() -> None:
    assert task_class("TRACKLINE") is TrackLine
    assert task_class("xyPattern") is XYPattern
    assert task_class("orbit") is Orbit
    assert task_class("Survey") is Survey


# ---- TrackLine ---------------------------------------------------------------------------------


def test_trackline_parameters_and_defaults(tblock: TBlock) -> None:
    t = make(tblock, "TrackLine", ("P2", "0, 100"))
    assert isinstance(t, TrackLine)
    assert (t.p1, t.p2, t.lead, t.lead_time, t.radius, t.thrust) == (
        None, (0.0, 100.0, None), None, 1.5, 3.0, None)  # no Lead: LeadTime × speed
    assert t.needs() == {"NAV_X", "NAV_Y", "NAV_HEADING"}
    t = make(tblock, "TrackLine", ("P1", "1,2"), ("P2", "3,4"), ("Lead", "1"), ("Radius", "7"),
             ("Thrust", "50"))
    assert (t.p1, t.lead, t.radius, t.thrust) == ((1.0, 2.0, None), 1.0, 7.0, 50.0)


@pytest.mark.parametrize(
    ("pairs", "expected"),
    [
        ((), "t.moos:60: TrackLine task TrackLine needs P2 (x,y or x,y,z in metres"),
        ((("P2", "0,10"), ("Lead", "0.5")),
         "t.moos:62: Lead must be a number in [1, 10000], got 0.5"),
        ((("P2", "0,10"), ("Radius", "0")),
         "t.moos:62: Radius must be a number in [0.1, 10000], got 0"),
        ((("P1", "0,10"), ("P2", "0,10")),
         "t.moos:62: P1 and P2 are the same point: task TrackLine has no line to follow"),
        ((("P2", "0"),), "t.moos:61: P2 expects x,y or x,y,z in metres, got '0'"),
        ((("P2", "0,1"), ("Thrust", "120")),
         "t.moos:62: Thrust must be a number in [-100, 100], got 120"),
        ((("P2", "0,1"), ("Heading", "3")), "t.moos:62: unknown setting 'Heading' for a "
         "TrackLine task"),
    ],
)
def test_trackline_refusals(tblock: TBlock, pairs, expected: str) -> None:
    assert refusal(tblock, "TrackLine", *pairs).startswith(expected)


def test_trackline_steers_for_the_carrot(tblock: TBlock, nav_at: NavAt) -> None:
    t = make(tblock, "TrackLine", ("P1", "0,0"), ("P2", "0,100"), ("LOGPID", "true"),
             ("Lead", "5"), ("Thrust", "70"))
    votes = t.step(nav_at(1.0, x=10.0, y=20.0, heading=0.0), 1.0)
    assert votes is not None and votes["RUDDER"] < 0 and votes["THRUST"] == 70.0
    out = dict(t.take_notifications())
    # carrot (0, 25): bearing from (10, 20) is 270 + atan(5/10) = 296.565°, error -63.435°
    assert out["T_YAW_PID"].startswith("e=-63.435,")
    assert out["T_XTE"] == 10.0, "10 m east of a northbound line: +10 (starboard)"
    t.step(nav_at(2.0, x=-2.0, y=50.0, heading=0.0), 2.0)
    out = dict(t.take_notifications())
    assert out["T_XTE"] == -2.0
    # carrot 5 m ahead: 21.801° to starboard (no integral: the vehicle just jumped sideways)
    assert out["T_YAW_PID"].startswith(f"e={math.degrees(math.atan2(2.0, 5.0)):.3f},")


def test_trackline_near_the_end_steers_for_p2(tblock: TBlock, nav_at: NavAt) -> None:
    t = make(tblock, "TrackLine", ("P1", "0,0"), ("P2", "0,100"), ("LOGPID", "true"),
             ("Lead", "5"), ("Radius", "1"))
    t.step(nav_at(1.0, x=4.0, y=98.0, heading=0.0), 1.0)
    out = dict(t.take_notifications())
    expected = angle_diff(bearing((4.0, 98.0), (0.0, 100.0)), 0.0)
    assert out["T_YAW_PID"].startswith(f"e={expected:.3f},"), "carrot clamped at P2"


def test_trackline_without_p1_starts_where_the_vehicle_is(tblock: TBlock, nav_at: NavAt) -> None:
    t = make(tblock, "TrackLine", ("P2", "5,50"))
    t.step(nav_at(1.0, x=5.0, y=5.0, heading=30.0), 1.0)
    assert dict(t.take_notifications())["T_XTE"] == 0.0
    t.step(nav_at(2.0, x=6.0, y=20.0, heading=0.0), 2.0)
    assert dict(t.take_notifications())["T_XTE"] == 1.0, "the line runs from (5,5) to (5,50)"
    assert isinstance(t, TrackLine) and t.follower is not None
    assert t.follower.p1 == (5.0, 5.0)


def test_trackline_completes_within_radius_of_p2(tblock: TBlock, nav_at: NavAt) -> None:
    t = make(tblock, "TrackLine", ("P1", "0,0"), ("P2", "0,100"), ("Radius", "3"),
             ("FinishFlag", "Done"))
    assert t.step(nav_at(1.0, x=0.0, y=96.0, heading=0.0), 1.0) is not None
    assert t.step(nav_at(2.0, x=1.0, y=97.5, heading=0.0), 2.0) is None
    assert t.end_cause == "complete"
    assert ("Done", "DONE") in t.take_notifications()


def test_trackline_completes_once_past_the_end_along_the_line(tblock: TBlock,
                                                             nav_at: NavAt) -> None:
    t = make(tblock, "TrackLine", ("P1", "0,0"), ("P2", "0,100"), ("Radius", "3"))
    assert t.step(nav_at(1.0, x=8.0, y=99.9, heading=0.0), 1.0) is not None
    assert t.step(nav_at(2.0, x=8.0, y=100.1, heading=0.0), 2.0) is None
    assert t.end_cause == "complete", "8 m to the side but past P2: done, no turning back"


def test_xte_integral_grows_bounded_and_only_near_the_line(tblock: TBlock,
                                                          nav_at: NavAt) -> None:
    t = make(tblock, "TrackLine", ("P1", "0,0"), ("P2", "0,1000"), ("Lead", "5"))
    assert isinstance(t, TrackLine)
    for k in range(1, 11):  # 10 s, 1 m to starboard, moving parallel to the line at 1 m/s
        t.step(nav_at(float(k), x=1.0, y=float(k), heading=0.0), float(k))
    assert t.follower is not None
    # track measured from t=2 (1 s baseline), steady 2 s later: learned over t = 3..10 at
    # XTE · speed / (XTE_TI_LEADS · Lead²) rad/s (1 m off, 1 m/s, Lead 5)
    rate = math.degrees(1.0 * 1.0 / (XTE_TI_LEADS * 5.0 ** 2))
    assert close(t.follower.correction, 7.0 * rate)
    for k in range(11, 200):
        t.step(nav_at(float(k), x=1.0, y=float(k), heading=0.0), float(k))
    assert t.follower.correction == XTE_LIMIT, "bounded"
    before = t.follower.correction
    t.step(nav_at(300.0, x=-20.0, y=100.0, heading=0.0), 300.0)
    assert t.follower.correction == before, "not integrated a Lead or more off the line"
    t.resume()
    assert t.follower.correction == 0.0, "the helm back online: forget the learned set"


def test_xte_integral_learns_in_pursuit_time_constants(tblock: TBlock, nav_at: NavAt) -> None:
    """The same offset is learned twice as fast at twice the speed, and 2.5 times slower with
    a Lead 1.58 times longer (the integral's time is XTE_TI_LEADS × Lead / speed)."""
    learned = {}
    for lead, speed in ((5.0, 1.0), (5.0, 2.0), (5.0 * math.sqrt(2.5), 1.0)):
        t = make(tblock, "TrackLine", ("P1", "0,0"), ("P2", "0,1000"), ("Lead", f"{lead!r}"))
        for k in range(1, 11):
            t.step(nav_at(float(k), x=1.0, y=speed * k, heading=0.0), float(k))
        assert isinstance(t, TrackLine) and t.follower is not None
        learned[lead, speed] = t.follower.correction
    assert learned[5.0, 1.0] > 0.0
    assert close(learned[5.0, 2.0], 2.0 * learned[5.0, 1.0])
    assert close(learned[5.0 * math.sqrt(2.5), 1.0], learned[5.0, 1.0] / 2.5)


def test_xte_integral_steps_at_most_one_second(tblock: TBlock, nav_at: NavAt) -> None:
    t = make(tblock, "TrackLine", ("P1", "0,0"), ("P2", "0,1000"), ("Lead", "5"))
    assert isinstance(t, TrackLine)
    for k in range(1, 7):
        t.step(nav_at(float(k), x=2.0, y=float(k), heading=0.0), float(k))
    assert t.follower is not None
    before = t.follower.correction
    assert before > 0
    t.step(nav_at(36.0, x=2.0, y=36.0, heading=0.0), 36.0)
    one_second = math.degrees(2.0 * 1.0 / (XTE_TI_LEADS * 5.0 ** 2))  # 2 m off at 1 m/s
    assert close(t.follower.correction - before, one_second), \
        "a 30 s gap counts as 1 s: not an offset"


def test_line_follower_heading_sign_and_correction() -> None:
    f = LineFollower((0.0, 0.0), (100.0, 0.0), 5.0)  # an eastbound line
    h = f.heading((50.0, 5.0), 0.0)  # 5 m north: to port of an eastbound line
    assert f.xte == -5.0 and close(h, 135.0), "carrot 5 m ahead on the line: south-east"


def test_trackline_removes_a_cross_current_offset(tblock: TBlock) -> None:
    """With 0.3 m/s across the line, pure pursuit would sit ~1 m off (5 · tan(asin(.3/1.6)))."""
    t = make(tblock, "TrackLine", ("P1", "0,0"), ("P2", "0,300"), ("Thrust", "80"))
    f = fly(t, x=10.0, current=(0.3, 0.0))
    assert t.end_cause == "complete"
    late = [x for (_, x, y, _) in f.track if y > 150.0]
    assert max(abs(x) for x in late) < 0.1
    assert min(x for (_, x, _, _) in f.track) > -1.0, "no large overshoot from 10 m off"
    xtes = f.values("T_XTE")
    assert len(xtes) == len(f.track) - 1, "XTE posted every tick but the completing one"


# ---- XYPattern ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("pairs", "expected"),
    [
        ((), "t.moos:60: XYPattern task XYPattern needs at least one Location"),
        ((("Location", "0,0"), ("Repeat", "-1")),
         "t.moos:62: Repeat must be a whole number in [0, 1000] or FOREVER, got -1"),
        ((("Location", "0,0"), ("Repeat", "often")),
         "t.moos:62: Repeat expects a whole number in [0, 1000] or FOREVER, got 'often'"),
        ((("Location", "0,0"), ("Repeat", "2")),
         "t.moos:62: Repeat needs at least two Locations"),
        ((("Location", "0,0"), ("Location", "3,0")),
         "t.moos:62: Location 3,0 is 3 m from the one before it (line 61), within Radius 5 m"),
        ((("Location", "0,0"), ("Location", "30,0"), ("Location", "2,0"), ("Repeat", "1")),
         "t.moos:61: Location 0,0 is 2 m from the one before it (line 63)"),
        ((("Location", "0,0"), ("Radius", "-1")),
         "t.moos:62: Radius must be a number in [0.1, 10000], got -1"),
    ],
)
def test_xypattern_refusals(tblock: TBlock, pairs, expected: str) -> None:
    assert refusal(tblock, "XYPattern", *pairs).startswith(expected)


def test_xypattern_parameters(tblock: TBlock) -> None:
    t = make(tblock, "XYPattern", ("Location", "0,30"), ("Location", "30,30"))
    assert isinstance(t, XYPattern)
    assert (t.locations, t.radius, t.repeat) == ([(0.0, 30.0, None), (30.0, 30.0, None)], 5.0, 0)
    t = make(tblock, "XYPattern", ("Location", "0,30"), ("Location", "30,30"),
             ("Repeat", "forever"))
    assert isinstance(t, XYPattern) and t.repeat is None


def test_xypattern_flies_waypoints_in_order_and_repeats(tblock: TBlock) -> None:
    t = make(tblock, "XYPattern", ("Location", "0,40"), ("Location", "40,40"),
             ("Location", "40,0"), ("Repeat", "1"), ("Radius", "4"), ("FinishFlag", "Done"))
    f = fly(t)
    assert t.end_cause == "complete"
    assert f.values("T_WAYPOINT") == [0.0, 1.0, 2.0, 0.0, 1.0, 2.0]
    assert ("Done", "DONE") in [(n, v) for _, n, v in f.posts]
    # the lines: start → W0, W0 → W1, W1 → W2, then W2 → W0 to begin the repeat pass
    assert f.lines == [((0.0, 0.0), (0.0, 40.0)), ((0.0, 40.0), (40.0, 40.0)),
                       ((40.0, 40.0), (40.0, 0.0)), ((40.0, 0.0), (0.0, 40.0)),
                       ((0.0, 40.0), (40.0, 40.0)), ((40.0, 40.0), (40.0, 0.0))]
    # it moved on from each waypoint when within Radius of it (or past it)
    moves = [tt for tt, n, _ in f.posts if n == "T_WAYPOINT"][1:]
    targets = [(0.0, 40.0), (40.0, 40.0), (40.0, 0.0), (0.0, 40.0), (40.0, 40.0)]
    for tt, goal in zip(moves, targets, strict=True):
        _, x, y, _ = next(s for s in f.track if s[0] >= tt - 0.1 - 1e-9)
        assert distance((x, y), goal) < 4.0 + 0.2


def test_xypattern_forever_patrols_until_its_timeout(tblock: TBlock) -> None:
    task = build_task(tblock("XYPattern", ("InitialState", "ON"), ("Name", "T"),
                             ("Location", "0,40"), ("Location", "0,0"), ("Repeat", "FOREVER"),
                             ("TimeOut", "200")))
    task.start(0.0)
    f = fly(task, seconds=300.0)
    assert task.end_cause == "timeout"
    assert len(f.values("T_WAYPOINT")) >= 6


def test_xypattern_each_line_starts_with_no_learned_correction(tblock: TBlock,
                                                              nav_at: NavAt) -> None:
    t = make(tblock, "XYPattern", ("Location", "0,100"), ("Location", "100,100"))
    assert isinstance(t, XYPattern)
    for k in range(1, 30):
        t.step(nav_at(float(k), x=1.0, y=3.0 * k, heading=0.0), float(k))
    assert t.follower is not None and t.follower.correction > 0
    t.step(nav_at(30.0, x=1.0, y=99.0, heading=0.0), 30.0)
    assert t.index == 1 and t.follower.correction == 0.0


# ---- Orbit -----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("pairs", "expected"),
    [
        ((("Radius", "10"),), "t.moos:60: Orbit task Orbit needs Location"),
        ((("Location", "0,0"), ("Radius", "1")),
         "t.moos:62: Radius must be a number in [2, 10000], got 1"),
        ((("Location", "0,0"), ("Radius", "10"), ("Sides", "2")),
         "t.moos:63: Sides must be a whole number in [3, 360], got 2"),
        ((("Location", "0,0"), ("Radius", "10"), ("Sides", "6.5")),
         "t.moos:63: Sides must be a whole number in [3, 360], got 6.5"),
        ((("Location", "0,0"), ("Radius", "10"), ("Direction", "left")),
         "t.moos:63: Direction expects one of CW, CCW, got 'left'"),
        ((("Location", "0,0"), ("Radius", "10"), ("Repeat", "0")),
         "t.moos:63: Repeat must be a whole number in [1, 1000], got 0"),
        ((("Location", "0,0"), ("Radius", "10"), ("PosRadius", "2")),
         "t.moos:63: PosRadius must be less than half a side (1.95 m for Radius 10 and 16 "
         "Sides), got 2"),
    ],
)
def test_orbit_refusals(tblock: TBlock, pairs, expected: str) -> None:
    assert refusal(tblock, "Orbit", *pairs).startswith(expected)


def test_orbit_parameters(tblock: TBlock) -> None:
    t = make(tblock, "Orbit", ("Location", "0,0"), ("Radius", "20"))
    assert isinstance(t, Orbit)
    assert (t.direction, t.repeat, t.sides, t.pos_radius) == ("CW", 1, 16, None)
    assert t.capture == 3.0, "default PosRadius 3 m (a side is 7.8 m)"
    t = make(tblock, "Orbit", ("Location", "0,0"), ("Radius", "10"), ("Direction", "ccw"),
             ("Sides", "6"), ("PosRadius", "2"))
    assert isinstance(t, Orbit) and t.direction == "CCW" and t.capture == 2.0
    t = make(tblock, "Orbit", ("Location", "0,0"), ("Radius", "5"))
    assert isinstance(t, Orbit) and close(t.capture, 0.4 * side_length(5.0, 16))


def test_orbit_starts_at_the_nearest_vertex(tblock: TBlock, nav_at: NavAt) -> None:
    t = make(tblock, "Orbit", ("Location", "0,50"), ("Radius", "20"), ("Sides", "8"))
    assert isinstance(t, Orbit)
    t.step(nav_at(1.0, x=0.0, y=0.0, heading=0.0), 1.0)
    assert t.follower is not None
    assert t.follower.p1 == (0.0, 0.0)
    assert distance(t.follower.p2, (0.0, 30.0)) < 1e-9, "the south vertex"


def _swept(track: list[tuple[float, float, float, float]], center: tuple[float, float]) -> float:
    """Unwrapped change of the bearing from the centre along a track (positive clockwise)."""
    total = 0.0
    last = bearing(center, track[0][1:3])
    for _, x, y, _ in track[1:]:
        b = bearing(center, (x, y))
        total += angle_diff(b, last)
        last = b
    return total


@pytest.mark.parametrize(("direction", "repeat", "sign"), [("CW", 1, 1), ("CCW", 2, -1)])
def test_orbit_direction_and_repeat(tblock: TBlock, direction: str, repeat: int,
                                    sign: int) -> None:
    t = make(tblock, "Orbit", ("Location", "0,30"), ("Radius", "15"), ("Sides", "12"),
             ("Direction", direction), ("Repeat", str(repeat)), ("Thrust", "80"))
    assert isinstance(t, Orbit)
    f = fly(t)
    assert t.end_cause == "complete"
    assert f.values("T_ORBIT") == [float(k) for k in range(1, repeat + 1)]
    on_circle = [s for s in f.track if abs(distance((s[1], s[2]), (0.0, 30.0)) - 15.0) < 3.0]
    swept = _swept(on_circle, (0.0, 30.0))
    assert abs(swept - sign * 360.0 * repeat) < 30.0, swept
    # the lines: approach, then Sides × Repeat sides of the polygon, every one in turn
    assert len(f.lines) == 1 + 12 * repeat
    steps = {round(angle_diff(bearing((0.0, 30.0), b), bearing((0.0, 30.0), a)), 6)
             for a, b in f.lines[1:]}
    assert steps == {sign * 30.0}


# ---- Survey ----------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("pairs", "expected"),
    [
        ((("A", "50"), ("B", "20"), ("Spacing", "5")), "t.moos:60: Survey task Survey needs "
         "Center"),
        ((("Center", "0,0"), ("A", "50"), ("B", "20"), ("Spacing", "25")),
         "t.moos:64: Spacing must be at most B (20 m), got 25"),
        ((("Center", "0,0"), ("A", "50"), ("B", "20"), ("Spacing", "0")),
         "t.moos:64: Spacing must be a number in (0, 100000], got 0"),
        ((("Center", "0,0"), ("A", "0"), ("B", "20"), ("Spacing", "5")),
         "t.moos:62: A must be a number in (0, 100000], got 0"),
        ((("Center", "0,0"), ("A", "50"), ("B", "20000"), ("Spacing", "1")),
         "t.moos:64: Spacing 1 m across B = 20000 m makes more than 1000 legs"),
        ((("Center", "0,0"), ("A", "50"), ("B", "20"), ("Spacing", "5"), ("Lead", "0")),
         "t.moos:65: Lead must be a number in [1, 10000], got 0"),
        ((("Center", "0,0"), ("A", "50"), ("B", "20"), ("Spacing", "5"), ("LegTimeOut", "0")),
         "t.moos:65: LegTimeOut must be a number in (0, 604800], got 0"),
    ],
)
def test_survey_refusals(tblock: TBlock, pairs, expected: str) -> None:
    assert refusal(tblock, "Survey", *pairs).startswith(expected)


def test_survey_parameters(tblock: TBlock) -> None:
    t = make(tblock, "Survey", ("Center", "0,40"), ("A", "50"), ("B", "20"), ("Spacing", "10"),
             ("Rotation", "-270"))
    assert isinstance(t, Survey)
    assert (t.rotation, t.lead, t.lead_time, t.leg_timeout, len(t.legs)) == (
        90.0, None, 1.5, None, 3)
    t = make(tblock, "Survey", ("Center", "0,40"), ("A", "50"), ("B", "20"), ("Spacing", "10"),
             ("LegTimeOut", "never"))
    assert isinstance(t, Survey) and t.leg_timeout is None


def test_survey_flies_legs_in_order_joined_at_the_ends(tblock: TBlock) -> None:
    t = make(tblock, "Survey", ("Center", "0,40"), ("A", "50"), ("B", "20"), ("Spacing", "10"),
             ("Rotation", "90"), ("Thrust", "80"))
    assert isinstance(t, Survey)
    f = fly(t)
    assert t.end_cause == "complete"
    assert f.values("T_LEG") == [0.0, 1.0, 2.0]
    legs = [((-25.0, 50.0), (25.0, 50.0)), ((25.0, 40.0), (-25.0, 40.0)),
            ((-25.0, 30.0), (25.0, 30.0))]
    expected = [((0.0, 0.0), legs[0][0]), legs[0], (legs[0][1], legs[1][0]), legs[1],
                (legs[1][1], legs[2][0]), legs[2]]
    assert len(f.lines) == len(expected)
    for got, want in zip(f.lines, expected, strict=True):
        assert distance(got[0], want[0]) < 1e-9 and distance(got[1], want[1]) < 1e-9
    # each leg was flown to its end (passed along the leg) before the join began
    leg_started = [tt for tt, n, _ in f.posts if n == "T_LEG"]
    for (start, end), t0 in zip(legs, leg_started, strict=True):
        flown = [s for s in f.track if s[0] >= t0][:400]
        reached = [s for s in flown if track_position(start, end, s[1:3])[0] >= 50.0 - 1e-6
                   or distance(s[1:3], end) < 1.0]
        assert reached, "the leg's end was reached"


def test_survey_abandons_a_leg_after_leg_timeout(tblock: TBlock) -> None:
    task = build_task(tblock("Survey", ("InitialState", "ON"), ("Name", "T"),
                             ("TimeOut", "NEVER"), ("Center", "0,0"), ("A", "100"),
                             ("B", "10"), ("Spacing", "10"), ("LegTimeOut", "20"),
                             ("EventFlag", "Skipped")))
    task.start(0.0)
    f = fly(task, x=0.0, y=-50.0, heading=0.0)
    assert task.end_cause == "complete"
    assert f.values("T_LEG") == [0.0, 1.0]
    warnings = f.values("T_WARNING")
    assert warnings == ["leg 0 abandoned after 20 s", "leg 1 abandoned after 20 s"]
    assert f.values("Skipped") == warnings
    # after leg 0 is abandoned, the vehicle runs a line from where it is to leg 1's start
    assert isinstance(task, Survey)
    join = f.lines[2]
    assert distance(join[1], task.legs[1][0]) < 1e-9
    assert distance(join[0], task.legs[0][1]) > 10.0, "from mid-leg, not the leg's end"


def _feed(f: LineFollower, fixes: list[tuple[float, float, float]]) -> list[bool]:
    """Give a follower (t, x, y) fixes; return whether each step was integrated."""
    gates = []
    for t, x, y in fixes:
        f.heading((x, y), t)
        gates.append(f.integrating)
    return gates


def test_integral_gate_learns_a_held_offset_only() -> None:
    line = ((0.0, 0.0), (0.0, 1000.0))
    held = LineFollower(*line, 5.0)  # 1 m off, running parallel at 1.6 m/s
    gates = _feed(held, [(0.1 * k, 1.0, 0.16 * k) for k in range(60)])
    assert not any(gates[:30]) and all(gates[31:]), "after 1 s of baseline and 2 s steady"
    closing = LineFollower(*line, 5.0)  # closing on the line at 20° to it
    slope = math.tan(math.radians(20.0))
    assert not any(_feed(closing, [(0.1 * k, 4.0 - slope * 0.16 * k, 0.16 * k)
                                   for k in range(60)]))
    stopped = LineFollower(*line, 5.0)  # held 1 m off, not making way
    assert not any(_feed(stopped, [(0.1 * k, 1.0, 20.0) for k in range(60)]))
    far = LineFollower(*line, 5.0)  # parallel, but a Lead or more off
    assert not any(_feed(far, [(0.1 * k, 6.0, 0.16 * k) for k in range(60)]))
    assert (closing.correction, stopped.correction, far.correction) == (0.0, 0.0, 0.0)


def test_integral_gate_ignores_the_far_point_of_a_swing() -> None:
    """Out to 2.5 m and back in 6 s (as after a turn onto a line, measured in the simulator):
    parallel to the line only for a moment at the top."""
    f = LineFollower((0.0, 0.0), (0.0, 1000.0), 5.0)
    fixes = [(0.1 * k, 2.5 * math.sin(math.pi * k / 60.0), 0.16 * k) for k in range(60)]
    assert not any(_feed(f, fixes)) and f.correction == 0.0
