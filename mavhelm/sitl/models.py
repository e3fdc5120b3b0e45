"""The vehicle models, one registry by name (``--model``): ArduPilot's SITL models
(``motorboat``, ``motorboat-skid``, ``rover``, ``rover-skid``, as the real binary's ``--model``)
and mavhelm's own hulls (``mavhelm-boat``, the default, ``mavhelm-boat-rudder``,
``mavhelm-rover``, ``mavhelm-rover-skid``), each behind one interface.

A caller (the simulator) picks a model by name and never asks what kind it is: the model says
which stock ``.parm`` files the real SITL is started with, which servo functions it expects on
SERVO1 and SERVO3, turns those two PWMs into its inputs the way SITL does, and steps and reports
its state. Figures are matched to the real Rover 4.8-dev SITL (docs/sim-vehicles.md;
benchmarks/bench_step_response.py compares them; tests/test_sitl_models.py pins them).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

from mavhelm.sitl import boat, rover
from mavhelm.sitl.boat import SimEnvironment
from mavhelm.sitl.truth import Truth

# SERVOn_FUNCTION values (ArduPilot SRV_Channel::Aux_servo_function_t)
FN_STEERING = 26
FN_THROTTLE = 70
FN_THROTTLE_LEFT = 73
FN_THROTTLE_RIGHT = 74

MAV_TYPE_GROUND_ROVER = 10
MAV_TYPE_SURFACE_BOAT = 11

# A motor output as the autopilot describes it: (channel, function, min, max, trim, reversed)
ServoMap = Sequence[tuple[int, int, float, float, float, bool]]


class Motion(NamedTuple):
    """What the autopilot's sensors and EKF need of the vehicle each step, whatever it is:
    heading (rad clockwise from north), yaw rate (rad/s), speed through the water or over the
    ground along and across the hull (sway None: on wheels, it cannot slip; the EKF then dead
    reckons along the heading and the wheel encoders count), earth velocity east/north (m/s)."""

    heading: float
    yaw_rate: float
    surge: float
    sway: float | None
    vx: float
    vy: float


def servo_to_unit(pwm: float) -> float:
    """A servo PWM as SITL's physics reads it: (PWM − 1500) / 500, clipped to [-1, 1]."""
    return max(-1.0, min(1.0, (pwm - 1500.0) / 500.0))


@dataclass(frozen=True)
class VehicleModel:
    """One vehicle model behind the interface the simulator uses.

    ``servo_functions``: the SERVO1 and SERVO3 functions the stock parameter files give this
    model (26/70 steering/throttle, 73/74 left/right throttle). Like the real SITL, the physics
    reads servo outputs 1 and 3 by position, whatever function they hold.
    ``defaults``: the stock files ``--defaults`` loads for this model, in order.
    """

    name: str
    vehicle: str  # "boat" or "rover"
    mav_type: int  # HEARTBEAT type
    params: Any
    defaults: tuple[str, ...]
    servo_functions: tuple[int, int]
    _new_state: Callable[[float], Any]
    _step: Callable[..., Any]
    _truth: Callable[..., Truth]
    _motion: Callable[..., Motion]
    # None: SITL's way, outputs 1 and 3 by position; else (outputs, servo map) → inputs
    _inputs: Callable[[Sequence[int], ServoMap], tuple[float, float]] | None = None
    # the autopilot's parameters start from ArduPilot's own defaults (the SITL models, as the
    # real SITL), not from the values tuned to mavhelm's hulls (autopilot.default_params)
    firmware_defaults: bool = False

    @property
    def skid(self) -> bool:
        return self.servo_functions == (FN_THROTTLE_LEFT, FN_THROTTLE_RIGHT)

    def initial_state(self, heading: float = 0.0) -> Any:
        """At rest at the origin, heading in radians clockwise from north."""
        return self._new_state(heading % (2 * math.pi))

    def inputs_from_servos(self, servo1_pwm: float, servo3_pwm: float) -> tuple[float, float]:
        """The model's two inputs from servo outputs 1 and 3: (steering, throttle) or (left,
        right), each in [-1, 1]."""
        return (servo_to_unit(servo1_pwm), servo_to_unit(servo3_pwm))

    def inputs_from_outputs(self, outputs: Sequence[int],
                            servo_map: ServoMap) -> tuple[float, float]:
        """The model's inputs from the 16 servo outputs: the SITL models read outputs 1 and 3
        by position (``inputs_from_servos``); mavhelm's own hulls go through the motor outputs'
        functions and ranges (``servo_map``, the autopilot's SERVOn_* table)."""
        if self._inputs is None:
            return self.inputs_from_servos(outputs[0], outputs[2])
        return self._inputs(outputs, servo_map)

    def step(self, state: Any, inputs: tuple[float, float], env: SimEnvironment,
             dt: float) -> Any:
        """The state dt seconds later under these inputs."""
        return self._step(state, inputs, env, dt, self.params)

    def truth(self, state: Any, t: float, env: SimEnvironment) -> Truth:
        """What the sensors of this vehicle observe in this state."""
        return self._truth(state, t, env, self.params)

    def motion(self, state: Any, env: SimEnvironment) -> Motion:
        """The state's heading, rates and velocities for the autopilot's estimator."""
        return self._motion(state, env, self.params)


