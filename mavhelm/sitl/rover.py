"""Ground-rover kinematics: Ackermann (car-like) or skid-steer, with speed and turn-rate limits.

A rover does not drift: it goes where its wheels point, with first-order lags in speed and
steering that give a controller realistic delay. ``step(state, inputs, env, dt)`` is pure.
With ``turning_circle`` set (``models.SITL_ROVER``/``SITL_ROVER_SKID``) the same step is
ArduPilot's SITL rover, matched to the real SITL (docs/sim-vehicles.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from mavhelm.sitl.boat import Environment
from mavhelm.sitl.truth import Truth


@dataclass(frozen=True)
class RoverParams:
    variant: str = "ackermann"  # "ackermann" or "skid"
    max_speed: float = 4.0  # m/s at full throttle
    max_reverse: float = 2.0  # m/s at full reverse
    speed_tau: float = 0.6  # s, throttle → speed lag
    wheelbase: float = 0.5  # m (ackermann)
    max_steer: float = math.radians(30.0)  # wheel angle at full steering (ackermann)
    steer_tau: float = 0.15  # s, steering servo lag
    max_turn_rate: float = math.radians(120.0)  # rad/s, hard limit on yaw rate
    turn_tau: float = 0.25  # s, skid yaw-rate lag
    # ArduPilot's SITL rover (SIM_Rover.cpp) sets the yaw rate from a turning circle instead of
    # a wheelbase: one lap of ``turning_circle`` × sin(max_steer) / sin(steering × max_steer)
    # metres (diameter). None keeps the bicycle model above.
    turning_circle: float | None = None


class RoverState(NamedTuple):
    """The rover's state (immutable; a NamedTuple, as one is made every physics step)."""

    x: float = 0.0
    y: float = 0.0
    heading: float = 0.0  # rad clockwise from north
    speed: float = 0.0  # m/s along the heading
    steer: float = 0.0  # ackermann wheel angle (rad); skid: unused
    r: float = 0.0  # yaw rate rad/s clockwise
    odometer: float = 0.0  # m travelled (signed, as wheel encoders count)


def _lag(value: float, target: float, tau: float, dt: float) -> float:
    return value + (target - value) * min(1.0, dt / max(tau, 1e-6))


def _circle_rate(speed: float, steer: float, p: RoverParams) -> float:
    """The SITL's yaw rate: a lap of the turning circle the wheel angle sets, at this speed."""
    if abs(steer) < 1e-9 or abs(speed) < 1e-6 or p.turning_circle is None:
        return 0.0
    diameter = p.turning_circle * math.sin(p.max_steer) / math.sin(steer)
    return 2.0 * speed / diameter


def step(state: RoverState, inputs: tuple[float, float], env: Environment, dt: float,
         p: RoverParams = RoverParams()) -> RoverState:
    """Advance by dt. inputs: ackermann → (steering, throttle); skid → (left, right), in [-1, 1]."""
    if p.variant == "skid":
        left = max(-1.0, min(1.0, inputs[0]))
        right = max(-1.0, min(1.0, inputs[1]))
        thr = 0.5 * (left + right)
        steer_cmd = 0.5 * (left - right)
        target_speed = thr * (p.max_speed if thr >= 0 else p.max_reverse)
        speed = _lag(state.speed, target_speed, p.speed_tau, dt)
        r = _lag(state.r, steer_cmd * p.max_turn_rate, p.turn_tau, dt)
        steer = 0.0
    else:
        steer_cmd = max(-1.0, min(1.0, inputs[0]))
        thr = max(-1.0, min(1.0, inputs[1]))
        target_speed = thr * (p.max_speed if thr >= 0 else p.max_reverse)
        speed = _lag(state.speed, target_speed, p.speed_tau, dt)
        steer = _lag(state.steer, steer_cmd * p.max_steer, p.steer_tau, dt)
        if p.turning_circle is None:
            r = speed * math.tan(steer) / p.wheelbase
        else:
            r = _circle_rate(state.speed, steer, p)
    r = max(-p.max_turn_rate, min(p.max_turn_rate, r))
    h = state.heading + 0.5 * (state.r + r) * dt
    v = 0.5 * (state.speed + speed)
    return RoverState(x=state.x + v * math.sin(h) * dt, y=state.y + v * math.cos(h) * dt,
                      heading=h % (2 * math.pi), speed=speed, steer=steer, r=r,
                      odometer=state.odometer + v * dt)


def truth(state: RoverState, t: float, env: Environment, p: RoverParams = RoverParams()) -> Truth:
    s, c = math.sin(state.heading), math.cos(state.heading)
    return Truth(
        t=t, x=state.x, y=state.y, heading=math.degrees(state.heading) % 360.0,
        yaw_rate=math.degrees(state.r), surge=state.speed, sway=0.0,
        vx=state.speed * s, vy=state.speed * c, z=0.0, water_depth=0.0,
    )
