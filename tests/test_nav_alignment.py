"""The heading from the motion (``mavhelm.nav.alignment``): runs made good between fixes give
the correction an orientation sensor's bias needs, whatever its size; turns, going astern and
crabbing give none."""

from __future__ import annotations

import itertools
import math
import random

import pytest

from mavhelm.nav.alignment import SAMPLES, MotionAlignment


def _straight(a: MotionAlignment, heading_deg: float, offset_deg: float, seconds: float,
              *, t0: float = 0.0, bias_deg: float = 0.0, speed: float = 1.5,
              drift_deg_s: float = 0.0, held: bool = False, fix_noise: float = 0.0,
              seed: int = 0) -> float:
    """Drive straight on ``heading_deg``: a fix every 2 s (its error ``fix_noise`` m, 1-σ),
    the sensor reading the heading plus ``offset_deg`` (+ drift) at 10 Hz, the filter holding
    ``bias_deg`` (+ the same drift) and following the sensor, or, when ``held``, holding the
    true heading (taken from the motion while it refuses the sensor)."""
    rng = random.Random(seed)
    h = math.radians(heading_deg)
    t = t0
    while t < t0 + seconds:
        drift = drift_deg_s * t
        yaw = -math.radians(heading_deg + offset_deg + drift)
        a.add_heading(t, yaw, -math.radians(bias_deg + drift), -h if held else None)
        if round(t * 10) % 20 == 0:
            d = speed * t
            a.add_fix(t, d * math.sin(h) + rng.gauss(0.0, fix_noise),
                      d * math.cos(h) + rng.gauss(0.0, fix_noise))
        t = round(t + 0.1, 6)
    return t


def test_a_sensor_turned_round_is_found_from_the_runs() -> None:
    a = MotionAlignment()
    _straight(a, 60.0, 180.0, 40.0)
    found = a.estimate()
    assert found is not None and found.runs >= SAMPLES
    # the sensor reads 180° clockwise of the heading: its yaw, and the bias needed, is −180°
    assert abs(math.degrees(math.remainder(found.correction - math.pi, 2 * math.pi))) < 0.5
    assert found.velocity == pytest.approx((1.5 * math.sin(math.radians(60)),
                                            1.5 * math.cos(math.radians(60))), abs=1e-6)


def test_a_bias_the_filter_holds_leaves_no_correction_even_while_it_drifts() -> None:
    a = MotionAlignment()
    _straight(a, 200.0, 90.0, 40.0, bias_deg=90.0, drift_deg_s=0.6)
    found = a.estimate()
    assert found is not None and abs(math.degrees(found.correction)) < 0.5


def test_a_steady_offset_is_taken_whole_while_the_filter_learns_its_bias() -> None:
    """The sensor 117° out from the start (clockwise), the filter learning its bias from
    position fixes meanwhile, 47° of it in 30 s: the bias it needs is the sensor's raw
    offset from the courses, not the runs' corrections (each against the bias held then)
    added to the bias now, which counted the 47° twice (−150°; the simulator's box patrol,
    its compass out, turned 35° wrong)."""
    a = MotionAlignment()
    h = math.radians(30.0)
    learned = 0.0
    for k in range(401):
        t = 0.1 * k
        learned = -math.radians(47.0) * min(t, 30.0) / 30.0  # learned as the filter goes
        a.add_heading(t, -h - math.radians(117.0), learned)
        if k % 20 == 0:
            a.add_fix(t, 1.5 * t * math.sin(h), 1.5 * t * math.cos(h))
    found = a.estimate()
    assert found is not None and found.told
    needed = math.degrees(math.remainder(learned + found.correction, 2 * math.pi))
    assert needed == pytest.approx(-117.0, abs=1.0)


