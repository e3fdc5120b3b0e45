"""A yaw rate of the wrong sign is told from the headings' turns, and only then
(:mod:`mavhelm.nav.rate_sense`)."""

from __future__ import annotations

import math

import numpy as np

from mavhelm.core.bus import Message
from mavhelm.core.mission import parse_mission
from mavhelm.nav.faults import layout_of, with_fault
from mavhelm.nav.fusion import SENSE_TIME
from mavhelm.nav.rate_sense import CONTRARY, VOTES, RateSense
from mavhelm.nav.replay import ReplayResult, replay
from tests.support.mission import EKF_GPS_COMPASS


def _weave(seconds: float, rate_sign: float = 1.0, bias=lambda t: 0.0, hold=None,
           sense: RateSense | None = None, t0: float = 0.0):
    """A vehicle weaving (yaw 40° sin(t/8)), a heading and a yaw rate each 5 Hz: the rate
    times ``rate_sign``, the heading plus ``bias(t)`` (rad), held at its value while
    ``hold(t)``. Returns the sense and its findings as (t, finding)."""
    sense = sense or RateSense()
    findings = []
    held = None
    for t in np.arange(t0, t0 + seconds, 0.2):
        yaw = math.radians(40.0) * math.sin(t / 8.0)
        rate = math.radians(40.0) / 8.0 * math.cos(t / 8.0)
        sense.rate("gyro", t, rate_sign * rate)
        heading = math.remainder(yaw + bias(t), 2 * math.pi)
        if hold is not None and hold(t):
            held = heading if held is None else held
            heading = held
        else:
            held = None
        findings += [(t, v) for v in sense.heading("compass", t, heading)]
    return sense, findings


def test_a_rate_of_the_right_sign_is_never_found_reversed() -> None:
    sense, findings = _weave(600.0)
    assert not findings and not sense.reversed


def test_a_reversed_rate_is_found_once_enough_turns_vote_and_dropped_when_it_agrees() -> None:
    sense, findings = _weave(120.0, rate_sign=-1.0)
    assert len(findings) == 1 and sense.reversed == {"gyro"}
    t, finding = findings[0]
    assert finding.reversed and finding.against >= CONTRARY * VOTES
    assert "gyro" in str(finding) and "compass" in str(finding) and "wrong sense" in str(finding)
    assert t < 30.0  # the first clear turns: the weave turns at up to 5°/s
    sense, back = _weave(120.0, sense=sense, t0=120.0)
    assert [v.reversed for _, v in back] == [False] and not sense.reversed
    assert "again" in str(back[0][1])


def test_a_heading_wandering_fast_jumping_or_stuck_does_not_reverse_a_good_rate() -> None:
    """A bias sweeping 180° in three minutes (1°/s), 60° jumps for 10 s every minute, the
    heading stuck for two minutes: the rate is still the right one."""
    _, wander = _weave(900.0, bias=lambda t: math.radians(t))
    _, jumps = _weave(900.0, bias=lambda t: math.radians(60.0) if t % 60.0 < 10.0 else 0.0)
    sense, stuck = _weave(900.0, hold=lambda t: 100.0 <= t < 220.0)
    assert not wander and not jumps and not stuck and not sense.reversed


def test_a_still_vehicle_or_a_gap_in_the_headings_gives_no_votes() -> None:
    sense = RateSense()
    for k in range(200):
        t = 0.2 * k
        sense.rate("gyro", t, -0.001 * math.sin(t))  # noise about a still vehicle
        assert not sense.heading("compass", t, 0.002 * math.sin(3 * t))
    for k in range(40):  # headings 3 s apart, turning the other way: too far apart to compare
        t = 40.0 + 3.0 * k
        sense.rate("gyro", t, 0.2)
        assert not sense.heading("compass", t, math.remainder(-0.2 * (t - 40.0), 2 * math.pi))
    assert not sense.reversed


