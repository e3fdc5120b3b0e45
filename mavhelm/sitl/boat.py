"""Surface-boat dynamics: a 3-DOF (surge, sway, yaw) model driven by thrusters or a rudder.

The numbers are those of a BlueBoat-like twin-thruster catamaran: each thruster gives
-27.6 N (full reverse) to +55.2 N (full forward); quadratic hull drag is chosen so that full
forward settles at about 3.2 m/s and full reverse at about 2.3 m/s, and a full differential
turn at about 1 rad/s. The response is a first-order-ish lag of a fraction of a second in surge
and yaw, which is what a helm controller has to cope with on the water.

The model is pure: ``step(state, inputs, env, dt)`` returns a new state, ``truth(state, t, env)``
the ground truth the sensors observe. Water current carries the hull; wind adds a leeway drift.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

from mavhelm.sitl.truth import Truth


@dataclass(frozen=True)
class BoatParams:
    """Hull and propulsion constants (SI units)."""

    variant: str = "skid"  # "skid" (twin thrusters) or "rudder" (one thruster + rudder)
    mass: float = 25.0  # kg, including surge added mass
    inertia: float = 4.0  # kg m², including added inertia
    thrust_fwd: float = 55.2  # N per thruster at full forward
    thrust_rev: float = 27.6  # N per thruster at full reverse (magnitude)
    drag_lin: float = 2.0  # N/(m/s), keeps low-speed decay finite
    drag_fwd: float = (2 * 55.2 - 2.0 * 3.2) / 3.2**2  # N/(m/s)² → 3.2 m/s top speed
    drag_rev: float = (2 * 27.6 - 2.0 * 2.3) / 2.3**2  # N/(m/s)² → 2.3 m/s top reverse
    sway_drag: float = 60.0  # N/(m/s)², sway is strongly damped by the hulls
    sway_lin: float = 20.0
    thruster_sep: float = 0.6  # m between thruster axes (skid)
    yaw_drag: float = 20.0  # N m/(rad/s)² → ~1 rad/s at full differential
    yaw_lin: float = 4.0  # N m/(rad/s)
    rudder_gain: float = 1.5  # N m per (m/s)² of flow per unit rudder
    rudder_wash: float = 0.35  # fraction of thrust wash over the rudder (steer at rest)
    leeway: float = 0.03  # drift speed as a fraction of wind speed


@dataclass(frozen=True)
class BoatState:
    x: float = 0.0  # m east
    y: float = 0.0  # m north
    heading: float = 0.0  # rad clockwise from north
    u: float = 0.0  # surge, m/s through the water
    v: float = 0.0  # sway, m/s (starboard positive)
    r: float = 0.0  # yaw rate, rad/s (clockwise positive)


@dataclass(frozen=True)
class Environment:
    """Things the vehicle does not control: current and wind set and drift, seabed depth."""

    current_east: float = 0.0  # m/s the water moves east
    current_north: float = 0.0
    wind_speed: float = 0.0  # m/s
    wind_from: float = 0.0  # degrees the wind blows FROM, clockwise from north
    water_depth: float = 20.0  # m

    def drift(self, leeway: float) -> tuple[float, float]:
        """Earth-frame (east, north) velocity added to the hull by current and wind."""
        return _drift(self, leeway)


@lru_cache(maxsize=64)
def _drift(env: Environment, leeway: float) -> tuple[float, float]:
    to = math.radians(env.wind_from + 180.0)
    w = leeway * env.wind_speed
    return (env.current_east + w * math.sin(to), env.current_north + w * math.cos(to))


def thruster_force(cmd: float, p: BoatParams) -> float:
    """Thrust in newtons for a normalised command in [-1, 1] (asymmetric like real props)."""
    cmd = max(-1.0, min(1.0, cmd))
    return cmd * (p.thrust_fwd if cmd >= 0.0 else p.thrust_rev)


def step(state: BoatState, inputs: tuple[float, float], env: Environment, dt: float,
         p: BoatParams = BoatParams()) -> BoatState:
    """Advance the hull by dt seconds.

    inputs: skid → (left thruster, right thruster); rudder → (rudder, throttle); each in [-1, 1],
    rudder positive turns to starboard.
    """
    u, v, r = state.u, state.v, state.r
    if p.variant == "skid":
        fl = thruster_force(inputs[0], p)
        fr = thruster_force(inputs[1], p)
        x_force = fl + fr
        n_moment = (fl - fr) * 0.5 * p.thruster_sep
    else:
        rudder = max(-1.0, min(1.0, inputs[0]))
        thrust = 2.0 * thruster_force(inputs[1], p)
        x_force = thrust
        flow = u * abs(u) + p.rudder_wash * abs(thrust) / max(p.drag_fwd, 1e-6)
        n_moment = p.rudder_gain * rudder * flow
    drag_u = (p.drag_fwd if u >= 0.0 else p.drag_rev) * u * abs(u) + p.drag_lin * u
    du = (x_force - drag_u) / p.mass + v * r
    dv = -(p.sway_drag * v * abs(v) + p.sway_lin * v) / p.mass - u * r * 0.2
    dr = (n_moment - p.yaw_drag * r * abs(r) - p.yaw_lin * r) / p.inertia
    u2 = u + du * dt
    v2 = v + dv * dt
    r2 = r + dr * dt
    h = state.heading + 0.5 * (r + r2) * dt
    s, c = math.sin(h), math.cos(h)
    ce, cn = env.drift(p.leeway)
    ve = u2 * s + v2 * c + ce
    vn = u2 * c - v2 * s + cn
    return BoatState(state.x + ve * dt, state.y + vn * dt, h % (2 * math.pi), u2, v2, r2)


def truth(state: BoatState, t: float, env: Environment, p: BoatParams = BoatParams()) -> Truth:
    """The ground truth of a boat state."""
    s, c = math.sin(state.heading), math.cos(state.heading)
    ce, cn = env.drift(p.leeway)
    return Truth(
        t=t, x=state.x, y=state.y, heading=math.degrees(state.heading) % 360.0,
        yaw_rate=math.degrees(state.r), surge=state.u, sway=state.v,
        vx=state.u * s + state.v * c + ce, vy=state.u * c - state.v * s + cn,
        z=0.0, water_depth=env.water_depth,
    )