def test_a_turn_going_astern_or_crabbing_gives_no_run() -> None:
    def circle(radius: float) -> MotionAlignment:
        """Round a circle at 2 m/s, clockwise, the sensor reading 30° more than the heading."""
        turning = MotionAlignment()
        for k in range(600):
            t = 0.1 * k
            a = 2.0 / radius * t
            turning.add_heading(t, -(a + math.pi / 2 + math.radians(30.0)))
            if k % 20 == 0:
                turning.add_fix(t, radius * math.sin(a), radius * math.cos(a) - radius)
        return turning

    assert circle(5.0).estimate() is None       # 23 deg/s: no run is straight enough
    gentle = circle(20.0).estimate()            # 5.7 deg/s: a chord's course is the mean heading
    assert gentle is not None
    assert math.degrees(gentle.correction) == pytest.approx(-30.0, abs=0.5)
    astern = MotionAlignment()
    for k in range(400):
        astern.add_body_velocity(0.1 * k, -1.5, 0.0)
    _straight(astern, 0.0, 180.0, 40.0)
    assert astern.estimate() is None
    crabbing = MotionAlignment()
    for k in range(400):
        crabbing.add_body_velocity(0.1 * k, 0.5, 0.6)
    _straight(crabbing, 0.0, 0.0, 40.0)
    assert crabbing.estimate() is None


def test_runs_that_disagree_make_no_estimate_and_old_ones_are_forgotten() -> None:
    a = MotionAlignment()
    end = _straight(a, 0.0, 90.0, 20.0)
    _straight(a, 90.0, -90.0, 20.0, t0=end)      # a sensor that jumped by 180° midway
    assert a.estimate() is None
    _straight(a, 90.0, -90.0, 120.0, t0=end + 20.0)   # long after, only the new runs count
    found = a.estimate()
    assert found is not None and abs(math.degrees(found.correction) - 90.0) < 0.5
    a.clear()
    assert a.estimate() is None


def test_fixes_that_move_while_the_odometry_stands_still_make_no_run() -> None:
    """Standing still, LSQ fixes thrown about by range outliers can lie 8 m apart in one
    direction again and again: a run only counts as far as the body velocity says the
    vehicle went; without body-velocity data the fixes are taken as they come."""
    still = MotionAlignment()
    moving = MotionAlignment()
    for k in range(400):
        still.add_body_velocity(0.1 * k, 0.0, 0.0)
        moving.add_body_velocity(0.1 * k, 1.5, 0.0)
    _straight(still, 0.0, 40.0, 40.0)
    _straight(moving, 0.0, 40.0, 40.0)
    assert still.estimate() is None
    found = moving.estimate()
    assert found is not None and math.degrees(found.correction) == pytest.approx(-40.0, abs=0.5)
    unmeasured = MotionAlignment()
    _straight(unmeasured, 0.0, 40.0, 40.0)
    assert unmeasured.estimate() is not None


def test_an_offset_short_of_turned_round_must_be_seen_to_last_without_a_gap() -> None:
    """40° off (not turned round): runs over 40 s straight make an estimate; runs as long
    apart but with 25 s of silence between them (a turn, no fixes) do not, nor do the runs
    after the silence alone (a kick of the compass lasting 10 s)."""
    steady = MotionAlignment()
    _straight(steady, 0.0, 40.0, 40.0)
    found = steady.estimate()
    assert found is not None and math.degrees(found.correction) == pytest.approx(-40.0, abs=0.5)
    broken = MotionAlignment()
    end = _straight(broken, 0.0, 40.0, 10.0)
    _straight(broken, 0.0, 40.0, 10.0, t0=end + 25.0)
    assert broken.estimate() is None


def test_runs_need_not_last_once_the_fixes_said_the_filter_is_off() -> None:
    """40° off for 12 s of runs: not long enough to be told from a kick, unless position
    fixes refused in a row said the filter itself is off (the fix watch), as a filter
    steering by a sensor out from the start is at once."""
    short = MotionAlignment()
    _straight(short, 0.0, 40.0, 20.0)
    assert short.estimate() is None
    told = MotionAlignment()
    end = _straight(told, 0.0, 40.0, 15.0)
    told.filter_off(end)
    _straight(told, 0.0, 40.0, 5.0, t0=end)
    found = told.estimate()
    assert found is not None and found.told
    assert math.degrees(found.correction) == pytest.approx(-40.0, abs=0.5)
    told.clear()
    _straight(told, 0.0, 40.0, 20.0, t0=end + 10.0)
    assert told.estimate() is None  # used: the next estimate waits again