def test_a_rate_gone_silent_is_not_held_into_the_turns_that_follow() -> None:
    """A gyro that stops while turning left at 5°/s: the headings then turning right are
    not set against the rate it last read."""
    sense = RateSense()
    sense.rate("gyro", 0.0, math.radians(5.0))
    for k in range(1, 200):
        t = 0.2 * k
        assert not sense.heading("compass", t, math.remainder(-math.radians(5.0) * t,
                                                               2 * math.pi))
    assert not sense.reversed



def test_a_rate_forgiven_is_taken_as_it_reads_and_judged_afresh() -> None:
    """The heading was the one of the wrong sense (``Fusion._test_sense``): the rate is
    taken as it reads at once, its votes forgotten; the heading, read negated from then on,
    agrees with it, and no finding follows either way (without the forgiving, the agreeing
    votes would find it "again")."""
    sense, _ = _weave(120.0, rate_sign=-1.0)
    assert sense.reversed == {"gyro"}
    sense.forgive("gyro")
    assert not sense.reversed
    sense, after = _weave(300.0, sense=sense, t0=120.0)  # heading and rate now agree
    assert not after and not sense.reversed
    unforgiven, _ = _weave(120.0, rate_sign=-1.0)
    unforgiven, again = _weave(300.0, sense=unforgiven, t0=120.0)
    assert [f.reversed for _, f in again] == [False]


def test_a_mirrored_rate_is_taken_the_other_way_round_and_judged_afresh() -> None:
    """The ranges found the heading read the wrong way round with its rate
    (``Fusion._mirror_from_ranges``): the heading is read negated from then on, the rate
    too, and the two then agree; mirrored once more, the rate reads as it did. Without the
    votes forgotten, the twenty agreeing votes taken as read would find the rate "again"
    at the next turn."""
    sense, findings = _weave(120.0)
    assert not findings and not sense.reversed
    sense.mirror()
    assert sense.reversed == {"gyro"}
    sense, after = _weave(120.0, rate_sign=-1.0, sense=sense, t0=120.0)  # as the sensor reads
    assert not after and sense.reversed == {"gyro"}
    sense.mirror()
    assert not sense.reversed
    sense, after = _weave(120.0, sense=sense, t0=240.0)
    assert not after and not sense.reversed


MISSION = ("ProcessConfig = pNav\n{" + EKF_GPS_COMPASS
           + "  SENSOR_BODY_VEL = INS -> gyro @ 0,0,0 ~ 0.5\n  FIXEDSIDESLIP = 0 @ 0.3\n}\n")
"""The EKF on GPS and compass, with a gyro's yaw rate and a sideslip constraint."""


def _boat(legs: list[float], *, weave: float = 30.0, seed: int = 2) -> list[Message]:
    """A boat weaving in place for ``weave`` s (heading ±40°, ~10°/s), then 30 s legs at
    2 m/s on each course of ``legs`` (deg, clockwise from north), turning at 15°/s between
    them: compass and gyro at 10 Hz, a GPS (0.3 m) at 5 Hz, the truth."""
    rng = np.random.default_rng(seed)
    out, t, x, y = [], 100.0, 0.0, 0.0
    heading = legs[0]
    plan = [(weave, None)] + [(30.0, c) for c in legs]
    for seconds, course in plan:
        for _ in range(round(seconds * 10)):
            if course is None:
                rate = 10.0 * math.cos((t - 100.0) / 2.5)  # deg/s clockwise
                speed = 0.0
            else:
                step = math.remainder(course - heading, 360.0)
                rate, speed = max(-15.0, min(15.0, step * 10.0)), 2.0
            heading += rate * 0.1
            x += speed * 0.1 * math.sin(math.radians(heading))
            y += speed * 0.1 * math.cos(math.radians(heading))
            t = round(t + 0.1, 6)
            out += [Message("INS_YAW", math.radians(-heading) + rng.normal(0, 0.01), t, "log"),
                    Message("INS_YAW_VEL", math.radians(-rate), t, "log"),
                    Message("TRUTH_X", x, t, "log"), Message("TRUTH_Y", y, t, "log")]
            if round(t * 10) % 2 == 0:
                out += [Message("GPS_X", x + rng.normal(0, 0.3), t, "log"),
                        Message("GPS_Y", y + rng.normal(0, 0.3), t, "log")]
    return out


