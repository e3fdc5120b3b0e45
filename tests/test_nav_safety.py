"""Filter safety (spec 2.2.9/2.2.11), the heading watch, channel down-weighting, the fault
library and the NEES: each as pure logic, then the navigator's decisions on the bus."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock
from mavhelm.core.mission import parse_mission
from mavhelm.nav.ekf import Beacon
from mavhelm.nav.faults import FAULTS, Layout, applies, with_fault
from mavhelm.nav.filter_safety import (
    FAILED,
    HEADING,
    LSQ_TRUST,
    REINITIALISED,
    FilterSafety,
)
from mavhelm.nav.fusion import NisTally
from mavhelm.nav.heading_watch import (
    CONTRADICTION_TIME,
    DOUBT_WINDOW,
    STILL_TIME,
    HeadingWatch,
)
from mavhelm.nav.lsq import Fix
from mavhelm.nav.navigator import Navigator
from mavhelm.nav.noise_match import MAX_SCALE, MIN_SCALE, SHRINK_AT, WINDOW, NoiseMatch
from mavhelm.nav.replay import NEES_BAND, nees


def fix(t: float, x: float, y: float = 0.0) -> Fix:
    return Fix(t, x, y, 1.0, 0.1, 3, ("A", "B", "C"))


def test_a_sustained_disagreement_reinitialises_the_ekf_a_lone_one_does_not() -> None:
    safety = FilterSafety(20.0, 30.0, 20.0)
    assert safety.on_fix(fix(0.0, 30.0), (0.0, 0.0)) is None
    assert safety.on_fix(fix(1.0, 5.0), (0.0, 0.0)) is None  # agreement: the count restarts
    decisions = [safety.on_fix(fix(2.0 + k, 30.0), (0.0, 0.0)) for k in range(6)]
    assert decisions[:5] == [None] * 5
    last = decisions[5]
    assert last is not None and last.kind == REINITIALISED
    assert "MaxLSQEKFDeviation 20 m" in last.why and "30.0 m" in last.why


def test_an_lsq_all_over_the_shop_is_untrusted_with_an_ekf_and_a_failure_without() -> None:
    safety = FilterSafety(20.0, None, 20.0)
    kinds = [safety.on_fix(fix(k, 50.0 * (k % 2)), (0.0, 0.0)) for k in range(9)]
    untrusted = [d for d in kinds if d is not None]
    assert [d.kind for d in untrusted] == [LSQ_TRUST] and "not trusted" in untrusted[0].why
    # while untrusted its disagreements do not count: no re-initialisation however long
    assert all(safety.on_fix(fix(10 + k, 50.0 * (k % 2)), (0.0, 0.0)) is None
               for k in range(20))
    lone = FilterSafety(20.0, None, 20.0)
    kinds = [lone.on_fix(fix(k, 50.0 * (k % 2)), None) for k in range(9)]
    assert kinds[-1] is not None and kinds[-1].kind == FAILED
    assert "MaxMedianLSQShift" in kinds[-1].why


def test_lsq_timeout_is_a_failure_when_unobservable_not_when_only_inconsistent() -> None:
    safety = FilterSafety(20.0, 30.0, 20.0)
    safety.start(0.0)
    assert safety.timed_out(29.0, 3, None, True) is None
    failure = safety.timed_out(31.0, 3, None, True)
    assert failure is not None and failure.kind == FAILED and "LSQTimeOut 30 s" in failure.why
    sparse = FilterSafety(20.0, 30.0, 20.0)
    sparse.start(0.0)
    said = sparse.timed_out(31.0, 3, None, True, window=5.0)  # the remedy named
    assert said is not None and "3 beacons within one LSQ_WINDOW (5 s)" in said.why
    assert "a longer LSQ_WINDOW, or LSQTimeOut = NEVER" in said.why
    heard = safety.timed_out(31.0, 3, 25.0, True)  # beacons heard, fixes refused, EKF on
    assert heard is not None and heard.kind == LSQ_TRUST
    assert safety.timed_out(32.0, 3, 25.0, True) is None  # said once
    assert safety.timed_out(32.0, 3, 25.0, False).kind == FAILED  # no EKF to carry on


def test_the_heading_watch_reports_a_contradicting_heading_and_its_return() -> None:
    watch = HeadingWatch(estimates_bias=True)
    said = [watch.heading(t / 10, "compass", False) for t in range(0, 40)]
    contradicts = [d for d in said if d is not None]
    assert len(contradicts) == 1 and "contradicts the motion" in contradicts[0].why
    assert contradicts[0].t == pytest.approx(CONTRADICTION_TIME)
    back = watch.heading(5.0, "compass", True)
    assert back is not None and back.kind == HEADING and "agrees" in back.why


def test_position_data_disagreeing_doubt_the_heading_once_per_episode() -> None:
    watch = HeadingWatch(estimates_bias=True)
    watch.motion(-STILL_TIME, 1.0)  # under way: the motion defines a course
    assert all(watch.position(k, 0.3) is None for k in range(50))  # agreeing data
    said = [watch.position(100 + k, 5.0) for k in range(3 * DOUBT_WINDOW)]
    assert watch.doubts == 3 and sum(d is not None for d in said) == 1
    assert "heading bias is doubted" in next(d for d in said if d is not None).why


def test_the_bias_is_said_unobservable_while_the_vehicle_is_still() -> None:
    watch = HeadingWatch(estimates_bias=True)
    said = [watch.motion(t / 10, 0.0) for t in range(80)]
    [still] = [d for d in said if d is not None]
    assert "unobservable" in still.why
    said = [watch.motion(10 + t / 10, 1.0) for t in range(80)]
    [moving] = [d for d in said if d is not None]
    assert "observable" in moving.why and "unobservable" not in moving.why
    assert HeadingWatch(estimates_bias=False).motion(0.0, 0.0) is None


def test_a_channel_disagreeing_beyond_its_noise_is_down_weighted_never_silenced() -> None:
    noise = NoiseMatch()
    for _ in range(WINDOW):
        noise.observe("b1", 9.0)
    assert noise.scale("b1") == pytest.approx(3.0)
    for _ in range(20 * WINDOW):
        noise.observe("b1", 1000.0)
    assert noise.scale("b1") == MAX_SCALE
    for _ in range(40 * WINDOW):
        noise.observe("b1", 0.01)
    assert noise.scale("b1") == 1.0  # back to the declared σ, never under it
    assert noise.scale("other") == 1.0


def test_a_channel_that_may_shrink_goes_under_its_declared_noise_slowly() -> None:
    """A range's σ declared far too large shrinks, a tenth a window, to a third at most; a
    window or two under SHRINK_AT by chance moves it little; a fix's never shrinks."""
    noise = NoiseMatch()
    for _ in range(2 * WINDOW):
        noise.observe("b1", 0.5 * SHRINK_AT, may_shrink=True)
        noise.observe("gps", 0.5 * SHRINK_AT)
    assert noise.scale("b1") == pytest.approx(0.81)
    assert noise.scale("gps") == 1.0
    for _ in range(40 * WINDOW):
        noise.observe("b1", 0.01, may_shrink=True)
    assert noise.scale("b1") == pytest.approx(MIN_SCALE)
    for _ in range(WINDOW):
        noise.observe("b1", 9.0, may_shrink=True)  # disagreeing again: grows back at once
    assert noise.scale("b1") == pytest.approx(3.0 * MIN_SCALE)


