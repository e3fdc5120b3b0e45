"""ScalarPID (spec 1.4.1): limits, time-stamp driven dt, smoothed derivative, angle wrap."""

from __future__ import annotations

import pytest

from mavhelm.core.mission import Block, Entry, MissionError
from mavhelm.tasks.helm import HELM_SCHEMA
from mavhelm.tasks.pid import HelmGains, ScalarPID
from mavhelm.tasks.registry import build_task


def test_proportional_only_and_output_limit() -> None:
    pid = ScalarPID(kp=2.0, kd=0.0, ki=0.0, integral_limit=0.0, output_limit=10.0)
    assert pid.run(3.0, 0.0) == pytest.approx(6.0)
    assert pid.run(50.0, 1.0) == 10.0
    assert pid.run(-50.0, 2.0) == -10.0


def test_integral_uses_time_stamps_not_call_count() -> None:
    a = ScalarPID(kp=0.0, kd=0.0, ki=1.0, integral_limit=100.0, output_limit=100.0)
    b = ScalarPID(kp=0.0, kd=0.0, ki=1.0, integral_limit=100.0, output_limit=100.0)
    for t in (0.0, 1.0, 2.0):
        out_a = a.run(1.0, t)
    for t in (0.0, 0.1, 0.3, 1.7, 2.0):
        out_b = b.run(1.0, t)
    assert out_a == pytest.approx(2.0)
    assert out_b == pytest.approx(2.0)


def test_integral_limit_bounds_the_integral_term() -> None:
    pid = ScalarPID(kp=0.0, kd=0.0, ki=0.5, integral_limit=2.0, output_limit=100.0)
    for t in range(100):
        pid.run(10.0, float(t))
    assert pid.i == pytest.approx(2.0)
    pid.run(-10.0, 100.0)
    assert pid.i < 2.0, "wind-up would keep the integral pinned long after the error reverses"


def test_repeated_time_stamp_adds_no_integral_or_derivative() -> None:
    pid = ScalarPID(kp=1.0, kd=1.0, ki=1.0, integral_limit=100.0, output_limit=100.0)
    pid.run(0.0, 0.0)
    pid.run(1.0, 1.0)
    i, d = pid.i, pid.d
    pid.run(5.0, 1.0)
    assert (pid.i, pid.d) == (i, d)
    assert pid.p == 5.0


def test_derivative_is_averaged_over_five_taps() -> None:
    pid = ScalarPID(kp=0.0, kd=1.0, ki=0.0, integral_limit=0.0, output_limit=1000.0)
    pid.run(0.0, 0.0)
    assert pid.run(10.0, 1.0) == pytest.approx(10.0)
    assert pid.run(10.0, 2.0) == pytest.approx(5.0)
    for t in (3.0, 4.0, 5.0):
        pid.run(10.0, t)
    assert pid.d == pytest.approx(2.0)
    assert pid.run(10.0, 6.0) == pytest.approx(0.0), "the step leaves the window after 5 taps"


def test_derivative_respects_irregular_dt() -> None:
    pid = ScalarPID(kp=0.0, kd=1.0, ki=0.0, integral_limit=0.0, output_limit=1000.0)
    pid.run(0.0, 0.0)
    assert pid.run(1.0, 0.25) == pytest.approx(4.0)


def test_angular_error_wraps_across_north() -> None:
    pid = ScalarPID(kp=1.0, kd=1.0, ki=0.0, integral_limit=0.0, output_limit=1000.0, angular=True)
    pid.run(179.0, 0.0)
    out = pid.run(-179.0 + 360.0, 1.0)
    assert pid.error == pytest.approx(-179.0)
    assert pid.d == pytest.approx(2.0), "179 → -179 is a 2 degree change, not 358"
    assert out == pytest.approx(-177.0)


def test_reset_forgets_history() -> None:
    pid = ScalarPID(kp=0.0, kd=1.0, ki=1.0, integral_limit=10.0, output_limit=100.0)
    pid.run(0.0, 0.0)
    pid.run(5.0, 1.0)
    pid.reset()
    assert pid.run(5.0, 50.0) == 0.0


