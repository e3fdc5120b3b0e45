"""The outputs (libraries/AR_Motors/AP_MotorsUGV.cpp, SRV_Channel, ServoRelayEvents.cpp):
the throttle demand slew-limited at MOT_SLEWRATE, steering and throttle mixed for a skid vehicle
and written as PWM on the outputs whose SERVOn_FUNCTION asks for them; DO_SET_SERVO on the
outputs no function holds.

Apart from the autopilot because it is what the physics reads: the vehicle moves only by the
PWM written here, as SITL's frames move only by the servo outputs."""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping

from mavhelm.sitl.attitude_control import clamp
from mavhelm.sitl.mavlink_defs import (
    FN_NONE,
    FN_STEERING,
    FN_THROTTLE,
    FN_THROTTLE_LEFT,
    FN_THROTTLE_RIGHT,
    MOTOR_FUNCTIONS,
    RESULT_ACCEPTED,
    RESULT_FAILED,
    SEVERITY_INFO,
)

ServoMapRow = tuple[int, int, float, float, float, bool]
# where each motor function's demand sits in mix()'s (steering, throttle, left, right)
_MIX_INDEX = {FN_STEERING: 0, FN_THROTTLE: 1, FN_THROTTLE_LEFT: 2, FN_THROTTLE_RIGHT: 3}