def test_nees_of_an_honest_covariance_is_two_and_inside_the_band() -> None:
    rng = np.random.default_rng(3)
    n = 5000
    t = np.arange(n, dtype=float)
    sx, sy = 2.0, 0.5
    ex, ey = rng.normal(0, sx, n), rng.normal(0, sy, n)
    honest = nees(t, ex, ey, [sx**2] * n, [0.0] * n, [sy**2] * n, t, np.zeros(n), np.zeros(n))
    assert honest.mean == pytest.approx(2.0, abs=0.15)
    assert honest.inside == pytest.approx(0.95, abs=0.015)
    proud = nees(t, ex, ey, [0.25 * sx**2] * n, [0.0] * n, [0.25 * sy**2] * n, t,
                 np.zeros(n), np.zeros(n))
    assert proud.mean == pytest.approx(8.0, rel=0.1) and proud.above > 0.3
    assert NEES_BAND[0] < 0.06 and 7.3 < NEES_BAND[1] < 7.4



def test_a_sensors_nis_tally_tells_an_honest_noise_from_a_cautious_one() -> None:
    """Honest χ² distances fall 95 % inside the band of their degrees of freedom, with the
    mean per dof near 1; a σ declared five times too large puts half of them below it."""
    rng = np.random.default_rng(5)
    honest, cautious = NisTally(), NisTally()
    for d2 in rng.chisquare(2, 4000):
        honest.add(float(d2), 2, accepted=True)
        cautious.add(float(d2) / 25.0, 2, accepted=True)
    honest.add(40.0, 2, accepted=False)
    assert honest.total / honest.dof == pytest.approx(1.0, abs=0.05)
    assert honest.inside / (honest.n - honest.rejected) == pytest.approx(0.95, abs=0.015)
    assert honest.rejected == 1 and honest.n == 4001
    assert cautious.below / cautious.n > 0.35 and cautious.above == 0


