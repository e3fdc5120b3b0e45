"""Survey's turns: the line to each corner, a leg's start or its end, is left a turn-in
before it (mavhelm.tasks.trackline, "The turn onto a line")."""

from __future__ import annotations

import math

import pytest

from mavhelm.tasks import turn_plan
from mavhelm.tasks.registry import build_task
from mavhelm.tasks.survey import CAPTURE, Survey
from mavhelm.tasks.trackline import LineFollower
from tests.support.task_rig import TBlock


def survey(tblock: TBlock, lead: str = "5") -> Survey:
    task = build_task(tblock("Survey", ("InitialState", "ON"), ("Name", "T"),
                             ("Center", "0,40"), ("A", "50"), ("B", "20"), ("Spacing", "10"),
                             ("Rotation", "90"), ("Lead", lead)))
    assert isinstance(task, Survey)
    return task


@pytest.mark.parametrize("lead, expected", [("5", CAPTURE), ("3", CAPTURE), ("20", 5.0)])
def test_a_leg_start_and_a_leg_end_are_turned_in_to(tblock: TBlock, lead, expected):
    task = survey(tblock, lead)
    # on the join from leg 0's end (25, 50) to leg 1's start (25, 40): a 90° turn onto leg 1
    task.index = 2
    task.follower = LineFollower(task.target(1), task.target(2), task.lead)
    # the arc's turn-in, Lead · tan(45°), at most half the 10 m join (no speed: no lag);
    # with Lead 3 or 5 the join is a U-turn's (half of it within 0.5-2 Leads), entered by one
    # half circle beyond the legs' ends that ends on leg 1: the join is flown to its end
    task.follower.entry = turn_plan.entry_path(*(task.target(k) for k in range(4)),
                                               float(lead), after_half_circle=False)
    assert turn_plan.is_half_circle(task.follower.entry) == (expected == CAPTURE)
    assert task.capture_radius(2) == pytest.approx(expected)
    # on leg 1 itself: the 90° turn onto the join to leg 2, as far (the join is 10 m)
    task.index = 3
    task.follower = LineFollower(task.target(2), task.target(3), task.lead)
    assert task.capture_radius(3) == pytest.approx(expected)


def test_no_turn_in_at_the_last_target_or_straight_on(tblock: TBlock):
    task = survey(tblock)
    last = 5  # leg 2's end
    task.follower = LineFollower(task.target(last - 1), task.target(last), task.lead)
    assert task.turn_in(last) == 0.0
    # the approach from the start straight onto leg 0: no turn, no turn-in
    start = task.target(0)
    behind = (start[0] - 10.0, start[1])
    task.follower = LineFollower(behind, start, task.lead)
    assert task.turn_in(0) == 0.0
    assert math.isclose(task.capture_radius(0), CAPTURE)
