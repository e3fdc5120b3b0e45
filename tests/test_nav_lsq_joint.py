"""The LSQ's one joint solve (spec 2.2, "five state": X, Y, Z, heading, tide) over whatever
pose-proportional observations a window holds, on synthetic data with known truth."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavhelm.nav.ekf import Beacon, Depth, Position, Range, Yaw
from mavhelm.nav.lsq import LSQ, solve, solve_joint

BEACONS = {"1": Beacon("1", 0.0, 0.0, -20.0), "2": Beacon("2", 100.0, 0.0, -20.0),
           "3": Beacon("3", 0.0, 100.0, -20.0), "4": Beacon("4", 100.0, 100.0, -20.0)}
TRUTH = (30.0, 40.0)
YAW = math.radians(-30.0)


def _range(name: str, t: float = 0.0, lever: tuple[float, float, float] = (0.0, 0.0, 0.0),
           noise: float = 0.0, sigma: float = 0.3) -> Range:
    """A slant range in the vehicle's plane from a sensor at ``lever`` (body x starboard,
    y forward) on a vehicle at TRUTH with yaw YAW."""
    b = BEACONS[name]
    s, c = math.sin(YAW), math.cos(YAW)
    px = TRUTH[0] + lever[0] * c - lever[1] * s
    py = TRUTH[1] + lever[0] * s + lever[1] * c
    return Range(t, name, math.hypot(px - b.x, py - b.y, b.z) + noise, sigma, lever)


def test_ranges_alone_give_the_position_and_say_what_is_unobserved() -> None:
    fix = solve_joint([_range(n) for n in "123"], [], BEACONS)
    assert fix is not None
    assert (fix.x, fix.y) == pytest.approx(TRUTH, abs=1e-4)
    assert fix.yaw is None and fix.z is None and fix.depth is None and fix.tide is None
    assert fix.unobserved == ("Z", "HEADING", "TIDE")


def test_the_joint_solve_is_the_range_solve_when_nothing_else_is_seen() -> None:
    rng = np.random.default_rng(3)
    ranges = [_range(n, noise=float(rng.normal(0, 0.3))) for n in "1234"]
    joint, alone = solve_joint(ranges, [], BEACONS), solve(ranges, BEACONS)
    assert joint is not None and alone is not None
    assert (joint.x, joint.y, joint.chi2, joint.dof) == pytest.approx(
        (alone.x, alone.y, alone.chi2, alone.dof), abs=1e-6)
    assert joint.sigma == pytest.approx(alone.sigma)


def test_every_state_from_one_solve() -> None:
    depth, tide = 12.0, 1.5
    poses = [Yaw(0.0, YAW + d, 0.02) for d in (-0.01, 0.0, 0.01)]
    poses += [Depth(0.0, depth, 0.05, (0.0, 0.0, -0.5)), Depth(0.1, depth, 0.05, (0, 0, -0.5))]
    lsq = LSQ(BEACONS.values())
    lsq.tide, lsq.tide_sigma = tide, 0.1
    for p in poses:
        lsq.add_pose(p)
    fix = None
    for k, name in enumerate("123"):
        fix = lsq.add(_range(name, 0.1 * k))
    assert fix is not None
    assert (fix.x, fix.y) == pytest.approx(TRUTH, abs=1e-4)
    assert fix.yaw == pytest.approx(YAW, abs=1e-6)
    assert fix.tide == pytest.approx(tide)
    assert fix.z == pytest.approx(tide - depth + 0.5)  # the origin, 0.5 m above the sensor
    assert fix.depth == pytest.approx(depth)
    assert fix.unobserved == ()


def test_a_lever_ties_the_heading_into_the_position() -> None:
    # an antenna 3 m forward and 1 m to starboard: the ranges are its, not the origin's
    lever = (1.0, 3.0, 0.0)
    ranges = [_range(n, lever=lever) for n in "1234"]
    fix = solve_joint(ranges, [Yaw(0.0, YAW, math.radians(1.0))], BEACONS)
    assert fix is not None
    assert (fix.x, fix.y) == pytest.approx(TRUTH, abs=1e-4)
    assert fix.yaw == pytest.approx(YAW, abs=1e-6)
    wrong = solve_joint(ranges, [Yaw(0.0, YAW + math.pi / 2, math.radians(1.0))], BEACONS)
    assert wrong is not None and math.dist((wrong.x, wrong.y), TRUTH) > 1.0


def test_an_xy_fix_joins_the_solve_and_observes_the_position_alone() -> None:
    fix = solve_joint([], [Position(0.0, 30.0, 40.0, 2.0)], BEACONS)
    assert fix is not None and (fix.x, fix.y) == pytest.approx(TRUTH)
    assert fix.sigma == pytest.approx(2.0)
    rng = np.random.default_rng(5)
    ranges = [_range(n, noise=float(rng.normal(0, 0.3))) for n in "123"]
    alone = solve_joint(ranges, [], BEACONS)
    joint = solve_joint(ranges, [Position(0.0, 30.0, 40.0, 0.3)], BEACONS)
    assert alone is not None and joint is not None
    assert math.dist((joint.x, joint.y), TRUTH) < math.dist((alone.x, alone.y), TRUTH)
    assert joint.sigma < alone.sigma and joint.dof == alone.dof + 2


def test_a_glitched_xy_fix_is_dropped_by_the_rejection() -> None:
    lsq = LSQ(BEACONS.values())
    lsq.add_pose(Position(0.0, 80.0, 90.0, 0.5))  # 70 m off
    fix = None
    for k, name in enumerate("123"):
        fix = lsq.add(_range(name, 0.1 * k))
    assert fix is not None and (fix.x, fix.y) == pytest.approx(TRUTH, abs=1e-3)
    assert lsq.rejected == 1


def test_a_depth_alone_cannot_part_z_from_the_tide() -> None:
    fix = solve_joint([_range(n) for n in "123"], [Depth(0.0, 5.0, 0.05)], BEACONS, tide=0.0)
    assert fix is not None and fix.z == pytest.approx(-5.0) and fix.tide is None
    assert "TIDE" in fix.unobserved and "Z" not in fix.unobserved