LAYOUT = Layout(("C",), ("R",), ("G",), (Beacon("1", 0.0, 0.0), Beacon("2", 50.0, 0.0)))


def _log(seconds: int = 1200) -> list[Message]:
    out = []
    for k in range(seconds):
        t = float(k)
        out += [Message("C_HEADING", 90.0, t, "log"), Message("R_RANGE_1", 10.0, t, "log"),
                Message("G_X", 1.0, t, "log"), Message("G_Y", 2.0, t, "log"),
                Message("TRUTH_X", 0.0, t, "log"), Message("TRUTH_Y", 10.0, t, "log")]
    return out


def test_faults_are_deterministic_and_do_what_they_say() -> None:
    log = _log()
    assert set(FAULTS) == {"heading_wander", "heading_drift", "heading_scale", "heading_offset",
                           "heading_jumps",
                           "heading_stuck", "ranges_gap", "beacon_moved", "range_outliers",
                           "ranges_long",
                           "gps_glitches", "yaw_rate_reversed", "heading_reversed",
                           "speed_scale"}
    for name in FAULTS:
        # no odometer's heading, no body velocity sensor
        assert applies(name, LAYOUT) is (name not in ("heading_scale", "yaw_rate_reversed",
                                                      "speed_scale"))
        assert with_fault(name, log, LAYOUT, seed=7) == with_fault(name, log, LAYOUT, seed=7)
    wander = [m.double for m in with_fault("heading_wander", log, LAYOUT)
              if m.name == "C_HEADING"]
    bias = [math.remainder(h - 90.0, 360.0) for h in wander]
    assert max(abs(b) for b in bias) == pytest.approx(180.0, abs=1.0)
    gap = [m.time for m in with_fault("ranges_gap", log, LAYOUT) if m.name == "R_RANGE_1"]
    assert max(b - a for a, b in zip(gap, gap[1:], strict=False)) == pytest.approx(61.0)
    moved = [m.double for m in with_fault("beacon_moved", log, LAYOUT)
             if m.name == "R_RANGE_1"]
    assert 0.0 < abs(moved[0] - 10.0) <= 5.0
    lengthened = [m.double - 10.0 for m in with_fault("ranges_long", log, LAYOUT)
                  if m.name == "R_RANGE_1"]
    long = [d for d in lengthened if d]
    assert all(5.0 <= d <= 50.0 for d in long) and 0.1 < len(long) / len(lengthened) < 0.3
    glitched = [m.double for m in with_fault("gps_glitches", log, LAYOUT) if m.name == "G_X"]
    assert 1.5 < float(np.std(glitched[:60])) < 2.5 and max(glitched) > 25.0
    for seed in range(1, 6):
        turned = {math.remainder(m.double - 90.0, 360.0)
                  for m in with_fault("heading_offset", log, LAYOUT, seed=seed)
                  if m.name == "C_HEADING"}
        assert len(turned) == 1 and 90.0 <= abs(turned.pop()) <= 180.0
    jumps = [m.double for m in with_fault("heading_jumps", log, LAYOUT) if m.name == "C_HEADING"]
    assert sum(h != 90.0 for h in jumps) > 60
    stuck = [m.double for m in with_fault("heading_stuck", log, LAYOUT) if m.name == "C_HEADING"]
    assert stuck == [90.0] * len(stuck)  # a constant heading stuck is still the same
    with pytest.raises(ValueError, match="unknown or repeated fault"):
        with_fault("nothing", log, LAYOUT)
    assert not applies("ranges_gap", Layout(("C",), (), ("G",), ()))