def _rover_step(state: rover.RoverState, inputs: tuple[float, float], env: SimEnvironment,
                dt: float, p: rover.RoverParams) -> rover.RoverState:
    return rover.step(state, inputs, _LAND, dt, p)


def _rover_truth(state: rover.RoverState, t: float, env: SimEnvironment,
                 p: rover.RoverParams) -> Truth:
    return rover.truth(state, t, _LAND, p)


def _rover_motion(state: rover.RoverState, env: SimEnvironment, p: rover.RoverParams) -> Motion:
    s, c = math.sin(state.heading), math.cos(state.heading)
    return Motion(state.heading, state.r, state.speed, None, state.speed * s, state.speed * c)


def _sitl_boat_motion(state: boat.BoatState, env: SimEnvironment,
                      p: boat.SitlBoatParams) -> Motion:
    tr = boat.sitl_truth(state, 0.0, env, p)
    return Motion(state.heading, state.r, state.u, 0.0, tr.vx, tr.vy)


_LAND = boat.Environment(water_depth=0.0)

# SIM_Rover.cpp: 20 m/s at full throttle, 10 m/s² at full error (speed lag 2 s), a 1.8 m turning
# circle at 35° of steering, yaw rate capped at 360°/s; skid: 4 m/s, 14 m/s² (lag 0.29 s),
# 140°/s per unit of (left − right). Confirmed on the real SITL (docs/sim-vehicles.md).
SITL_ROVER = rover.RoverParams(
    variant="ackermann", max_speed=20.0, max_reverse=20.0, speed_tau=2.0,
    max_steer=math.radians(35.0), steer_tau=0.0, max_turn_rate=math.radians(360.0),
    turn_tau=0.0, turning_circle=1.8)
SITL_ROVER_SKID = rover.RoverParams(
    variant="skid", max_speed=4.0, max_reverse=4.0, speed_tau=4.0 / 14.0,
    max_turn_rate=math.radians(280.0), turn_tau=0.0)

SITL_MODELS: dict[str, VehicleModel] = {
    "motorboat": VehicleModel(
        "motorboat", "boat", MAV_TYPE_SURFACE_BOAT, boat.SitlBoatParams(skid=False),
        ("rover.parm", "motorboat.parm"), (FN_STEERING, FN_THROTTLE),
        lambda h: boat.BoatState(heading=h), boat.sitl_step, boat.sitl_truth,
        _sitl_boat_motion, firmware_defaults=True),
    "motorboat-skid": VehicleModel(
        "motorboat-skid", "boat", MAV_TYPE_SURFACE_BOAT, boat.SitlBoatParams(skid=True),
        ("rover.parm", "motorboat.parm", "rover-skid.parm"),
        (FN_THROTTLE_LEFT, FN_THROTTLE_RIGHT),
        lambda h: boat.BoatState(heading=h), boat.sitl_step, boat.sitl_truth,
        _sitl_boat_motion, firmware_defaults=True),
    "rover": VehicleModel(
        "rover", "rover", MAV_TYPE_GROUND_ROVER, SITL_ROVER, ("rover.parm",),
        (FN_STEERING, FN_THROTTLE), lambda h: rover.RoverState(heading=h),
        _rover_step, _rover_truth, _rover_motion, firmware_defaults=True),
    "rover-skid": VehicleModel(
        "rover-skid", "rover", MAV_TYPE_GROUND_ROVER, SITL_ROVER_SKID,
        ("rover.parm", "rover-skid.parm"), (FN_THROTTLE_LEFT, FN_THROTTLE_RIGHT),
        lambda h: rover.RoverState(heading=h), _rover_step, _rover_truth, _rover_motion,
        firmware_defaults=True),
}


# ---------------------------------------------------------------------------------------------
# mavhelm's own hulls: a BlueBoat-like 3-DOF boat (twin thrusters or rudder) and a small rover
# (Ackermann or skid). They are slower and more boat-like than the SITL toys above; the demo and
# most tests run them, so the default model is one of them. Unlike the SITL models they read
# their outputs through SERVOn_FUNCTION/MIN/MAX/TRIM/REVERSED, and move with mavhelm's
# SIM_CURRENT_SPD/DIR current and a leeway of 3 % of the wind (no tide, no waves).
# ---------------------------------------------------------------------------------------------


_last_hull: tuple[SimEnvironment, boat.Environment] | None = None


