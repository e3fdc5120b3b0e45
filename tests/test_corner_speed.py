"""The slow-down for a sharp corner (mavhelm.tasks.corner_speed): how slow, how early, and that
routes with corners up to 90° and a survey's U-turns fly at full thrust as before."""

from __future__ import annotations

import math

import pytest

from mavhelm.tasks import corner_speed
from mavhelm.tasks.corner_speed import braking_distance, fraction
from mavhelm.tasks.registry import build_task
from mavhelm.tasks.survey import Survey
from mavhelm.tasks.trackline import DEFAULT_LEAD_TIME, MIN_LEAD, TrackLine, link_track_lines
from mavhelm.tasks.turn_plan import corner_arc
from tests.support.routes import held_xte, zigzag
from tests.support.task_rig import TBlock, nav_at, task_block


def test_corners_up_to_90_degrees_are_not_slowed_for() -> None:
    for turn in (0.0, 45.0, 90.0, 90.9):
        assert fraction(turn, 5.0, DEFAULT_LEAD_TIME, MIN_LEAD) == 1.0


@pytest.mark.parametrize("turn", [100.0, 120.0, 135.0])
def test_the_slowed_arc_is_no_further_off_the_line_in_than_a_right_angles(turn: float) -> None:
    """At cot²(Δ/2) of the speed the arc starts Lead · cot(Δ/2) before the corner, and is off
    the line in no more than a 90° corner's arc at full speed, at every distance before the
    corner (exactly, not only to the parabola's approximation, until the sharp arc has turned
    90°)."""
    lead = DEFAULT_LEAD_TIME * 5.0
    share = fraction(turn, 5.0, DEFAULT_LEAD_TIME, MIN_LEAD)
    assert share == pytest.approx(1.0 / math.tan(math.radians(turn) / 2.0) ** 2)
    p0, p1 = (0.0, 0.0), (0.0, 60.0)
    p2 = (60.0 * math.sin(math.radians(turn)), 60.0 + 60.0 * math.cos(math.radians(turn)))
    sharp = corner_arc(p0, p1, p2, lead * share)
    square = corner_arc(p0, p1, (60.0, 60.0), lead)
    assert sharp is not None and square is not None
    assert sharp.turn_in == pytest.approx(lead / math.tan(math.radians(turn) / 2.0))
    for k in range(1, 40):
        d = sharp.turn_in * k / 40.0                     # metres before the corner
        s = sharp.turn_in - d                            # along the sharp arc's start
        if s > sharp.radius:
            break
        off_sharp = sharp.radius - math.sqrt(sharp.radius ** 2 - s * s)
        s90 = max(0.0, square.turn_in - d)
        off_square = square.radius - math.sqrt(square.radius ** 2 - s90 * s90)
        assert off_sharp <= off_square + 1e-9


def test_the_slowest_is_the_shortest_lead_or_the_floor() -> None:
    # at 2 m/s the shortest Lead (1 m) is had at a third of the speed
    assert fraction(160.0, 2.0, DEFAULT_LEAD_TIME, MIN_LEAD) == pytest.approx(1.0 / 3.0)
    assert fraction(160.0, 5.0, DEFAULT_LEAD_TIME, MIN_LEAD) == corner_speed.MIN_FRACTION
    assert fraction(180.0, 5.0, DEFAULT_LEAD_TIME, MIN_LEAD) == corner_speed.MIN_FRACTION
    assert fraction(135.0, 0.0, DEFAULT_LEAD_TIME, MIN_LEAD) == 1.0       # at rest


def test_braking_distance_is_the_lag_then_a_steady_deceleration() -> None:
    a, lag = corner_speed.DECELERATION, corner_speed.SPEED_LAG_S
    assert braking_distance(5.0, 1.0) == pytest.approx(5.0 * lag + (25.0 - 1.0) / (2 * a))
    assert braking_distance(2.0, 2.0) == 0.0
    assert braking_distance(1.0, 2.0) == 0.0


# ---- flown: a kinematic boat whose speed follows the thrust --------------------------------

def chain(tblock: TBlock, points: list[tuple[float, float]]) -> list[TrackLine]:
    lines = []
    for k in range(len(points) - 1):
        (x1, y1), (x2, y2) = points[k], points[k + 1]
        task = build_task(tblock("TrackLine", ("Name", f"T{k}"), ("P1", f"{x1},{y1}"),
                                 ("P2", f"{x2},{y2}"), ("Radius", "1"), ("Thrust", "100"),
                                 ("TimeOut", "1000"),
                                 *((("StartFlag", f"F{k}"),) if k else ()),
                                 ("FinishFlag", f"F{k + 1}")))
        assert isinstance(task, TrackLine)
        lines.append(task)
    link_track_lines(lines)
    return lines