def test_a_reversed_yaw_rate_is_every_body_velocity_sensors_rate_negated() -> None:
    log = [Message(name, value, float(k), "log") for k in range(10)
           for name, value in (("C_HEADING", 90.0), ("D_YAW_VEL", 0.1 * k),
                               ("D_VX_BODY", 1.0))]
    layout = Layout(("C",), (), (), (), ("D",))
    assert applies("yaw_rate_reversed", layout)
    reversed_ = with_fault("yaw_rate_reversed", log, layout)
    assert [m.double for m in reversed_ if m.name == "D_YAW_VEL"] == [
        -0.1 * k for k in range(10)]
    assert ([m for m in reversed_ if m.name != "D_YAW_VEL"]
            == [m for m in log if m.name != "D_YAW_VEL"])


def test_a_reversed_heading_turns_the_other_way_about_an_axis_each_seed_draws() -> None:
    """Degrees clockwise (``_HEADING``) and radians anticlockwise (``_YAW``) alike: each
    reading is one angle less the true one, so every turn is read backwards."""
    log = [Message(name, value, float(k), "log") for k in range(10)
           for name, value in (("C_HEADING", 10.0 * k), ("Y_YAW", math.radians(-10.0 * k)),
                               ("R_RANGE_1", 10.0))]
    layout = Layout(("C", "Y"), ("R",), (), (Beacon("1", 0.0, 0.0),))
    axes = set()
    for seed in (1, 2):
        reversed_ = with_fault("heading_reversed", log, layout, seed)
        headings = [m.double for m in reversed_ if m.name == "C_HEADING"]
        yaws = [m.double for m in reversed_ if m.name == "Y_YAW"]
        axis = headings[0]
        axes.add(round(axis, 6))
        assert headings == pytest.approx([(axis - 10.0 * k) % 360.0 for k in range(10)])
        assert [math.remainder(-math.degrees(y) - h, 360.0) for y, h in zip(
            yaws, headings, strict=True)] == pytest.approx([0.0] * 10, abs=1e-9)
        assert [m for m in reversed_ if m.name == "R_RANGE_1"] == [
            m for m in log if m.name == "R_RANGE_1"]
    assert len(axes) == 2


def test_faults_joined_are_made_on_one_log_together() -> None:
    log = _log()
    both = with_fault("heading_wander+ranges_gap", log, LAYOUT)
    assert both == with_fault("heading_wander+ranges_gap", log, LAYOUT)
    wandered = with_fault("heading_wander", log, LAYOUT)  # the first as when made alone
    assert ([m for m in both if m.name == "C_HEADING"]
            == [m for m in wandered if m.name == "C_HEADING"])
    gap = [m.time for m in both if m.name == "R_RANGE_1"]
    assert max(b - a for a, b in zip(gap, gap[1:], strict=False)) == pytest.approx(61.0)
    jumped = with_fault("heading_wander+heading_jumps", log, LAYOUT)
    assert ([m.double for m in jumped if m.name == "C_HEADING"]
            != [m.double for m in wandered if m.name == "C_HEADING"])
    assert applies("heading_wander+ranges_gap", LAYOUT)
    assert not applies("heading_wander+heading_scale", LAYOUT)  # no odometer's heading
    for bad in ("heading_wander+nothing", "heading_jumps+heading_jumps", "heading_wander+"):
        with pytest.raises(ValueError, match="unknown or repeated fault"):
            with_fault(bad, log, LAYOUT)


