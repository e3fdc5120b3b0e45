"""The heading watch at a start from rest (issue 15's false doubt at 6.9 s): position data
that disagree before the vehicle has moved for ``STILL_TIME`` tell of the filter's speed
catching up with the vehicle's, not of the heading, and doubt nothing; once under way they do.
A heading that goes wrong slowly is still doubted, by the longer look back."""

from __future__ import annotations

from mavhelm.nav.heading_watch import (
    DOUBT_LONG_NIS,
    DOUBT_LONG_WINDOW,
    DOUBT_NIS,
    DOUBT_WINDOW,
    STILL_SPEED,
    STILL_TIME,
    HeadingWatch,
)

TICK = 0.1


def _drive(watch: HeadingWatch, t0: float, seconds: float, speed: float, nis: float) -> int:
    """Ten ticks a second at ``speed``, a position reading of ``nis`` each; the doubts."""
    before = watch.doubts
    for k in range(round(seconds / TICK)):
        t = t0 + k * TICK
        watch.position(t, nis)
        watch.motion(t, speed)
    return watch.doubts - before


def test_disagreeing_position_data_while_starting_from_rest_doubt_nothing() -> None:
    for bias in (True, False):
        watch = HeadingWatch(estimates_bias=bias)
        assert _drive(watch, 0.0, 5.0, 0.0, 0.3) == 0  # at rest
        # under way, the filter's speed trailing the vehicle's: ranges far off
        assert _drive(watch, 5.0, STILL_TIME - 2 * TICK, 2.0, 10.0) == 0
        assert not watch.course_defined(5.0 + STILL_TIME - 2 * TICK)


def test_once_under_way_the_same_data_doubt_the_heading() -> None:
    watch = HeadingWatch(estimates_bias=False)
    _drive(watch, 0.0, STILL_TIME + 1.0, 2.0, 0.3)
    assert watch.course_defined(STILL_TIME + 1.0)
    assert _drive(watch, STILL_TIME + 1.0, DOUBT_WINDOW * TICK, 2.0, 10.0) == 1


def test_a_stop_takes_the_course_away_until_the_vehicle_has_moved_again() -> None:
    watch = HeadingWatch(estimates_bias=True)
    _drive(watch, 0.0, 2 * STILL_TIME, 2.0, 0.3)
    assert watch.course_defined(2 * STILL_TIME)
    _drive(watch, 2 * STILL_TIME, 1.0, STILL_SPEED / 2, 0.3)  # stopped
    assert not watch.course_defined(2 * STILL_TIME + 1.0)
    assert _drive(watch, 2 * STILL_TIME + 1.0, STILL_TIME - 2 * TICK, 2.0, 10.0) == 0


def test_a_slow_sustained_disagreement_is_doubted_by_the_longer_look_back() -> None:
    mild = (DOUBT_LONG_NIS + DOUBT_NIS) / 2  # beyond the long window's, short of the short's
    watch = HeadingWatch(estimates_bias=True)
    _drive(watch, 0.0, STILL_TIME, 2.0, 0.3)  # under way from the next reading on
    start = STILL_TIME
    assert _drive(watch, start, (DOUBT_LONG_WINDOW - 1) * TICK, 2.0, mild) == 0
    assert _drive(watch, start + (DOUBT_LONG_WINDOW - 1) * TICK, 5 * TICK, 2.0, mild) == 1
    calm = HeadingWatch(estimates_bias=True)
    _drive(calm, 0.0, STILL_TIME + 1.0, 2.0, 0.3)
    assert _drive(calm, start, 10 * DOUBT_LONG_WINDOW * TICK, 2.0, 1.0) == 0


def test_without_a_bias_state_the_motion_is_watched_but_nothing_is_said() -> None:
    watch = HeadingWatch(estimates_bias=False)
    said = [watch.motion(k * TICK, 2.0) for k in range(round(2 * STILL_TIME / TICK))]
    assert said == [None] * len(said) and watch.course_defined(2 * STILL_TIME)
