"""Surface-boat dynamics: a 3-DOF (surge, sway, yaw) model driven by thrusters or a rudder.

The numbers are those of a BlueBoat-like twin-thruster catamaran: each thruster gives
-27.6 N (full reverse) to +55.2 N (full forward); quadratic hull drag is chosen so that full
forward settles at about 3.2 m/s and full reverse at about 2.3 m/s, and a full differential
turn at about 1 rad/s. The response is a first-order-ish lag of a fraction of a second in surge
and yaw, which is what a helm controller has to cope with on the water.

The model is pure: ``step(state, inputs, env, dt)`` returns a new state, ``truth(state, t, env)``
the ground truth the sensors observe. Water current carries the hull; wind adds a leeway drift.

Below it, ``sitl_step``/``sitl_truth`` with ``SitlBoatParams`` and ``SimEnvironment`` are
ArduPilot's own SITL motorboat (``--model motorboat``/``motorboat-skid``), matched to the real
SITL; ``mavhelm.sitl.models`` serves both behind one interface (docs/sim-vehicles.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, fields
from functools import cached_property
from typing import Any, NamedTuple

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


class BoatState(NamedTuple):
    """The hull's state (immutable; a NamedTuple, as one is made every physics step)."""

    x: float = 0.0  # m east
    y: float = 0.0  # m north
    heading: float = 0.0  # rad clockwise from north
    u: float = 0.0  # surge, m/s through the water
    v: float = 0.0  # sway, m/s (starboard positive)
    r: float = 0.0  # yaw rate, rad/s (clockwise positive)
    roll: float = 0.0  # rad, starboard down positive (waves; the SITL hull only)
    pitch: float = 0.0  # rad, bow up positive
    wave_phase: float = 0.0  # rad, where on the swell the hull sits


@dataclass(frozen=True)
class Environment:
    """Things the vehicle does not control: current and wind set and drift, seabed depth."""

    current_east: float = 0.0  # m/s the water moves east
    current_north: float = 0.0
    wind_speed: float = 0.0  # m/s
    wind_from: float = 0.0  # degrees the wind blows FROM, clockwise from north
    water_depth: float = 20.0  # m

    @cached_property
    def _wind_toward(self) -> tuple[float, float]:
        """(sin, cos) of the direction the wind blows toward, worked out once."""
        to = math.radians(self.wind_from + 180.0)
        return math.sin(to), math.cos(to)

    def drift(self, leeway: float) -> tuple[float, float]:
        """Earth-frame (east, north) velocity added to the hull by current and wind (asked
        several times a physics step, hence the direction kept above)."""
        w = leeway * self.wind_speed
        sin_to, cos_to = self._wind_toward
        return (self.current_east + w * sin_to, self.current_north + w * cos_to)


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


