"""The planned turn onto a line (mavhelm.tasks.turn_plan): its geometry, how it is flown, the
routes that plan it (Survey, chained TrackLines) and the tune's restatement of it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavhelm.tasks import turn_plan
from mavhelm.tasks.pid import HelmGains
from mavhelm.tasks.registry import build_task
from mavhelm.tasks.survey import Survey
from mavhelm.tasks.trackline import (
    TURN_LAG_S,
    FlownLine,
    LineFollower,
    TrackLine,
    link_track_lines,
)
from mavhelm.tasks.turn_plan import Arc, corner_arc, entry_path, is_u_turn, u_turn_arc
from tests.support.task_rig import TBlock, nav_at, task_block


def test_a_corner_arc_is_tangent_to_both_lines() -> None:
    arc = corner_arc((0.0, 0.0), (100.0, 0.0), (100.0, -50.0), 7.5)
    assert arc is not None
    assert arc.radius == pytest.approx(7.5)
    assert arc.start == pytest.approx((92.5, 0.0))
    assert arc.end == pytest.approx((100.0, -7.5))
    assert arc.centre == pytest.approx((92.5, -7.5))      # to starboard: a right turn
    assert arc.sweep == pytest.approx(math.pi / 2)
    assert arc.turn_in == pytest.approx(7.5)
    assert arc.heading_out == pytest.approx(180.0)


def test_a_corner_arc_fits_in_half_of_either_line() -> None:
    arc = corner_arc((0.0, 0.0), (100.0, 0.0), (100.0, 10.0), 7.5)   # a left turn, 10 m on
    assert arc is not None
    assert arc.radius == pytest.approx(5.0) and arc.sweep == pytest.approx(-math.pi / 2)
    assert arc.centre == pytest.approx((95.0, 5.0))


@pytest.mark.parametrize("p2", [(100.5, 0.001), (0.0, 0.0), (100.0, 0.001)])
def test_no_arc_straight_on_reversed_or_too_tight(p2) -> None:
    assert corner_arc((0.0, 0.0), (100.0, 0.0), p2, 7.5) is None


def test_locate_and_heading_on_each_part_of_the_entry_path() -> None:
    arc = corner_arc((0.0, 0.0), (100.0, 0.0), (100.0, -50.0), 5.0)
    assert arc is not None
    # on the line in, 1 m to starboard (south), 3 m before the arc
    assert arc.locate((92.0, -1.0)) == pytest.approx((-3.0, 1.0))
    # half way round, 0.5 m outside the arc: to port of a right turn
    mid = (95.0 + 5.5 * math.sin(math.radians(45)), -5.0 + 5.5 * math.cos(math.radians(45)))
    s, xte = arc.locate(mid)
    assert s == pytest.approx(5.0 * math.pi / 4) and xte == pytest.approx(-0.5)
    # on the line out, 0.2 m to starboard (west), 4 m past the arc
    assert arc.locate((99.8, -9.0)) == pytest.approx((arc.length + 4.0, 0.2))
    # on the arc, on it: the tangent there, or ahead along the path
    on = (95.0 + 5.0 * math.sin(math.radians(30)), -5.0 + 5.0 * math.cos(math.radians(30)))
    assert arc.heading(on, 5.0, 0.0) == pytest.approx((120.0, 0.0), abs=1e-9)
    assert arc.heading(on, 5.0, 100.0)[0] == pytest.approx(180.0)
    # off it, pursuit's correction: atan(offset / Lead) back towards it
    assert arc.heading(mid, 5.0, 0.0)[0] == pytest.approx(135.0 + math.degrees(
        math.atan(0.5 / 5.0)))
    assert not arc.done(on) and arc.done((100.0, -9.0))


def test_a_u_turn_is_one_half_circle_beyond_the_lines_ends() -> None:
    legs = ((0.0, 0.0), (100.0, 0.0), (100.0, -20.0), (0.0, -20.0))
    assert is_u_turn(*legs, 7.5)
    assert not is_u_turn(*legs, 3.0)         # 10 m is more than two Leads: two corners
    assert not is_u_turn(*legs, 25.0)        # less than half a Lead: too tight for one
    assert not is_u_turn(legs[0], legs[1], legs[2], (0.0, -25.0), 7.5)   # not parallel
    arc = u_turn_arc(*legs[:3])
    assert arc.centre == pytest.approx((100.0, -10.0)) and arc.radius == pytest.approx(10.0)
    assert arc.sweep == pytest.approx(math.pi) and arc.heading_out == pytest.approx(270.0)
    assert arc.locate((110.0, -10.0)) == pytest.approx((5.0 * math.pi, 0.0), abs=1e-9)
    assert entry_path(*legs, 7.5, after_half_circle=False) == arc
    assert entry_path(legs[1], legs[2], legs[3], None, 7.5, after_half_circle=True) is None
    assert turn_plan.is_half_circle(arc)
    # the line is flown to its end (less the lag), the join to its end
    assert turn_plan.turn_in(*legs, 7.5, 2.5, on_half_circle=False) == pytest.approx(2.5)
    assert turn_plan.turn_in(legs[1], legs[2], legs[3], None, 7.5, 2.5,
                             on_half_circle=True) == 0.0


def test_the_corner_after_a_join_is_planned_as_the_join_was_flown() -> None:
    """Whether a U-turn is one half circle depends on the Lead, so on the speed measured at
    each of its two corners. A join entered by its corner's arc (the speed measured was low
    there) is left for the line out at that corner's turn-in, and the line out entered by its
    own arc, whatever the speed says there; a join entered by its half circle needs neither."""
    legs = ((0.0, 0.0), (100.0, 0.0), (100.0, -20.0), (0.0, -20.0))
    corner = corner_arc(*legs[:3], 4.8)
    assert corner is not None and not turn_plan.is_half_circle(corner)
    at_join_end = turn_plan.turn_in(legs[1], legs[2], legs[3], None, 6.0, 2.0,
                                    on_half_circle=False)
    assert at_join_end == pytest.approx(min(6.0 + 2.0, 10.0))
    line_out = entry_path(legs[1], legs[2], legs[3], None, 6.0, after_half_circle=False)
    assert line_out is not None and line_out.radius == pytest.approx(6.0)


def survey(tblock: TBlock, lead: str) -> Survey:
    task = build_task(tblock("Survey", ("InitialState", "ON"), ("Name", "S"),
                             ("Center", "70,-30"), ("A", "100"), ("B", "60"),
                             ("Spacing", "20"), ("Rotation", "90"), ("Lead", lead),
                             ("Thrust", "100"), ("TimeOut", "1000")))
    assert isinstance(task, Survey)
    return task


def fly(task, speed: float, *, tasks=(), limit: float = 60.0, tau: float = 0.2,
        dt: float = 0.1, max_t: float = 200.0) -> list[tuple[float, float]]:
    """A kinematic vehicle on the helm's output: full rudder (20°) a turn of 90 deg/s, the turn
    rate a lag of ``tau`` limited to ``limit`` deg/s; the track, one point a tick. ``tasks``:
    the chain after ``task``, each started when the one before completes."""
    x = y = 0.0
    heading, rate, t = 90.0, 0.0, 1.0
    track = []
    chain = [task, *tasks]
    task.start(0.0)
    while t < max_t and chain:
        votes = chain[0].step(nav_at(t, x=x, y=y, heading=heading % 360.0, speed=speed), t)
        if not chain[0].active:
            chain.pop(0)
            if chain:
                chain[0].start(t)
            continue
        want = (votes or {}).get("RUDDER", 0.0) / 20.0 * 90.0
        rate += (max(-limit, min(limit, want)) - rate) * min(1.0, dt / tau)
        heading += rate * dt
        x += speed * math.sin(math.radians(heading)) * dt
        y += speed * math.cos(math.radians(heading)) * dt
        track.append((x, y))
        t += dt
    return track


def damped(task):
    """The task with a derivative in its heading loop (the heading tasks' YAW_PID defaults):
    this kinematic boat has no delay, so KD only damps it, and the plan's geometry is seen
    clean. The product's line loop (LINE_PID KP 1.0, KD 0) suits the real SITL's delays
    (``test_the_line_loop_comes_out_of_the_u_turn_on_the_line``)."""
    task.gains = HelmGains(line_kp=0.75, line_kd=0.2)
    task.yaw_pid = task.heading_pid()
    return task


def worst_on_legs(track: list[tuple[float, float]]) -> float:
    """The largest |XTE| on legs 1-3 (y = -20, -40, -60, x 20..120) from 10 m along each to 5 m
    before its end (the benchmark's ``--window issue``)."""
    worst = 0.0
    for y0, lo, hi in ((-20.0, 25.0, 110.0), (-40.0, 30.0, 115.0), (-60.0, 25.0, 110.0)):
        on = [abs(y - y0) for x, y in track if lo <= x <= hi and abs(y - y0) < 5.0]
        worst = max(worst, *on)
    return worst


def test_a_survey_at_5_m_s_comes_out_of_each_u_turn_on_the_next_leg() -> None:
    """A kinematic boat at 5 m/s (Lead 7.5 m: each U-turn one half circle of 10 m)."""
    task = damped(survey(task_block, "7.5"))
    track = fly(task, 5.0)
    assert not task.active
    assert worst_on_legs(track) < 0.15
    assert max(x for x, _ in track) == pytest.approx(130.0, abs=1.0)   # beyond the legs' ends


def test_a_survey_at_2_m_s_turns_its_corners_on_arcs() -> None:
    task = survey(task_block, "3")
    track = fly(task, 2.0, max_t=400.0)
    assert not task.active
    assert worst_on_legs(track) < 0.15
    assert max(x for x, _ in track) < 120.5                         # corners cut inside


def test_chained_tracklines_fly_the_u_turn_as_a_survey_does(tblock: TBlock) -> None:
    corners = ["0,0", "100,0", "100,-20", "0,-20"]
    lines = [build_task(tblock("TrackLine", ("Name", f"T{k}"), ("P1", corners[k]),
                               ("P2", corners[k + 1]), ("Radius", "1"), ("Lead", "7.5"),
                               ("Thrust", "100"), ("TimeOut", "1000"),
                               *((("StartFlag", f"F{k}"),) if k else ()),
                               ("FinishFlag", f"F{k + 1}")))
             for k in range(3)]
    assert all(isinstance(t, TrackLine) for t in lines)
    link_track_lines(lines)
    lines = [damped(t) for t in lines]
    track = fly(lines[0], 5.0, tasks=lines[1:], max_t=60.0)
    assert max(x for x, _ in track) == pytest.approx(110.0, abs=1.0)   # the half circle
    on_leg = [abs(y + 20.0) for x, y in track if 5.0 <= x <= 90.0 and y < -15.0]
    assert on_leg and max(on_leg) < 0.15


def test_the_tunes_planned_turn_matches_the_helms() -> None:
    """``tuning`` may import only core: its restatement of the planned U-turn (which turns are
    planned, where each line is left, the entry paths and how they are flown) is the helm's."""
    from mavhelm.tuning import gains

    assert (gains.FIT, gains.U_TURN_LEADS) == (turn_plan.FIT, turn_plan.U_TURN_LEADS)
    speed, leg = 5.0, 600.0
    lag = TURN_LAG_S * speed
    leads = np.array([1.0, 3.0, 4.0, 5.0, 7.5, 10.0, 20.0, 25.0])
    one, leave, entries = gains._u_turn_plan(leads, leg, lag)
    corners = [(-leg, 0.0), (0.0, 0.0), (0.0, -gains.JOIN), (-leg, -gains.JOIN)]
    rng = np.random.default_rng(1)
    for i, lead in enumerate(leads):
        assert one[i] == is_u_turn(*corners, float(lead))
        helm_leave = [turn_plan.turn_in(*corners, float(lead), lag, on_half_circle=False),
                      turn_plan.turn_in(*corners[1:], None, float(lead), lag,
                                        on_half_circle=bool(one[i]))]
        assert [leave[0][i], leave[1][i]] == pytest.approx(helm_leave)
        helm_entries = [entry_path(*corners, float(lead), after_half_circle=False),
                        entry_path(*corners[1:], None, float(lead),
                                   after_half_circle=bool(one[i]))]
        for arcs, helm in zip(entries[1:], helm_entries, strict=True):
            assert arcs is not None
            if helm is None:
                assert one[i]
                continue
            ours = Arc((arcs.sx[i], arcs.sy[i]), (arcs.ex[i], arcs.ey[i]),
                       (arcs.cx[i], arcs.cy[i]), arcs.radius[i], arcs.heading_in[i],
                       arcs.sweep[i])
            assert _same_arc(ours, helm)
            points = rng.uniform(-15.0, 15.0, (40, 2)) + np.array(helm.centre)
            aim, s, xte = gains._arc_heading(_one(arcs, i, len(points)), points[:, 0],
                                             points[:, 1], np.full(len(points), lead), lag)
            for k, p in enumerate(points):
                want_s, want_xte = helm.locate((p[0], p[1]))
                want_aim, _ = helm.heading((p[0], p[1]), float(lead), lag)
                assert (s[k], xte[k]) == pytest.approx((want_s, want_xte), abs=1e-6)
                assert (aim[k] - want_aim + 180.0) % 360.0 - 180.0 == pytest.approx(0.0,
                                                                                  abs=1e-6)


def _same_arc(a: Arc, b: Arc) -> bool:
    fields = ("start", "end", "centre")
    return all(np.allclose(getattr(a, f), getattr(b, f)) for f in fields) and \
        math.isclose(a.radius, b.radius) and math.isclose(a.sweep, b.sweep) and \
        math.isclose(a.heading_in % 360.0, b.heading_in % 360.0)


def _one(arcs, i: int, n: int):
    """Candidate i's arc, repeated n times (one per sample point)."""
    from mavhelm.tuning import gains
    return gains._Arcs(*(np.full(n, getattr(arcs, f)[i]) for f in (
        "sx", "sy", "ex", "ey", "cx", "cy", "radius", "heading_in", "sweep")))


@pytest.mark.parametrize("where, planned", [((100.0, -2.0), True), ((60.0, -30.0), False)])
def test_a_chained_trackline_started_far_from_its_planned_turn_flies_its_line(
        tblock: TBlock, where, planned: bool) -> None:
    first = build_task(tblock("TrackLine", ("Name", "A"), ("P1", "0,0"), ("P2", "100,0"),
                              ("FinishFlag", "Next")))
    then = build_task(tblock("TrackLine", ("Name", "B"), ("P1", "100,0"), ("P2", "100,-50"),
                             ("StartFlag", "Next"), ("Lead", "5")))
    assert isinstance(first, TrackLine) and isinstance(then, TrackLine)
    link_track_lines([first, then])
    first.last_flown = FlownLine((0.0, 0.0), (100.0, 0.0))     # the first line, flown to its end
    then.start(0.0)
    then.step(nav_at(1.0, x=where[0], y=where[1], heading=180.0, speed=2.0), 1.0)
    assert then.follower is not None
    assert (then.follower.entry is not None) == planned


def test_past_a_u_turns_half_circle_the_join_is_done() -> None:
    """The half circle ends at the join's end: a vehicle past it, still more than the capture
    radius from that end, is on the line out, and is not steered along the join (square off
    the line out: full rudder the wrong way, 1.5 m wide at 5 m/s on a kinematic boat)."""
    join = LineFollower((120.0, 0.0), (120.0, -20.0), 7.5)
    join.entry = u_turn_arc((20.0, 0.0), (120.0, 0.0), (120.0, -20.0))
    past = (119.6, -19.0)                       # 1.1 m from the join's end, 19 m along it
    assert join.entry.done(past)
    assert join.reached(past, 1.0)
    halfway = (130.0, -10.0)
    assert not join.reached(halfway, 1.0)
    corner = LineFollower((0.0, 0.0), (100.0, 0.0), 7.5)   # a corner's arc ends on the line
    corner.entry = corner_arc((0.0, 50.0), (0.0, 0.0), (100.0, 0.0), 7.5)
    assert corner.entry is not None and corner.entry.done((8.0, 0.1))
    assert not corner.reached((8.0, 0.1), 1.0)


def test_the_line_loop_comes_out_of_the_u_turn_on_the_line() -> None:
    """The product's line loop, LINE_PID KP 1.0 with no KD (the real SITL boats' best), on the
    kinematic boat at 5 m/s: before the join was done past its half circle, it left the half
    circle 1.1 m from the join's end and swung 0.93 m."""
    task = survey(task_block, "7.5")
    assert (task.yaw_pid.kp, task.yaw_pid.kd) == (1.0, 0.0)
    assert worst_on_legs(fly(task, 5.0)) < 0.3