def test_a_scaled_heading_errs_by_its_scale_times_each_turn_and_its_yaw_rate_with_it() -> None:
    """``heading_scale``: an odometer whose yaw rate is a few % off, and its heading that
    rate integrated. Turning 90° and back, the heading's error grows by the scale times the
    turn and unwinds with the turn back (no drift in time); a yaw rate from another
    instrument is left alone; without one source giving both, the fault does not apply."""
    log = []
    for k in range(200):
        heading = (10.0 + (k if k < 90 else max(180 - k, 0))) % 360.0  # 1°/s, out and back
        rate = -math.radians(1.0 if k < 90 else -1.0 if k < 180 else 0.0)
        log += [Message("C_HEADING", heading, float(k), "log"),
                Message("C_YAW_VEL", rate, float(k), "log"),
                Message("D_YAW_VEL", rate, float(k), "log")]
    layout = Layout(("C",), (), (), (), ("C", "D"))
    scaled = with_fault("heading_scale", log, layout, seed=3)
    heading = [m.double for m in scaled if m.name == "C_HEADING"]
    rates = [m.double for m in scaled if m.name == "C_YAW_VEL"]
    k = rates[10] / log[31].double - 1.0  # the scale the seed drew
    assert 0.03 <= abs(k) <= 0.08
    assert math.remainder(heading[89] - 99.0, 360.0) == pytest.approx(89 * k)  # 89° turned
    assert math.remainder(heading[199] - 10.0, 360.0) == pytest.approx(0.0, abs=1e-9)
    assert [m.double for m in scaled if m.name == "D_YAW_VEL"] == [
        m.double for m in log if m.name == "D_YAW_VEL"]
    assert scaled == with_fault("heading_scale", log, layout, seed=3)
    assert not applies("heading_scale", Layout(("C",), (), (), (), ("D",)))


def test_a_drifting_heading_swings_180_within_five_minutes_and_its_yaw_rate_with_it() -> None:
    """``heading_drift``: an odometry-integrated heading. Its error's widest swing over any
    five minutes is 180°, and the same instrument's yaw rate (yaw = −heading, rad/s) carries
    the drift's rate, so heading and rate still agree with each other; a yaw rate from
    another instrument is left alone."""
    log = [m for k in range(1200) for m in (
        Message("C_HEADING", 90.0, float(k), "log"), Message("C_YAW_VEL", 0.0, float(k), "log"),
        Message("D_YAW_VEL", 0.0, float(k), "log"))]
    layout = Layout(("C",), (), (), (), ("C", "D"))
    drifted = with_fault("heading_drift", log, layout, seed=3)
    bias = np.unwrap(np.radians([m.double - 90.0 for m in drifted if m.name == "C_HEADING"]))
    bias = np.degrees(bias)
    swings = np.ptp(np.lib.stride_tricks.sliding_window_view(bias, 300), axis=1)
    assert swings.max() == pytest.approx(180.0, abs=1.0)
    assert np.ptp(bias) > 180.0  # over the whole run it goes further than five minutes' swing
    rate = np.array([m.double for m in drifted if m.name == "C_YAW_VEL"])
    np.testing.assert_allclose(rate, -np.radians(np.gradient(bias)), atol=1e-3)
    assert all(m.double == 0.0 for m in drifted if m.name == "D_YAW_VEL")