def _replayed(log: list[Message], fault: str | None) -> tuple[ReplayResult, list[str]]:
    block = parse_mission(MISSION, "sense.moos").process("pNav")
    assert block is not None
    result = replay(block, with_fault(fault, log, layout_of(block)) if fault else log)
    return result, [d.why for d in result.navigator.fusion.decisions]


def test_the_courses_made_good_tell_a_reversed_compass_from_a_reversed_gyro() -> None:
    """Found in the weave, told once the boat has run two courses: the reversed one is the
    one taken the other way round, the other taken as it reads; the heading then follows
    the truth again."""
    log = _boat([0.0, 90.0, 180.0, 270.0, 0.0])
    clean, said = _replayed(log, None)
    assert not any("wrong sense" in why for why in said)
    for fault, verdict in (("heading_reversed", "the heading of sensor compass turns against "
                            "the courses made good between fixes"),
                           ("yaw_rate_reversed", "the courses made good between fixes turn "
                            "with the heading of sensor compass")):
        result, said = _replayed(log, fault)
        assert any("one of the two is of the wrong sense" in why
                   and "neither is taken until the motion tells which" in why for why in said)
        assert any(verdict in why for why in said), said
        assert result.accuracy("NAV").rms < 2.0 * clean.accuracy("NAV").rms + 0.2, fault
        final = result.final
        assert final is not None
        assert abs(math.degrees(math.remainder(final.yaw, 2 * math.pi))) < 10.0, fault


def test_one_course_cannot_tell_and_the_rate_is_taken_negated_after_a_while() -> None:
    """Weaving in place, then one course for longer than the motion is asked: nothing can
    tell, so it says so and takes the rate negated, the heading as it reads, as before."""
    log = _boat([0.0] * round((SENSE_TIME + 60.0) / 30.0))
    _, said = _replayed(log, "yaw_rate_reversed")
    assert any(f"the motion did not tell in {SENSE_TIME:.0f} s" in why for why in said), said
    assert not any("courses made good" in why for why in said)


def test_without_ranges_or_fixes_nothing_can_tell_and_the_rate_is_negated_at_once() -> None:
    """Dead reckoning on compass and gyro from a start, no position data: the motion cannot
    be asked, so the rate is taken negated at once, as before the motion was asked, and the
    decision says why."""
    mission = ("ProcessConfig = pNav\n{\n  X = EKF @ 2\n  Y = EKF @ 2\n  Yaw = EKF @ 2\n"
               "  SENSOR_ORIENTATION = INS -> compass @ 0,0,0 ~ 1.0\n"
               "  SENSOR_BODY_VEL = INS -> gyro @ 0,0,0 ~ 0.5\n"
               "  EKF_X = 0\n  EKF_Y = 0\n  EKF_SIGMA_XY = 1\n}\n")
    block = parse_mission(mission, "dead_reckoning.moos").process("pNav")
    assert block is not None
    log = [m for m in _boat([0.0, 90.0]) if not m.name.startswith("GPS")]
    result = replay(block, with_fault("yaw_rate_reversed", log, layout_of(block)))
    said = [d.why for d in result.navigator.fusion.decisions]
    found = [why for why in said if "one of the two is of the wrong sense" in why]
    assert len(found) == 1 and found[0].endswith(
        "the rate is taken negated (no ranges or fixes to tell which)"), said
    assert result.navigator.fusion.rate_sense.reversed == {"INS_YAW_VEL (sensor gyro)"}
    assert not any("neither is taken" in why or "courses made good" in why for why in said)