def fly(tasks, cruise: float, *, limit: float = 60.0, tau: float = 0.2, dt: float = 0.1,
        max_t: float = 300.0) -> list[tuple[int, bool, float, float, float, float]]:
    """The helm's output flown: the turn rate (full rudder 90 deg/s) a lag of ``tau`` limited
    to ``limit`` deg/s, the speed thrust × ``cruise`` ramped at ``DECELERATION`` (as Rover's
    speed target is). One (task, on its entry arc, x, y, speed, thrust) a tick."""
    x = y = 0.0
    heading, rate, speed, t = 90.0, 0.0, cruise, 1.0
    ramp = corner_speed.DECELERATION * dt
    track = []
    chain = list(tasks)
    done = 0
    chain[0].start(0.0)
    while t < max_t and chain:
        votes = chain[0].step(nav_at(t, x=x, y=y, heading=heading % 360.0, speed=speed), t)
        if not chain[0].active:
            chain.pop(0)
            done += 1
            if chain:
                chain[0].start(t)
            continue
        votes = votes or {}
        thrust = votes.get("THRUST", 0.0)
        follower = chain[0].follower
        track.append((done, follower is not None and follower.entry is not None, x, y, speed,
                      thrust))
        want = votes.get("RUDDER", 0.0) / 20.0 * 90.0
        rate += (max(-limit, min(limit, want)) - rate) * min(1.0, dt / tau)
        speed += max(-ramp, min(ramp, thrust / 100.0 * cruise - speed))
        heading += rate * dt
        x += speed * math.sin(math.radians(heading)) * dt
        y += speed * math.cos(math.radians(heading)) * dt
        t += dt
    return track


def worst_in_window(track, points) -> float:
    """The largest |XTE| in the held part of any line (``routes.held_xte``); infinite where a
    line was never held."""
    worst = held_xte([(x, y) for _, _, x, y, _, _ in track], points)
    return max(math.inf if w is None else w[1] for w in worst)


@pytest.mark.parametrize("turn, cruise", [(45.0, 5.0), (90.0, 2.0), (90.0, 5.0)])
def test_corners_up_to_90_degrees_fly_at_full_thrust(turn: float, cruise: float) -> None:
    points = zigzag(turn)
    track = fly(chain(task_block, points), cruise)
    assert track[-1][0] == len(points) - 2                  # flown to the last line
    assert {thrust for *_, thrust in track} == {100.0}


@pytest.mark.parametrize("cruise", [2.0, 5.0])
def test_a_surveys_u_turns_fly_at_full_thrust(cruise: float) -> None:
    task = build_task(task_block("Survey", ("InitialState", "ON"), ("Name", "S"),
                                 ("Center", "70,-30"), ("A", "100"), ("B", "60"),
                                 ("Spacing", "20"), ("Rotation", "90"), ("Thrust", "100"),
                                 ("TimeOut", "1000")))
    assert isinstance(task, Survey)
    thrusts = []
    x = y = 0.0
    heading, t = 90.0, 1.0
    task.start(0.0)
    while task.active and t < 400.0:       # flown exactly, the votes are what is checked
        votes = task.step(nav_at(t, x=x, y=y, heading=heading, speed=cruise), t) or {}
        thrusts.append(votes.get("THRUST"))
        follower = task.follower
        if follower is not None:
            heading = follower.heading((x, y), t)
        x += cruise * math.sin(math.radians(heading)) * 0.1
        y += cruise * math.cos(math.radians(heading)) * 0.1
        t += 0.1
    assert not task.active
    assert set(thrusts) - {None} == {100.0}


@pytest.mark.parametrize("turn, cruise, before, after", [
    (135.0, 5.0, 2.0, 0.3), (135.0, 2.0, 0.5, 0.2), (160.0, 5.0, 4.0, 2.5)])
def test_a_sharp_corner_is_slowed_for_and_flown_tight(monkeypatch, turn: float, cruise: float,
                                                      before: float, after: float) -> None:
    points = zigzag(turn)
    slowed = fly(chain(task_block, points), cruise)
    assert slowed[-1][0] == len(points) - 2
    assert worst_in_window(slowed, points) < after
    share = fraction(turn, cruise, DEFAULT_LEAD_TIME, MIN_LEAD)
    assert min(thrust for *_, thrust in slowed) == pytest.approx(100.0 * share)
    # the speed is down to the corner's before the turn off the first leg starts ...
    first_arc = next(i for i, (task, on_arc, *_) in enumerate(slowed) if task == 2 and on_arc)
    assert slowed[first_arc][4] <= 1.1 * share * cruise
    # ... and back to full thrust once on the next line
    off_arc = next(i for i in range(first_arc, len(slowed)) if not slowed[i][1])
    assert slowed[off_arc][5] == 100.0
    monkeypatch.setattr(corner_speed, "fraction", lambda *_: 1.0)
    unslowed = fly(chain(task_block, points), cruise)
    assert worst_in_window(unslowed, points) > before


@pytest.mark.parametrize("thrust, lead", [(None, None), ("100", "7.5")])
def test_a_line_that_cannot_slow_leaves_the_line_where_its_turn_starts(thrust, lead) -> None:
    """Steering only (no Thrust of its own), or with a fixed Lead, a TrackLine is not slowed
    and its turn-in is the one at the speed measured."""
    pairs = [*((("Thrust", thrust),) if thrust else ()), *((("Lead", lead),) if lead else ())]
    points = zigzag(135.0)[1:4]
    first, then = (build_task(task_block("TrackLine", ("Name", f"T{k}"),
                                         ("P1", "{},{}".format(*points[k])),
                                         ("P2", "{},{}".format(*points[k + 1])),
                                         *pairs, ("FinishFlag", f"F{k + 1}"),
                                         *((("StartFlag", "F1"),) if k else ())))
                   for k in range(2))
    assert isinstance(first, TrackLine) and isinstance(then, TrackLine)
    link_track_lines([first, then])
    first.start(0.0)
    for i in range(12):
        t = 1.0 + 0.5 * i
        votes = first.step(nav_at(t, x=20.0 + 2.5 * i, y=0.0, heading=90.0, speed=5.0), t)
        assert (votes or {}).get("THRUST") == (100.0 if thrust else None)
    assert first.corner_speed() is None
    assert first.turn_in(0) == pytest.approx(first.turn_in(0, 5.0))