def hull_environment(env: SimEnvironment) -> boat.Environment:
    """mavhelm's environment for its own hulls, from the same parameter table. Asked for
    several times a physics step with the same (immutable) environment, so the last answer
    is kept (by identity: cheaper than hashing the environment)."""
    global _last_hull
    last = _last_hull
    if last is None or last[0] is not env:
        cs, cd = env.SIM_CURRENT_SPD, math.radians(env.SIM_CURRENT_DIR)
        hull_env = boat.Environment(current_east=cs * math.sin(cd),
                                    current_north=cs * math.cos(cd),
                                    wind_speed=env.SIM_WIND_SPD, wind_from=env.SIM_WIND_DIR,
                                    water_depth=env.SIM_DEPTH)
        last = _last_hull = (env, hull_env)
    return last[1]


def _by_function(skid: bool) -> Callable[[Sequence[int], ServoMap], tuple[float, float]]:
    """Servo PWM → actuator commands through SERVOn_FUNCTION and each output's range, so a
    steering/throttle autopilot can drive a twin-thruster hull and the other way round."""

    def inputs(outputs: Sequence[int], servo_map: ServoMap) -> tuple[float, float]:
        vals: dict[int, float] = {}
        for ch, fn, lo, hi, trim, rev in servo_map:
            pwm = outputs[ch - 1]
            v = (pwm - trim) / max((hi - trim) if pwm >= trim else (trim - lo), 1)
            vals[fn] = -v if rev else v
        if FN_THROTTLE_LEFT in vals or FN_THROTTLE_RIGHT in vals:
            left = vals.get(FN_THROTTLE_LEFT, 0.0)
            right = vals.get(FN_THROTTLE_RIGHT, 0.0)
            steer, thr = 0.5 * (left - right), 0.5 * (left + right)
        else:
            steer = vals.get(FN_STEERING, 0.0)
            thr = vals.get(FN_THROTTLE, 0.0)
            left, right = thr + steer, thr - steer
        return (left, right) if skid else (steer, thr)

    return inputs


def _hull_boat_step(state: boat.BoatState, inputs: tuple[float, float], env: SimEnvironment,
                    dt: float, p: boat.BoatParams) -> boat.BoatState:
    return boat.step(state, inputs, hull_environment(env), dt, p)


def _hull_boat_truth(state: boat.BoatState, t: float, env: SimEnvironment,
                     p: boat.BoatParams) -> Truth:
    return boat.truth(state, t, hull_environment(env), p)


def _hull_boat_motion(state: boat.BoatState, env: SimEnvironment, p: boat.BoatParams) -> Motion:
    s, c = math.sin(state.heading), math.cos(state.heading)
    ce, cn = hull_environment(env).drift(p.leeway)
    return Motion(state.heading, state.r, state.u, state.v,
                  state.u * s + state.v * c + ce, state.u * c - state.v * s + cn)


def _hull_rover_step(state: rover.RoverState, inputs: tuple[float, float],
                     env: SimEnvironment, dt: float, p: rover.RoverParams) -> rover.RoverState:
    return rover.step(state, inputs, hull_environment(env), dt, p)


def _hull_rover_truth(state: rover.RoverState, t: float, env: SimEnvironment,
                      p: rover.RoverParams) -> Truth:
    return rover.truth(state, t, hull_environment(env), p)


def _hull(name: str, vehicle: str, variant: str) -> VehicleModel:
    skid = variant == "skid"
    functions = (FN_THROTTLE_LEFT, FN_THROTTLE_RIGHT) if skid else (FN_STEERING, FN_THROTTLE)
    if vehicle == "boat":
        return VehicleModel(name, vehicle, MAV_TYPE_SURFACE_BOAT, boat.BoatParams(variant=variant),
                            (), functions, lambda h: boat.BoatState(heading=h),
                            _hull_boat_step, _hull_boat_truth, _hull_boat_motion,
                            _by_function(skid))
    return VehicleModel(name, vehicle, MAV_TYPE_GROUND_ROVER, rover.RoverParams(variant=variant),
                        (), functions, lambda h: rover.RoverState(heading=h),
                        _hull_rover_step, _hull_rover_truth, _rover_motion,
                        _by_function(skid))


HULL_MODELS: dict[str, VehicleModel] = {
    m.name: m for m in (_hull("mavhelm-boat", "boat", "skid"),
                        _hull("mavhelm-boat-rudder", "boat", "rudder"),
                        _hull("mavhelm-rover", "rover", "ackermann"),
                        _hull("mavhelm-rover-skid", "rover", "skid"))}

# Every model by name, ``--model``'s choices: ArduPilot's SITL names, then mavhelm's own hulls
MODELS: dict[str, VehicleModel] = {**SITL_MODELS, **HULL_MODELS}
MODEL_NAMES: tuple[str, ...] = tuple(MODELS)
DEFAULT_MODEL = "mavhelm-boat"  # the twin-thruster hull the demo's figures were made on


def get_model(name: str) -> VehicleModel:
    """The model called ``name``; ValueError naming the known ones otherwise."""
    try:
        return MODELS[name]
    except KeyError:
        raise ValueError(f"unknown vehicle model {name!r}; known: "
                         f"{', '.join(MODEL_NAMES)}") from None