# ---------------------------------------------------------------------------------------------
# ArduPilot's own SITL boats (``--model motorboat`` / ``motorboat-skid``), matched to the real
# Rover 4.8-dev SITL's step responses (docs/sim-vehicles.md). Upstream the motorboat is the
# sailboat model with the sail removed (SIM_Sailboat.cpp, SIM_MotorBoat.h): a 2 kg hull, thrust
# proportional to the throttle servo, drag quadratic in speed, and a yaw rate set at once by the
# steering through a turning circle, not by a rudder moment. The figures that follow from it
# (10 m/s flat out, 0.4 s to 63 % of it, 425 deg/s turns at 6.7 m/s) are not those of a real
# boat, but they are what a companion tested against the real SITL meets.
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SimEnvironment:
    """The simulated world, held under ArduPilot's own SITL parameter names so a ``.parm`` file
    or a PARAM_SET reaches it unchanged. Defaults are ArduPilot's (read back from the 4.8-dev
    SITL); ``motorboat.parm`` sets SIM_WIND_SPD 3, SIM_WIND_T 1 and SIM_WAVE_ENABLE 1.

    SIM_DEPTH is mavhelm's own (the echo sounder's seabed), and so is SIM_CURRENT_SPD/DIR, the
    water current of mavhelm's own hulls (models.HULL_MODELS). ``armed``: the SITL moves the hull
    with the tide and rocks it on the waves only while the vehicle is armed."""

    SIM_WIND_SPD: float = 0.0  # m/s
    SIM_WIND_DIR: float = 180.0  # degrees the wind comes from
    SIM_WIND_T: int = 0  # wind profile with height; a surface vehicle sits at 0 m
    SIM_WAVE_ENABLE: int = 0  # 0 off, 1 roll and pitch, 2 also heave
    SIM_WAVE_AMP: float = 0.5  # m, crest to trough
    SIM_WAVE_DIR: float = 0.0  # the SITL uses this number as radians in the hull's frame
    SIM_WAVE_LENGTH: float = 10.0  # m
    SIM_WAVE_SPEED: float = 0.5  # m/s
    SIM_TIDE_DIR: float = 0.0  # degrees the tidal stream comes from
    SIM_TIDE_SPEED: float = 0.0  # m/s
    SIM_DEPTH: float = 20.0  # m of water under the hull (mavhelm)
    SIM_CURRENT_SPD: float = 0.0  # m/s of water current (mavhelm's own hulls only)
    SIM_CURRENT_DIR: float = 0.0  # degrees the current flows *to* (mavhelm's own hulls only)
    armed: bool = True

    @classmethod
    def from_params(cls, params: Mapping[str, float], armed: bool = True) -> SimEnvironment:
        """The environment named in a parameter table (other names are ignored)."""
        known = {f.name for f in fields(cls)} - {"armed"}
        values: dict[str, Any] = {k: params[k] for k in known if k in params}
        for name in ("SIM_WIND_T", "SIM_WAVE_ENABLE"):
            if name in values:
                values[name] = int(values[name])
        return cls(armed=armed, **values)

    def tide(self) -> tuple[float, float]:
        """Earth-frame (east, north) velocity of the water, m/s (zero while disarmed)."""
        if not self.armed or self.SIM_TIDE_SPEED == 0.0:
            return (0.0, 0.0)
        d = math.radians(self.SIM_TIDE_DIR)
        return (-math.sin(d) * self.SIM_TIDE_SPEED, -math.cos(d) * self.SIM_TIDE_SPEED)

    def wind(self) -> tuple[float, float]:
        """Earth-frame (east, north) velocity of the air, m/s."""
        d = math.radians(self.SIM_WIND_DIR)
        return (-math.sin(d) * self.SIM_WIND_SPD, -math.cos(d) * self.SIM_WIND_SPD)


@dataclass(frozen=True)
class SitlBoatParams:
    """The SITL motorboat's constants. ``skid``: inputs are the left and right thrusters
    (SERVO1/SERVO3 functions 73/74) instead of steering and throttle (26/70)."""

    skid: bool = False
    mass: float = 2.0  # kg
    thrust_full: float = 50.0  # N at full throttle, ahead or astern
    hull_drag: float = 0.5  # N/(m/s)², so thrust equals drag at 10 m/s
    turning_circle: float = 1.8  # m, diameter at full steering
    steering_angle_max: float = 35.0  # degrees of "rudder" at full steering
    skid_spin_rate: float = 5.0 * math.pi  # deg/s per unit steering at exactly zero speed
    wave_gain: float = 1.0  # 1/s, how fast roll and pitch follow the wave slope
    leeway: float = 0.0  # drift as a fraction of wind speed: the SITL hull has no windage


def sitl_turn_rate(steering: float, speed: float, p: SitlBoatParams) -> float:
    """Yaw rate (rad/s, clockwise) the SITL hull turns at: one lap of the turning circle that the
    steering sets per lap time at this speed; none without way on, except a skid boat at rest."""
    if steering == 0.0:
        return 0.0
    if speed == 0.0:
        return math.radians(steering * p.skid_spin_rate) if p.skid else 0.0
    diameter = (p.turning_circle * math.sin(math.radians(p.steering_angle_max))
                / math.sin(math.radians(steering * p.steering_angle_max)))
    return 2.0 * speed / diameter