def test_a_stale_bias_is_told_from_the_heading_the_filter_held_across_gaps() -> None:
    """The filter held its heading from the motion while it refused a sensor now 100° off
    (its bias went stale): fixes 2 m apart in error put the courses tens of degrees out, and
    a 25 s silence splits the runs, so the correction itself is not told; the sensor's
    offset from the heading held is, to a degree."""
    a = MotionAlignment()
    end = _straight(a, 30.0, 100.0, 12.0, held=True, fix_noise=2.0, seed=1)
    _straight(a, 30.0, 100.0, 16.0, t0=end + 25.0, held=True, fix_noise=2.0, seed=2)
    found = a.estimate()
    assert found is not None and not found.told
    assert math.degrees(found.stale) == pytest.approx(-100.0, abs=1.0)  # yaw = −heading
    assert math.degrees(found.stale_spread) < 1.0
    assert math.degrees(found.spread) > math.degrees(found.stale_spread) + 5.0
    assert abs(math.degrees(found.heading_error)) < 20.0


def test_a_kick_the_filter_refused_is_no_stale_bias() -> None:
    """A compass kicked 60° for 15 s, refused while the filter held its heading: its runs
    agree, but no offset that lasts ``MIN_SPAN`` is in them; a filter that followed the
    sensor has no offset from it at all."""
    kicked = MotionAlignment()
    end = _straight(kicked, 30.0, 0.0, 20.0, held=True)
    _straight(kicked, 30.0, 60.0, 15.0, t0=end, held=True)
    assert kicked.estimate() is None
    followed = MotionAlignment()
    end = _straight(followed, 30.0, 0.0, 12.0, bias_deg=0.0)
    _straight(followed, 30.0, 0.0, 16.0, t0=end + 25.0)
    assert followed.estimate() is None


def _legs(courses_deg: list[float], *, mirrored: bool, axis_deg: float = 70.0,
          leg_s: float = 15.0, fix_noise: float = 0.3, seed: int = 0) -> MotionAlignment:
    """Drive legs of ``leg_s`` on each course in turn at 1.5 m/s, a fix every 0.5 s (its
    error ``fix_noise`` m), the sensor at 10 Hz reading the yaw plus 20°, or ``mirrored``:
    ``axis_deg`` less the yaw (its sense the wrong way round)."""
    rng = random.Random(seed)
    a = MotionAlignment()
    x = y = t = 0.0
    for course in courses_deg:
        h = math.radians(course)
        for _ in range(round(leg_s / 0.1)):
            yaw = -h
            read = math.radians(axis_deg) - yaw if mirrored else yaw + math.radians(20.0)
            a.add_heading(t, math.remainder(read, 2 * math.pi))
            if round(t * 10) % 5 == 0:
                a.add_fix(t, x + rng.gauss(0.0, fix_noise), y + rng.gauss(0.0, fix_noise))
            x, y, t = x + 0.15 * math.sin(h), y + 0.15 * math.cos(h), round(t + 0.1, 6)
    return a


def test_a_heading_read_the_wrong_way_round_is_told_by_the_courses_across_turns() -> None:
    """Read the wrong way round, the sensor's offset from the course turns twice as far as
    the vehicle; negated, it holds one offset, which is the bias to take it with."""
    mirrored = _legs([30.0, 120.0, 210.0, 300.0], mirrored=True).sense()
    assert mirrored is not None and mirrored.reversed
    # negated, the reading is the true yaw less the axis: a bias of −axis
    assert abs(math.degrees(math.remainder(mirrored.bias + math.radians(70.0),
                                           2 * math.pi))) < 3.0
    right = _legs([30.0, 120.0, 210.0, 300.0], mirrored=False).sense()
    assert right is not None and not right.reversed
    assert abs(math.degrees(right.bias) - 20.0) < 3.0


