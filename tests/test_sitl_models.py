"""The vehicle models alone: the numbers a helm tuned on the simulator will rely on."""

from __future__ import annotations

import math

import pytest

from mavhelm.sitl import boat, rover


def _settle(step, state, inputs, env, params, seconds=60.0, dt=0.02):
    for _ in range(int(seconds / dt)):
        state = step(state, inputs, env, dt, params)
    return state


def test_skid_boat_top_speeds_and_turn_rate():
    env, p = boat.Environment(), boat.BoatParams()
    assert _settle(boat.step, boat.BoatState(), (1, 1), env, p).u == pytest.approx(3.2, abs=0.05)
    assert _settle(boat.step, boat.BoatState(), (-1, -1), env, p).u == pytest.approx(-2.3,
                                                                                     abs=0.05)
    spin = _settle(boat.step, boat.BoatState(), (1, -1), env, p)
    assert spin.r == pytest.approx(1.0, abs=0.1)
    assert boat.thruster_force(1.0, p) == 55.2 and boat.thruster_force(-1.0, p) == -27.6


def test_boat_surge_lags_the_throttle():
    env, p = boat.Environment(), boat.BoatParams()
    s = _settle(boat.step, boat.BoatState(), (1, 1), env, p, seconds=0.5)
    assert 0.5 < s.u < 2.9


def test_rudder_boat_turns_only_with_flow():
    env, p = boat.Environment(), boat.BoatParams(variant="rudder")
    still = _settle(boat.step, boat.BoatState(), (1.0, 0.0), env, p)
    assert still.r == pytest.approx(0.0, abs=1e-6)
    going = _settle(boat.step, boat.BoatState(), (1.0, 1.0), env, p)
    assert 0.5 < going.r < 1.2 and going.u > 2.5


def test_current_and_wind_carry_the_boat():
    env = boat.Environment(current_east=0.5, wind_speed=10.0, wind_from=0.0)
    p = boat.BoatParams()
    s = _settle(boat.step, boat.BoatState(), (0, 0), env, p, seconds=10.0)
    assert s.x == pytest.approx(5.0, abs=0.1)
    assert s.y == pytest.approx(-10.0 * p.leeway * 10.0, abs=0.1)  # blown downwind (south)
    t = boat.truth(s, 10.0, env, p)
    assert t.vx == pytest.approx(0.5) and t.surge == pytest.approx(0.0, abs=1e-9)


def test_truth_conventions():
    env, p = boat.Environment(), boat.BoatParams()
    s = _settle(boat.step, boat.BoatState(heading=math.radians(90)), (1, 1), env, p, 10.0)
    t = boat.truth(s, 10.0, env, p)
    assert t.heading == pytest.approx(90.0, abs=0.01)
    assert t.vx == pytest.approx(3.2, abs=0.05) and abs(t.vy) < 1e-6
    turning = boat.truth(_settle(boat.step, boat.BoatState(), (1, 0.5), env, p, 1.0), 1, env, p)
    assert turning.yaw_rate > 0  # more thrust on the left turns clockwise (starboard)


def test_ackermann_rover_turn_limits_and_odometer():
    env, p = boat.Environment(), rover.RoverParams()
    s = _settle(rover.step, rover.RoverState(), (0.0, 1.0), env, p, seconds=5.0)
    assert s.speed == pytest.approx(p.max_speed, abs=0.01)
    assert s.odometer > 15.0
    turning = _settle(rover.step, rover.RoverState(), (1.0, 1.0), env, p, seconds=5.0)
    assert 0 < turning.r <= p.max_turn_rate
    stopped = _settle(rover.step, rover.RoverState(), (1.0, 0.0), env, p, seconds=5.0)
    assert stopped.r == 0.0  # an Ackermann rover cannot turn on the spot


def test_skid_rover_turns_on_the_spot():
    env, p = boat.Environment(), rover.RoverParams(variant="skid")
    s = _settle(rover.step, rover.RoverState(), (1.0, -1.0), env, p, seconds=3.0)
    assert s.r == pytest.approx(p.max_turn_rate, rel=0.01) and abs(s.speed) < 1e-9
    t = rover.truth(s, 3.0, env, p)
    assert t.x == pytest.approx(0.0) and t.y == pytest.approx(0.0)