def _helm_block(*pairs: tuple[str, str]) -> Block:
    entries = [Entry(k, v, "m.moos", 20 + i) for i, (k, v) in enumerate(pairs)]
    return Block("ProcessConfig", "pHelm", "m.moos", 19, entries)


def test_gains_defaults_and_overrides() -> None:
    g = HelmGains.from_values(HELM_SCHEMA.read(
        _helm_block(("yaw_pid_kp", "0.8"), ("MAXRUDDER", "30"), ("AppTick", "5"))
    ))
    assert (g.yaw_kp, g.yaw_kd, g.yaw_ki, g.yaw_integral_limit) == (0.8, 0.2, 0.0, 2.0)
    assert (g.max_rudder, g.max_thrust, g.max_elevator) == (30.0, 100.0, 30.0)
    pid = g.yaw_pid()
    assert pid.run(170.0, 0.0) == 30.0


def test_line_tasks_steer_on_the_line_gains_and_heading_tasks_on_the_yaw_gains(
        tblock) -> None:
    """LINE_PID_* drive the tasks that hold a line (their own loop sits outside the heading
    loop and wants it stiff, without KD); YAW_PID_* every other steering task."""
    g = HelmGains.from_values(HELM_SCHEMA.read(
        _helm_block(("YAW_PID_KP", "0.6"), ("LINE_PID_KP", "1.3"), ("LINE_PID_KD", "0.05"))))
    assert (g.line_kp, g.line_kd, g.line_ki, g.line_integral_limit) == (1.3, 0.05, 0.0, 2.0)
    assert (HelmGains().line_kp, HelmGains().line_kd) == (1.0, 0.0)
    line = build_task(tblock("TrackLine", ("P1", "0,0"), ("P2", "100,0")), g)
    survey = build_task(tblock("Survey", ("Center", "0,0"), ("A", "50"), ("B", "20"),
                               ("Spacing", "10")), g)
    heading = build_task(tblock("ConstantHeading", ("Heading", "90")), g)
    assert (line.yaw_pid.kp, line.yaw_pid.kd) == (1.3, 0.05)
    assert (survey.yaw_pid.kp, survey.yaw_pid.kd) == (1.3, 0.05)
    assert (heading.yaw_pid.kp, heading.yaw_pid.kd) == (0.6, 0.2)


@pytest.mark.parametrize(("entries", "line"), [
    ((), (1.0, 0.0)),                                                # the product's defaults
    ((("YAW_PID_KP", "0.6"),), (0.6, 0.2)),                          # a MOOS mission's one loop
    ((("yaw_pid_kd", "0.3"), ("LINE_PID_KP", "1.3")), (1.3, 0.0)),   # both loops its own
])
def test_a_block_that_sets_only_yaw_pid_keeps_its_lines_on_it(entries, line) -> None:
    """The original pHelm has one heading loop: a mission that tunes YAW_PID_* and says nothing
    of LINE_PID_* has tuned its lines too, and they keep those gains."""
    block = _helm_block(*entries)
    g = HelmGains.from_values(HELM_SCHEMA.read(block), [e.key for e in block.entries])
    assert (g.line_kp, g.line_kd) == line
    assert (g.line_ki, g.line_integral_limit) == (0.0, 2.0)


@pytest.mark.parametrize(
    ("key", "value", "expected"),
    [
        ("YAW_PID_KQ", "1", "unknown setting 'YAW_PID_KQ' for pHelm (did you mean YAW_PID_KP?"),
        ("YAW_PID_KP", "-1", "YAW_PID_KP must be a number in [0, 1000], got -1"),
        ("MAXRUDDER", "0", "MAXRUDDER must be a number in (0, 90], got 0"),
        ("MAXTHRUST", "lots", "MAXTHRUST expects a number in (0, 100], got 'lots'"),
    ],
)
def test_bad_gains_are_refused_with_location(key: str, value: str, expected: str) -> None:
    with pytest.raises(MissionError) as err:
        HELM_SCHEMA.read(_helm_block(("AppTick", "4"), (key, value)))
    assert expected in str(err.value)
    assert str(err.value).startswith("m.moos:21:")