class MotorsUGV:
    """AP_MotorsUGV for the four motor functions (steering 26, throttle 70, left 73, right 74)
    and the free outputs DO_SET_SERVO may drive."""

    def __init__(self, params: Mapping[str, float], skid: bool,
                 text: Callable[[int, str], None]) -> None:
        self.params = params
        self.skid = skid
        self.text = text  # a STATUSTEXT for every link
        self.servo_override: dict[int, int] = {}  # DO_SET_SERVO outputs (1-based)
        self._servo_map: list[ServoMapRow] | None = None
        # servo_map() as outputs() reads it: (output index, mix index, min, max, trim, reversed)
        self._rows: list[tuple[int, int, float, float, float, bool]] | None = None
        self.throttle_prev = 0.0  # _throttle_prev: the last slew-limited throttle, -1..1
        # limit.throttle_lower/upper of the last output() (the speed controller's I-term stops
        # growing while either is set: AR_AttitudeControl::get_throttle_out_speed)
        self.limit_lower = True
        self.limit_upper = True
        # limit.steer_left || steer_right of the last output: the steering rate controller's
        # I-term may then only shrink (AR_AttitudeControl::get_steering_out_rate)
        self.limit_steer = True

    def slew_limited(self, throttle: float, dt: float) -> float:
        """AP_MotorsUGV::get_slew_limited_throttle: ``throttle`` (-1..1) moved no further from
        the last output than MOT_SLEWRATE (%/s of the -100..100 range; 0: no limit) allows in
        dt. Stores nothing (MANUAL asks it to see whether the output will change direction)."""
        rate = self.params.get("MOT_SLEWRATE", 100.0)
        if rate <= 0:
            return throttle
        step = rate * 0.01 * dt
        prev = self.throttle_prev
        return clamp(throttle, prev - step, prev + step)

    def output(self, steering: float, throttle: float, armed: bool, dt: float) -> float:
        """The throttle path of AP_MotorsUGV::output, once a control-loop pass, every mode
        (MANUAL too): disarmed the demand is zero; it is held within MOT_THR_MAX (set_throttle)
        and slew-limited at MOT_SLEWRATE. Returns the throttle the outputs carry and sets the
        limit flags the speed controller reads next pass: throttle_upper/lower when the slew
        held it back, when it is at ±MOT_THR_MAX, when skid mixing cut it, and both while
        disarmed (set_limits_from_input)."""
        # clamp() inlined: this runs every control-loop pass
        tmax = self.params.get("MOT_THR_MAX", 100.0)
        tmax = (5.0 if tmax < 5.0 else 100.0 if tmax > 100.0 else tmax) * 0.01
        if armed:
            demand = -tmax if throttle < -tmax else tmax if throttle > tmax else throttle
        else:
            demand = 0.0
        out = self.slew_limited(demand, dt)
        self.throttle_prev = out
        lower = out > demand or out <= -tmax or not armed
        upper = out < demand or out >= tmax or not armed
        if self.skid and armed and abs(steering) + abs(out) > 1.0:
            thr = self.mix(steering, out, True)[1]
            if abs(thr) < abs(out):
                lower = lower or out < 0
                upper = upper or out > 0
        self.limit_lower, self.limit_upper = lower, upper
        return out

    def steering_output(self, steering: float, ground_speed: float, armed: bool,
                        scaled: bool) -> float:
        """The steering path of AP_MotorsUGV::output_regular for a steering/throttle vehicle:
        in a mode that asks for scaling (all but MANUAL), above MOT_SPD_SCA_BASE (m/s) the
        steering shrinks as base / speed, so a turn-rate demand gives the same turn rate at any
        speed; at or below it the steering is marked limited, so the rate controller's I-term
        cannot wind up while the vehicle is too slow to turn; backing up reverses it.
        MOT_SPD_SCA_BASE 0 turns both off (upstream still marks the steering limited then:
        docs/sim-differences.md), which is what mavhelm's own hulls, tuned without it, run.
        A skid vehicle has no steering output and keeps ``steering``. Sets ``limit_steer``
        (also at full deflection, set_limits_from_input)."""
        if self.skid or not armed:
            self.limit_steer = not armed
            return steering
        limit = False
        if scaled:
            base = self.params.get("MOT_SPD_SCA_BASE", 1.0)
            speed = abs(ground_speed)
            if base > 0.0:
                if speed > base:
                    steering *= base / speed
                else:
                    limit = True
            if ground_speed < 0.0:
                steering = -steering
        self.limit_steer = limit or abs(steering) >= 1.0
        return steering

    def do_set_servo(self, channel: int, pwm: int) -> int:
        """MAV_CMD_DO_SET_SERVO: refused on outputs that already have a function."""
        if not 1 <= channel <= 16:
            return RESULT_FAILED
        fn = int(self.params.get(f"SERVO{channel}_FUNCTION", 0))
        if fn not in (FN_NONE, 1) and not 51 <= fn <= 66:  # none, RCPassThru, RCINn
            self.text(SEVERITY_INFO, f"ServoRelayEvent: Channel {channel} is already in use")
            return RESULT_FAILED
        self.servo_override[channel] = int(pwm)
        return RESULT_ACCEPTED

    def mix(self, steering: float, throttle: float,
            armed: bool) -> tuple[float, float, float, float]:
        """(steering, throttle, left, right) after skid-steer mixing; zero when disarmed."""
        if not armed:
            return 0.0, 0.0, 0.0, 0.0
        steer, thr = steering, throttle
        # skid steering saturation (AP_MotorsUGV): MOT_STR_THR_MIX 0.5 scales both fairly,
        # 1.0 gives steering priority; throttle takes what steering leaves
        sat = abs(steer) + abs(thr)
        if self.skid and sat > 1.0:
            mix = clamp(self.params.get("MOT_STR_THR_MIX", 0.5), 0.0, 1.0)
            if mix >= 0.5:
                steer *= 1.0 / sat + (1.0 - 1.0 / sat) * (mix - 0.5) / 0.5
                thr = math.copysign(max(0.0, 1.0 - abs(steer)), thr)
            else:
                thr *= 1.0 / sat + (1.0 - 1.0 / sat) * (0.5 - mix) / 0.5
                steer = math.copysign(max(0.0, 1.0 - abs(thr)), steer)
        return steer, thr, clamp(thr + steer, -1, 1), clamp(thr - steer, -1, 1)

    def servo_map(self) -> list[ServoMapRow]:
        """(channel, function, min, max, trim, reversed) of the motor outputs; cached until
        a SERVOn_ parameter changes (call invalidate())."""
        if self._servo_map is None:
            p = self.params
            self._servo_map = [
                (ch, int(p.get(f"SERVO{ch}_FUNCTION", 0)), p.get(f"SERVO{ch}_MIN", 1100),
                 p.get(f"SERVO{ch}_MAX", 1900), p.get(f"SERVO{ch}_TRIM", 1500),
                 bool(p.get(f"SERVO{ch}_REVERSED", 0)))
                for ch in range(1, 17)
                if int(p.get(f"SERVO{ch}_FUNCTION", 0)) in MOTOR_FUNCTIONS]
        return self._servo_map

    def invalidate(self) -> None:
        """Parameters changed: drop the cached servo map."""
        self._servo_map = None
        self._rows = None

    def outputs(self, steering: float, throttle: float, armed: bool) -> list[int]:
        """SERVO_OUTPUT_RAW values for outputs 1..16."""
        value = self.mix(steering, throttle, armed)
        out = [0] * 16
        for ch, pwm in self.servo_override.items():
            out[ch - 1] = pwm
        rows = self._rows
        if rows is None:
            rows = self._rows = [(ch - 1, _MIX_INDEX[fn], lo, hi, trim, rev)
                                 for ch, fn, lo, hi, trim, rev in self.servo_map()]
        for i, k, lo, hi, trim, rev in rows:
            v = -value[k] if rev else value[k]
            out[i] = int(round(trim + v * (hi - trim if v >= 0 else trim - lo)))
        return out