NAV_LSQ = """
ProcessConfig = pNav
{
    X = EKF @ 2, LSQ @ 5
    Y = EKF @ 2, LSQ @ 5
    SENSOR_RANGE = R -> ranger @ 0,0,0 ~ 0.3
    BEACON = 1 @ 0,0,0
    BEACON = 2 @ 100,0,0
    BEACON = 3 @ 0,100,0
    EKF_X = 60
    EKF_Y = 60
    EKF_SIGMA_XY = 0.5
    MaxLSQEKFDeviation = 10
    LSQTimeOut = NEVER
}
"""


def test_the_navigator_posts_its_decisions_and_the_position_sigma() -> None:
    """An EKF started confidently 36 m from the truth rejects the ranges; the LSQ disagrees
    fix after fix, and the navigator re-initialises the EKF to it and says why."""
    block = parse_mission(NAV_LSQ, "m.moos").process("pNav")
    assert block is not None
    clock = SimClock(0.0)
    bus = Bus(clock)
    nav = Navigator.from_block(bus, block)
    bus.subscribe(nav.name, nav.subscriptions())
    bus.subscribe("test", {"NAV_STATUS", "NAV_WARNING", "NAV_X", "NAV_X_STD", "NAV_Y_STD"})
    truth = (30.0, 40.0)
    got: list[Message] = []
    for k in range(200):
        t = 0.5 * k
        clock.set(t)
        name = "123"[k % 3]
        bx, by = {"1": (0, 0), "2": (100, 0), "3": (0, 100)}[name]
        bus.notify(f"R_RANGE_{name}", math.hypot(truth[0] - bx, truth[1] - by), "log", t)
        nav.on_mail(bus.fetch(nav.name), t)
        nav.iterate(t)
        got += bus.fetch("test")
    status = [m.string for m in got if m.name == "NAV_STATUS"]
    assert any(s.startswith("reinitialised: EKF and LSQ disagreed for 6 fixes") for s in status)
    assert any("reinitialised" in m.string for m in got if m.name == "NAV_WARNING")
    x = [m for m in got if m.name == "NAV_X"]
    std = {m.time: m.double for m in got if m.name == "NAV_X_STD"}
    assert abs(x[-1].double - truth[0]) < 1.0
    # the 1-σ of that very value: metres, since a still vehicle cannot tell its position from
    # the beacons' range offsets the filter is learning
    assert x[-1].time in std and 0.0 < std[x[-1].time] < 5.0


def test_a_lost_ekf_goes_off_line_and_the_lsq_boots_it_again() -> None:
    """MaxEKFPositionUncertainty with an LSQ running: the original's reset, not a failure."""
    from mavhelm.nav.ekf import EKFConfig, Range
    from mavhelm.nav.filter_safety import BOOTED, LOST
    from mavhelm.nav.fusion import Fusion, FusionConfig, Start
    from mavhelm.nav.sensors import Reading, SensorSpec

    beacons = (Beacon("1", 0.0, 0.0), Beacon("2", 100.0, 0.0), Beacon("3", 0.0, 100.0))
    fusion = Fusion(FusionConfig(ekf=EKFConfig(max_position_sigma=10.0), beacons=beacons,
                                 start=Start(30.0, 40.0, sigma_xy=20.0), lsq_timeout=None))
    ranger = SensorSpec("RANGE", "R", "ranger")
    for k in range(60):
        t = 0.5 * k
        b = beacons[k % 3]
        fusion.add(Reading(ranger, Range(t, b.name, math.hypot(30.0 - b.x, 40.0 - b.y), 0.3)),
                   t)
        fusion.step(t)
    kinds = [d.kind for d in fusion.decisions]
    assert kinds[:3] == [BOOTED, LOST, BOOTED] and fusion.failure is None
    assert "(MaxEKFPositionUncertainty)" in fusion.decisions[1].why
    assert "EKF off-line until the LSQ boots it again" in fusion.decisions[1].why
    assert fusion.ekf is not None and fusion.ekf.position_sigma() < 10.0
