"""The fix watch (:mod:`mavhelm.nav.fix_watch`): fixes refused in a row that follow on from
one another as the vehicle moves tell of a filter gone astray, and it is put right; a glitch,
which jumps, is refused to its end."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavhelm.core.bus import Message
from mavhelm.core.mission import parse_mission
from mavhelm.nav import fix_watch
from mavhelm.nav.filter_safety import FIX
from mavhelm.nav.fix_watch import REFUSED_RUN, FixWatch
from mavhelm.nav.replay import accuracy, replay
from tests.support import box_boat


def test_fixes_refused_in_a_row_that_follow_on_say_the_filter_is_off() -> None:
    watch = FixWatch()
    assert watch.heard(0.0, "gps", 0.0, 0.0, 2.0, True, 3.0, 0.0) is None
    said = [watch.heard(0.2 * k, "gps", 0.6 * k, 0.0, 2.0, False, 3.0, 5.0 * k)
            for k in range(1, REFUSED_RUN + 1)]
    assert said[:-1] == [None] * (REFUSED_RUN - 1)
    assert said[-1] is not None and said[-1].kind == FIX
    assert "position sensor gps" in said[-1].why and "the filter is off" in said[-1].why
    # counted again from there; an accepted fix ends the run
    assert watch.heard(1.0, "gps", 3.0, 0.0, 2.0, False, 3.0, 9.0) is None
    assert watch.heard(1.2, "gps", 3.6, 0.0, 2.0, True, 3.0, 0.0) is None
    assert all(watch.heard(1.2 + 0.2 * k, "gps", 3.6 + 0.6 * k, 0.0, 2.0, False, 3.0, 1.0)
               is None for k in range(1, REFUSED_RUN))


def test_a_glitch_jumps_and_is_refused_to_its_end() -> None:
    watch = FixWatch()
    watch.heard(0.0, "gps", 0.0, 0.0, 2.0, True, 3.0, 0.0)
    # 40 m out at once, then every fix of the glitch near the one before it
    assert all(watch.heard(0.2 * k, "gps", 40.0 + 0.6 * k, 0.0, 2.0, False, 3.0, 40.0) is None
               for k in range(1, 30))
    watch.heard(6.0, "gps", 18.0, 0.0, 2.0, True, 3.0, 0.0)  # over: taken again
    said = [watch.heard(6.0 + 0.2 * k, "gps", 18.0 + 0.6 * k, 0.0, 2.0, False, 3.0, 5.0)
            for k in range(1, REFUSED_RUN + 1)]
    assert said[-1] is not None


def test_each_sensor_is_watched_on_its_own() -> None:
    watch = FixWatch()
    for name in ("gps", "usbl"):
        watch.heard(0.0, name, 0.0, 0.0, 2.0, True, 3.0, 0.0)
    for k in range(1, REFUSED_RUN):
        assert watch.heard(0.2 * k, "gps", 0.6 * k, 0.0, 2.0, False, 3.0, 5.0) is None
        assert watch.heard(0.2 * k, "usbl", 0.6 * k, 0.0, 2.0, False, 3.0, 5.0) is None
    assert watch.heard(0.2 * REFUSED_RUN, "usbl", 1.8, 0.0, 2.0, False, 3.0, 5.0) is not None


MISSION = """
LatOrigin = 56.412
LongOrigin = -5.476
ProcessConfig = pNav
{
    X       = EKF @ 2
    Y       = EKF @ 2
    Heading = EKF @ 2
    SENSOR_XY          = GPS -> gps ~ 2
    SENSOR_ORIENTATION = HDG -> compass ~ 0.5
    SENSOR_BODY_VEL    = DVL -> dvl ~ 0.02, 0.02
    SENSOR_BODY_VEL    = INS -> gyro ~ 0.5
}
"""
SPEED = 4.0
STILL = 20.0
RAMP = 4.0


def _boat(heading_error: float, seconds: float = 80.0) -> list[Message]:
    """A boat still for ``STILL`` s, then east, reaching ``SPEED`` in ``RAMP`` s: 5 Hz GPS
    (0.3 m of noise), 10 Hz compass ``heading_error`` degrees out from the start, 10 Hz
    gyro, 5 Hz DVL, the truth."""
    rng = np.random.default_rng(3)
    out = []
    for k in range(int(seconds * 10)):
        t = 1000.0 + 0.1 * k
        run = max(t - 1000.0 - STILL, 0.0)
        speed = SPEED * min(run / RAMP, 1.0)
        x = SPEED * (run**2 / (2 * RAMP) if run < RAMP else run - RAMP / 2)
        out += [Message("HDG_HEADING", (90.0 + heading_error) % 360.0, t, "log"),
                Message("INS_YAW_VEL", 0.0, t, "log")]
        if k % 2 == 0:
            out += [Message("GPS_X", x + rng.normal(0, 0.3), t, "log"),
                    Message("GPS_Y", rng.normal(0, 0.3), t, "log"),
                    Message("DVL_VX_BODY", speed, t, "log"),
                    Message("DVL_VY_BODY", 0.0, t, "log"),
                    Message("TRUTH_X", x, t, "log"), Message("TRUTH_Y", 0.0, t, "log")]
    return out


def _worst_after(result, seconds: float) -> float:  # noqa: ANN001
    """The EKF's largest position error from ``seconds`` into the replay on."""
    c, tt = result.covariance, result.truth
    t = np.asarray(c.t)
    late = t - result.start >= seconds
    return accuracy(t[late], np.asarray(c.x)[late], np.asarray(c.y)[late],
                    tt.t, tt.x, tt.y).max