def _wave_angle(state: BoatState, env: SimEnvironment, dt: float, ve: float, vn: float,
                gain: float) -> tuple[float, float, float]:
    """(roll, pitch, phase) after dt: the hull leans towards the slope of a sine swell under it
    with a first-order lag, as the SITL's waves do (angles in radians)."""
    if env.SIM_WAVE_ENABLE == 0 or not env.armed or env.SIM_WAVE_AMP == 0.0:
        return (state.roll - state.roll * gain * dt, state.pitch - state.pitch * gain * dt, 0.0)
    wave_dir = math.radians(env.SIM_WAVE_DIR)
    # the SITL takes the boat's speed along the swell with north and east swapped; kept, so
    # the encounter period matches it
    along = vn * math.sin(wave_dir) + ve * math.cos(wave_dir)
    phase = state.wave_phase + (env.SIM_WAVE_SPEED - along) * dt / env.SIM_WAVE_LENGTH * 2 * math.pi
    phase %= 2 * math.pi
    slope = 0.5 * env.SIM_WAVE_AMP * (2 * math.pi / env.SIM_WAVE_LENGTH) * math.cos(phase)
    angle = math.atan(slope)
    yaw = state.heading if state.heading <= math.pi else state.heading - 2 * math.pi
    rel = env.SIM_WAVE_DIR - yaw  # degrees minus radians, as upstream does
    roll = state.roll + (math.sin(rel) * angle - state.roll) * gain * dt
    pitch = state.pitch + (math.cos(rel) * angle - state.pitch) * gain * dt
    return (roll, pitch, phase)


def sitl_step(state: BoatState, inputs: tuple[float, float], env: SimEnvironment, dt: float,
              p: SitlBoatParams = SitlBoatParams()) -> BoatState:
    """Advance the SITL motorboat by dt. inputs: (steering, throttle), or (left, right) when
    ``p.skid``, each the servo output normalised to [-1, 1] ((PWM − 1500) / 500)."""
    a = max(-1.0, min(1.0, inputs[0]))
    b = max(-1.0, min(1.0, inputs[1]))
    steering, throttle = (a - b, 0.5 * (a + b)) if p.skid else (a, b)
    u = state.u
    r = sitl_turn_rate(steering, u, p)
    heading = (state.heading + r * dt) % (2 * math.pi)
    drag = p.hull_drag * u * abs(u)
    u2 = u + (throttle * p.thrust_full - drag) / p.mass * dt
    s, c = math.sin(heading), math.cos(heading)
    te, tn = env.tide()
    we, wn = env.wind()
    ve = u2 * s + te + p.leeway * we
    vn = u2 * c + tn + p.leeway * wn
    moved = BoatState(state.x + ve * dt, state.y + vn * dt, heading, u2, 0.0, r,
                      state.roll, state.pitch, state.wave_phase)
    roll, pitch, phase = _wave_angle(moved, env, dt, ve, vn, p.wave_gain)
    return moved._replace(roll=roll, pitch=pitch, wave_phase=phase)


def sitl_truth(state: BoatState, t: float, env: SimEnvironment,
               p: SitlBoatParams = SitlBoatParams()) -> Truth:
    """The ground truth of a SITL motorboat state."""
    s, c = math.sin(state.heading), math.cos(state.heading)
    te, tn = env.tide()
    we, wn = env.wind()
    return Truth(
        t=t, x=state.x, y=state.y, heading=math.degrees(state.heading) % 360.0,
        yaw_rate=math.degrees(state.r), surge=state.u, sway=0.0,
        vx=state.u * s + te + p.leeway * we, vy=state.u * c + tn + p.leeway * wn,
        z=0.0, water_depth=env.SIM_DEPTH, roll=math.degrees(state.roll),
        pitch=math.degrees(state.pitch),
    )
