"""Chained TrackLines turn in to the next line, and the lead is a lead time
(mavhelm.tasks.trackline: ``link_track_lines``, ``RouteTask.current_lead``)."""

from __future__ import annotations

import math

import pytest

from mavhelm.tasks.registry import build_task
from mavhelm.tasks.trackline import (
    DEFAULT_LEAD_TIME,
    MIN_LEAD,
    TURN_LAG_S,
    TrackLine,
    link_track_lines,
)
from tests.support.task_rig import TBlock, nav_at


def line(tblock: TBlock, name: str, p1: str, p2: str, *pairs: tuple[str, str]) -> TrackLine:
    task = build_task(tblock("TrackLine", ("Name", name), ("P1", p1), ("P2", p2),
                             ("Radius", "1"), *pairs))
    assert isinstance(task, TrackLine)
    return task


def chain(tblock: TBlock, *extra: tuple[str, str]) -> tuple[TrackLine, TrackLine]:
    """East along y = 0 to (100, 0), then a 90° turn south to (100, -50)."""
    first = line(tblock, "A", "0,0", "100,0", ("FinishFlag", "Next"), *extra)
    then = line(tblock, "B", "100,0", "100,-50", ("StartFlag", "Next"), *extra)
    return first, then


def drive_east(task: TrackLine, until_x: float, speed: float = 2.0, dt: float = 0.1) -> float:
    """Step the task with the vehicle running east along y = 0; the x where it completes."""
    t, x = 1.0, 0.0
    while x < until_x:
        task.step(nav_at(t, x=x, y=0.0, heading=90.0), t)
        if not task.active:
            return x
        t += dt
        x += speed * dt
    return math.inf


def test_a_chained_trackline_knows_the_next_line_and_shares_the_speed(tblock: TBlock) -> None:
    first, then = chain(tblock)
    link_track_lines([first, then])
    assert first.next_point == (100.0, -50.0) and then.next_point is None
    assert then.speedometer is first.speedometer is not None


def test_a_chained_trackline_is_left_a_turn_in_before_its_end(tblock: TBlock) -> None:
    first, then = chain(tblock)
    link_track_lines([first, then])
    first.start(0.0)
    x = drive_east(first, 100.0)
    # Lead = LeadTime × 2 m/s = 3 m; a 90° turn on an arc of one Lead: Lead · tan(45°) = 3 m
    # before the corner, and the heading loop's lag run earlier (turn_plan.turn_in)
    lead = DEFAULT_LEAD_TIME * 2.0
    assert x == pytest.approx(100.0 - lead - TURN_LAG_S * 2.0, abs=0.25)


def test_onto_a_longer_line_the_turn_is_asked_for_a_lag_earlier(tblock: TBlock) -> None:
    first = line(tblock, "A", "0,0", "100,0", ("FinishFlag", "Next"))
    then = line(tblock, "B", "100,0", "100,-500", ("StartFlag", "Next"))
    link_track_lines([first, then])
    first.start(0.0)
    x = drive_east(first, 100.0)
    assert x == pytest.approx(100.0 - DEFAULT_LEAD_TIME * 2.0 - TURN_LAG_S * 2.0, abs=0.25)


@pytest.mark.parametrize("p1, flags", [("100,5", ("Next",)), ("100,0", ("Next", "Next2"))])
def test_no_link_unless_one_line_continues_from_p2(tblock: TBlock, p1: str, flags) -> None:
    first = line(tblock, "A", "0,0", "100,0", ("FinishFlag", "Next"), ("FinishFlag", "Next2"))
    others = [line(tblock, f"B{k}", p1, "100,-50", ("StartFlag", flag))
              for k, flag in enumerate(flags)]
    link_track_lines([first, *others])
    assert first.next_point is None
    first.start(0.0)
    assert drive_east(first, 101.0) == pytest.approx(99.0, abs=0.25)  # its Radius, 1 m


def test_the_lead_is_lead_time_times_the_speed(tblock: TBlock) -> None:
    task = line(tblock, "A", "0,0", "1000,0", ("LeadTime", "2"))
    task.start(0.0)
    assert task.current_lead() == MIN_LEAD, "no speed measured yet: the shortest lead"
    drive_east(task, 20.0, speed=4.0)
    assert task.current_lead() == pytest.approx(8.0)
    fixed = line(tblock, "F", "0,0", "1000,0", ("Lead", "6"), ("LeadTime", "2"))
    fixed.start(0.0)
    drive_east(fixed, 20.0, speed=4.0)
    assert fixed.current_lead() == 6.0, "a Lead given is kept whatever the speed"


@pytest.mark.parametrize("dip", [False, True])
def test_a_u_turn_held_near_its_corner_stays_one_half_circle(tblock: TBlock, dip: bool) -> None:
    """A U-turn over a 20 m join is one half circle at 4 m/s (Lead 6 m) and two corners below
    3.3 m/s. A fix stamped late drops the speed measured by a fifth for one tick: near the
    corner the plan stays a half circle (the two corners' turn would already have started
    behind the vehicle), the line is left at the half circle's turn-in, and the join is
    entered by its half circle."""
    first = line(tblock, "A", "0,0", "100,0", ("FinishFlag", "Join"))
    join = line(tblock, "B", "100,0", "100,-20", ("StartFlag", "Join"), ("FinishFlag", "Back"))
    back = line(tblock, "C", "100,-20", "0,-20", ("StartFlag", "Back"))
    link_track_lines([first, join, back])
    first.start(0.0)
    t, x, dt, speed = 1.0, 60.0, 0.2, 4.0
    left_at = math.inf
    while x < 100.0:
        stamp = t + (0.25 if dip and x > 95.0 else 0.0)   # one fix heard 0.25 s late
        first.step(nav_at(stamp, x=x, y=0.0, heading=90.0), stamp)
        if not first.active:
            left_at = x
            break
        t += dt
        x += speed * dt
    assert first.u_turn_held
    lag = TURN_LAG_S * 4.0
    assert 100.0 - left_at <= lag + speed * dt
    join.start(t)
    join.step(nav_at(t, x=left_at, y=0.0, heading=90.0), t)
    assert join.follower is not None and join.follower.entry is not None
    assert join.follower.entry.radius == pytest.approx(10.0)        # the half circle