def test_a_compass_half_a_turn_out_from_the_start_is_put_right_by_the_gps(monkeypatch) -> None:
    """The compass 180° out and no bias declared: under way, the dead reckoning runs west
    while the GPS goes east and is refused from the first second. Three refused fixes that
    follow on from one another say the filter is off: its position is widened to the fixes
    and its heading doubted, and the motion sets it right. Without the watch the filter
    runs on, refusing every fix, until the courses made good between fixes tell."""
    block = parse_mission(MISSION, "boat.moos").process("pNav")
    assert block is not None
    watched = replay(block, _boat(180.0))
    decisions = [d for d in watched.navigator.fusion.decisions if d.kind == FIX]
    assert decisions and decisions[0].t - watched.start < STILL + 5.0  # measured 3.4 s in
    monkeypatch.setattr(fix_watch, "REFUSED_RUN", 10**9)
    unwatched = replay(block, _boat(180.0))
    assert not [d for d in unwatched.navigator.fusion.decisions if d.kind == FIX]
    after = STILL + 10.0
    assert _worst_after(watched, after) < 3.0
    # measured: 10.8 m at worst, 22.3 m without the watch
    assert _worst_after(unwatched, STILL) > 1.5 * _worst_after(watched, STILL)


@pytest.mark.parametrize("error", [0.0, 5.0])
def test_a_sound_filter_never_says_it_is_off(error: float) -> None:
    block = parse_mission(MISSION, "boat.moos").process("pNav")
    assert block is not None
    result = replay(block, _boat(error))
    assert not [d for d in result.navigator.fusion.decisions if d.kind == FIX]
    assert _worst_after(result, 0.0) < 2.5  # measured 0.98 m and 1.72 m (no bias declared)


RANGING = MISSION.replace("    SENSOR_BODY_VEL    = INS -> gyro ~ 0.5\n", """\
    SENSOR_RANGE       = RNG -> radio ~ 0.3
    BEACON = 1 @ -60,-60,0
    BEACON = 2 @ 160,-50,0
    BEACON = 3 @ 50,160,0
""")


