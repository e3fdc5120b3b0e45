"""The vehicle models by ArduPilot's SITL names: ``motorboat``, ``motorboat-skid``, ``rover``,
``rover-skid`` (``--model`` of the real binary), each behind one interface.

A caller (the simulator) picks a model by name and never asks what kind it is: the model says
which stock ``.parm`` files the real SITL is started with, which servo functions it expects on
SERVO1 and SERVO3, turns those two PWMs into its inputs the way SITL does, and steps and reports
its state. Figures are matched to the real Rover 4.8-dev SITL (docs/sim-vehicles.md;
benchmarks/bench_step_response.py compares them; tests/test_sitl_models.py pins them).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

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

    def step(self, state: Any, inputs: tuple[float, float], env: SimEnvironment,
             dt: float) -> Any:
        """The state dt seconds later under these inputs."""
        return self._step(state, inputs, env, dt, self.params)

    def truth(self, state: Any, t: float, env: SimEnvironment) -> Truth:
        """What the sensors of this vehicle observe in this state."""
        return self._truth(state, t, env, self.params)


def _rover_step(state: rover.RoverState, inputs: tuple[float, float], env: SimEnvironment,
                dt: float, p: rover.RoverParams) -> rover.RoverState:
    return rover.step(state, inputs, _LAND, dt, p)


def _rover_truth(state: rover.RoverState, t: float, env: SimEnvironment,
                 p: rover.RoverParams) -> Truth:
    return rover.truth(state, t, _LAND, p)


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

MODELS: dict[str, VehicleModel] = {
    "motorboat": VehicleModel(
        "motorboat", "boat", MAV_TYPE_SURFACE_BOAT, boat.SitlBoatParams(skid=False),
        ("rover.parm", "motorboat.parm"), (FN_STEERING, FN_THROTTLE),
        lambda h: boat.BoatState(heading=h), boat.sitl_step, boat.sitl_truth),
    "motorboat-skid": VehicleModel(
        "motorboat-skid", "boat", MAV_TYPE_SURFACE_BOAT, boat.SitlBoatParams(skid=True),
        ("rover.parm", "motorboat.parm", "rover-skid.parm"),
        (FN_THROTTLE_LEFT, FN_THROTTLE_RIGHT),
        lambda h: boat.BoatState(heading=h), boat.sitl_step, boat.sitl_truth),
    "rover": VehicleModel(
        "rover", "rover", MAV_TYPE_GROUND_ROVER, SITL_ROVER, ("rover.parm",),
        (FN_STEERING, FN_THROTTLE), lambda h: rover.RoverState(heading=h),
        _rover_step, _rover_truth),
    "rover-skid": VehicleModel(
        "rover-skid", "rover", MAV_TYPE_GROUND_ROVER, SITL_ROVER_SKID,
        ("rover.parm", "rover-skid.parm"), (FN_THROTTLE_LEFT, FN_THROTTLE_RIGHT),
        lambda h: rover.RoverState(heading=h), _rover_step, _rover_truth),
}


def get_model(name: str) -> VehicleModel:
    """The model ArduPilot's SITL calls ``name``; ValueError naming the known ones otherwise."""
    try:
        return MODELS[name]
    except KeyError:
        raise ValueError(f"unknown vehicle model {name!r}; known: "
                         f"{', '.join(sorted(MODELS))}") from None