def test_one_course_cannot_tell_which_way_round_the_sensor_reads() -> None:
    for mirrored in (False, True):
        assert _legs([30.0, 30.0, 30.0], mirrored=mirrored).sense() is None


def _tour(a: MotionAlignment, start_s: float, end_s: float, *,
          mirrored: bool) -> MotionAlignment:
    """Legs of 15 s on 30°, 120°, 210° and 300° in turn at 1.5 m/s, from ``start_s`` to
    ``end_s`` of the same tour: the sensor at 4 Hz reading the yaw plus 20°, or ``mirrored``
    (70° less the yaw), a fix every 0.5 s (its error a function of its time, so that two
    tours over one stretch see the same). Times are multiples of 0.25 s: exact in binary,
    so two tours keep the same readings."""
    x = y = 0.0
    for k in range(round(end_s / 0.25)):
        t = k * 0.25
        h = math.radians((30.0, 120.0, 210.0, 300.0)[int(t // 15.0) % 4])
        if t >= start_s:
            read = math.radians(70.0) + h if mirrored else math.radians(20.0) - h
            a.add_heading(t, math.remainder(read, 2 * math.pi))
            if k % 2 == 0:
                noise = random.Random(k)
                a.add_fix(t, x + noise.gauss(0.0, 0.3), y + noise.gauss(0.0, 0.3))
        x, y = x + 0.375 * math.sin(h), y + 0.375 * math.cos(h)
    return a


@pytest.mark.parametrize("mirrored", [True, False])
def test_ten_minutes_of_runs_come_and_go_leaving_what_the_last_minute_alone_says(
        mirrored: bool) -> None:
    """The sums kept as runs enter and leave the window: after ten minutes they say what a
    tour of only the window's stretch (and the runs' lead-in) says: which way round the
    sensor reads, and (read the right way round) the correction its bias needs."""
    whole = _tour(MotionAlignment(), 0.0, 600.0, mirrored=mirrored)
    last = _tour(MotionAlignment(), 520.0, 600.0, mirrored=mirrored)
    told, alone = whole.sense(), last.sense()
    assert told is not None and alone is not None
    assert told.reversed == alone.reversed == mirrored
    assert told.runs == alone.runs
    assert told.bias == pytest.approx(alone.bias, abs=1e-9)
    assert told.spread == pytest.approx(alone.spread, abs=1e-9)
    if mirrored:
        return
    found, found_alone = whole.estimate(), last.estimate()
    assert found is not None and found_alone is not None and found.told
    assert abs(math.degrees(found.correction) - 20.0) < 3.0
    assert found.runs == found_alone.runs
    assert found.correction == pytest.approx(found_alone.correction, abs=1e-9)
    assert found.spread == pytest.approx(found_alone.spread, abs=1e-9)


@pytest.mark.parametrize("seed", range(5))
def test_the_largest_gap_between_runs_is_kept_as_runs_come_and_go(seed: int) -> None:
    """Legs driven with silences of 0-40 s (no fixes) between them for ten minutes: after
    every leg, the largest gap the window's runs leave (what ``MAX_GAP`` judges) is the one
    kept incrementally."""
    rng = random.Random(seed)
    a = MotionAlignment()
    t, checked = 0.0, 0
    while t < 600.0:
        heading = rng.uniform(0.0, 360.0)
        t = _straight(a, heading, 30.0, rng.uniform(5.0, 40.0), t0=t) + rng.uniform(0.0, 40.0)
        times = [run[0] for run in a._runs]
        if len(times) > 1:
            assert a._gaps[0][1] == max(b - p for p, b in itertools.pairwise(times))
            checked += 1
    assert checked > 5