def test_a_gps_boat_among_beacons_started_under_way_boots_from_its_first_fix() -> None:
    """Started (or restarted) under way at 4 m/s among beacons: a position sensor boots the
    filter at its first fix, beacons or not (here 0.2 s; the LSQ boot, three fixes within
    10 m of each other, came at 4 s). On the real ArduPilot SITL's outage run with a beacon
    off its survey the LSQ fixed seldom, seconds and tens of metres apart: the three never
    agreed, and its median shift (20 m) declared a navigation failure at 89 s with the GPS
    good all along."""
    block = parse_mission(RANGING, "ranging.moos").process("pNav")
    assert block is not None
    beacons = {1: (-60.0, -60.0), 2: (160.0, -50.0), 3: (50.0, 160.0)}
    rng = np.random.default_rng(5)
    log = []
    for k in range(1200):
        t = 2000.0 + 0.1 * k
        x = SPEED * 0.1 * k
        log.append(Message("HDG_HEADING", 90.0, t, "log"))
        if k % 2 == 0:
            log += [Message("GPS_X", x + rng.normal(0, 0.5), t, "log"),
                    Message("GPS_Y", rng.normal(0, 0.5), t, "log"),
                    Message("DVL_VX_BODY", SPEED, t, "log"), Message("DVL_VY_BODY", 0.0, t, "log"),
                    Message("TRUTH_X", x, t, "log"), Message("TRUTH_Y", 0.0, t, "log")]
        if k % 5 == 0:
            name = 1 + (k // 5) % 3
            bx, by = beacons[name]
            log.append(Message(f"RNG_RANGE_{name}", math.hypot(x - bx, by) + rng.normal(0, 0.3),
                               t, "log"))
    result = replay(block, log)
    booted = [d for d in result.navigator.fusion.decisions if d.kind == "booted"]
    assert booted and "first gps fix" in booted[0].why and booted[0].t - result.start < 0.5
    assert result.failure is None
    assert result.accuracy().rms < 1.0


def test_a_jump_among_refused_fixes_holds_the_judgement_for_a_glitchs_time_not_for_ever(
) -> None:
    """A fix beyond reach among refused ones (one noisy fix, or a glitch's start) starts the
    count again and holds the judgement for ``GLITCH_TIME``: still refused, still following on
    from one another after it, the fixes are no glitch and the filter is off."""
    watch = FixWatch()
    watch.heard(0.0, "gps", 0.0, 0.0, 2.0, True, 3.0, 0.0)
    watch.heard(0.2, "gps", 0.6, 0.0, 2.0, False, 3.0, 5.0)
    assert watch.heard(0.4, "gps", 30.0, 0.0, 2.0, False, 3.0, 30.0) is None  # a jump
    said = []
    for k in range(1, 60):
        t = 0.4 + 0.2 * k
        said.append((t, watch.heard(t, "gps", 30.0 + 0.6 * k, 0.0, 2.0, False, 3.0, 30.0)))
    first = next(t for t, d in said if d is not None)
    assert first == pytest.approx(0.4 + fix_watch.GLITCH_TIME, abs=0.21)
    decision = dict(said)[first]
    assert decision is not None and "since they jumped" in decision.why



def test_a_noisy_fix_among_the_refused_does_not_shut_the_watch(monkeypatch) -> None:
    """GPS and a compass read the wrong way round: the compass turns the dead reckoning
    against every turn and the fixes are refused, and now and then one fix lies 20 m out, a
    jump. A jump once stopped the count until a fix was accepted, which never came while the
    filter was off (the real ArduPilot SITL's boat, its compass so read: 200 m from its GPS
    for 90 s, 77 m RMS). The watch now judges again a glitch's time after it. (Measured with
    the runs made good waiting their full span after the watch's word, as they did when it
    was written: told the filter is off, they now turn the heading at the first three runs,
    and this log never reaches the jump; 5.7 m RMS.)"""
    from mavhelm.nav.alignment import MotionAlignment

    block = parse_mission(box_boat.MISSION, "box.moos").process("pNav")
    assert block is not None
    # the compass 70° less the true heading; every 150th fix (30 s) 20 m out
    log = box_boat.box(lambda _t, heading: 70.0 - heading, seed=7, outlier_every=150)
    early = replay(block, log).accuracy().rms
    monkeypatch.setattr(MotionAlignment, "filter_off", lambda self, t: None)
    watched = replay(block, log)
    assert early < watched.accuracy().rms
    fixes = [d for d in watched.navigator.fusion.decisions if d.kind == FIX]
    assert any("since they jumped" in d.why for d in fixes)
    monkeypatch.setattr(fix_watch, "GLITCH_TIME", math.inf)  # a jump shuts the watch
    shut = replay(block, log)
    rms, shut_rms = watched.accuracy().rms, shut.accuracy().rms
    print(f"\nEKF RMS {rms:.1f} m, {shut_rms:.1f} m with the watch shut by a jump")
    assert rms < 15.0  # measured 9.0 m (the GPS 2.8 m: the compass's sense is not told)
    assert shut_rms > 5.0 * rms  # measured 111.6 m
