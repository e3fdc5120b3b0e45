"""ArduPilot Rover's behaviour, as seen from its MAVLink side: pure logic, no sockets, no clock.

This is the part of the stand-in that must tell the truth: mode numbers and refusals, the
start-up timeline, arming, GUIDED targets and their 3 s time-out, RC override rules, parameters,
DO_SET_SERVO, the GCS failsafe, and the steering/speed controllers that turn targets into servo
outputs. Facts were checked against ArduPilot's Rover sources and the measurements recorded in
design.md; the simulator (simulator.py) feeds it decoded messages and an estimate of the vehicle
state, and sends what it queues (STATUSTEXT, MISSION_ITEM_REACHED).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from mavhelm.sitl.statustext import BOOT_TEXTS

# Rover custom modes (Rover/mode.h).
MODES: dict[int, str] = {
    0: "MANUAL", 1: "ACRO", 3: "STEERING", 4: "HOLD", 5: "LOITER", 6: "FOLLOW", 7: "SIMPLE",
    10: "AUTO", 11: "RTL", 12: "SMART_RTL", 15: "GUIDED", 16: "INITIALISING",
}
MODE_NUMBERS: dict[str, int] = {v: k for k, v in MODES.items()}
MANUAL, ACRO, STEERING, HOLD, LOITER, FOLLOW, SIMPLE = 0, 1, 3, 4, 5, 6, 7
AUTO, RTL, SMART_RTL, GUIDED, INITIALISING = 10, 11, 12, 15, 16

_MANUAL_INPUT_MODES = {MANUAL, ACRO, STEERING, SIMPLE, INITIALISING}  # has_manual_input()
_AUTOPILOT_MODES = {AUTO, GUIDED, RTL, SMART_RTL, LOITER, FOLLOW}
_NEEDS_POSITION = {LOITER, FOLLOW, AUTO, RTL, SMART_RTL, GUIDED, SIMPLE}
_NEEDS_VELOCITY = {ACRO, STEERING}

# MAVLink constants used here (kept local so this module needs no pymavlink).
SEVERITY_CRITICAL, SEVERITY_WARNING, SEVERITY_NOTICE, SEVERITY_INFO = 2, 4, 5, 6
RESULT_ACCEPTED, RESULT_DENIED, RESULT_FAILED, RESULT_UNSUPPORTED = 0, 2, 4, 3
RESULT_TEMPORARILY_REJECTED = 1
MODE_FLAG_CUSTOM = 1
MODE_FLAG_GUIDED = 8
MODE_FLAG_MANUAL = 64
MODE_FLAG_ARMED = 128

# SERVOn_FUNCTION values.
FN_NONE, FN_STEERING, FN_THROTTLE, FN_THROTTLE_LEFT, FN_THROTTLE_RIGHT = 0, 26, 70, 73, 74

_MOTOR_FUNCTIONS = (FN_STEERING, FN_THROTTLE, FN_THROTTLE_LEFT, FN_THROTTLE_RIGHT)

# SET_ATTITUDE_TARGET / SET_POSITION_TARGET_* type_mask bits.
ATT_YAW_RATE_IGNORE = 0x04
ATT_THROTTLE_IGNORE = 0x40
POS_IGNORE = 0x7
VEL_IGNORE = 0x38
ACC_IGNORE = 0x1C0
YAW_IGNORE = 0x400
YAW_RATE_IGNORE = 0x800

# Rover 4.8 has no GUID_TIMEOUT parameter: ModeGuided stops after a fixed 3 s without a target.
GUIDED_TIMEOUT = 3.0
GUIDED_TIMEOUT_TEXT = "target not received last 3secs, stopping"

# HEARTBEAT system_status (MAV_STATE)
MAV_STATE_CALIBRATING, MAV_STATE_STANDBY, MAV_STATE_ACTIVE, MAV_STATE_CRITICAL = 2, 3, 4, 5


@dataclass(frozen=True)
class Timeline:
    """Seconds after boot at which the start-up milestones happen, as measured on the real
    Rover 4.8-dev SITL (motorboat, autopilot time from the ground station's connection)."""

    initialised: float = 1.4  # INITIALISING → MANUAL (or INITIAL_MODE)
    gps_fix: float = 9.9  # u-blox detected at 9.7, 3D fix and "Set HOME" at 9.9
    ekf_origin: float = 19.9  # "EKF3 IMU0 origin set"
    arming: float = 23.5  # IMU checks pass: refused at 23.2, accepted at 24.2; pre-arm bit 24.05
    ekf_gps: float = 41.9  # "EKF3 IMU0 is using GPS": position OK; GUIDED ~1 s later
    gyros: float = 13.5  # the arming refusal says "Accels inconsistent" before, "Gyros" after

    @staticmethod
    def fast() -> Timeline:
        """Everything ready within 3 s of sim time, for tests."""
        return Timeline(0.2, 0.5, 1.0, 1.5, 2.0, 0.8)

    def milestones(self) -> list[float]:
        return [0.0, self.initialised, self.gps_fix, self.gyros, self.ekf_origin, self.arming,
                self.ekf_gps]

    def map(self, t_normal: float) -> float:
        """A time on the normal (measured) timeline moved onto this one, piecewise linearly
        between the milestones, so the boot texts keep their order and place when the start-up
        is compressed."""
        src, dst = Timeline().milestones(), self.milestones()
        for i in range(1, len(src)):
            if t_normal <= src[i] or i == len(src) - 1:
                a0, a1, b0, b1 = src[i - 1], src[i], dst[i - 1], dst[i]
                if a1 <= a0:
                    return b1
                return b0 + (t_normal - a0) * (b1 - b0) / (a1 - a0)
        return t_normal


@dataclass
class Estimate:
    """What the autopilot believes (its EKF output), local frame X east, Y north."""

    x: float = 0.0
    y: float = 0.0
    heading: float = 0.0  # degrees clockwise from north
    yaw_rate: float = 0.0  # deg/s clockwise
    vx: float = 0.0  # m/s east
    vy: float = 0.0  # m/s north
    position_ok: bool = False  # EKF has an absolute horizontal position

    @property
    def forward_speed(self) -> float:
        h = math.radians(self.heading)
        return self.vx * math.sin(h) + self.vy * math.cos(h)


def default_params(boat: bool, skid: bool) -> dict[str, float]:
    """The parameter table: the names and values the real Rover 4.8-dev SITL answers with its
    stock rover.parm (WP_SPEED 5, CRUISE_SPEED 5, WP_RADIUS 3, ATC_STR_RAT_FF 0.75, ATC_SPEED_P
    0.1), except a few controller terms tuned to the simulator's hulls (docs/sim-differences.md).
    Names are 4.8's: MAV_SYSID (was SYSID_THISMAV), GPS1_*, ARMING_SKIPCHK; there is no
    GUID_TIMEOUT."""
    p: dict[str, float] = {
        "MAV_SYSID": 1, "MAV_GCS_SYSID": 255, "RC_OVERRIDE_TIME": 3.0,
        "WP_SPEED": 5.0, "WP_RADIUS": 3.0, "WP_ACCEL": 0.0, "RTL_SPEED": 0.0,
        "CRUISE_SPEED": 5.0, "CRUISE_THROTTLE": 40.0 if boat else 50.0, "SPEED_MAX": 0.0,
        "TURN_RADIUS": 0.9, "LOIT_RADIUS": 2.0, "LOIT_SPEED_GAIN": 0.5, "ACRO_TURN_RATE": 180.0,
        "FS_GCS_ENABLE": 0, "FS_GCS_TIMEOUT": 5.0, "FS_ACTION": 2, "FS_TIMEOUT": 1.5,
        "FS_OPTIONS": 0, "FS_THR_ENABLE": 1, "FS_EKF_ACTION": 1, "FS_EKF_THRESH": 0.8,
        "RCMAP_ROLL": 1, "RCMAP_PITCH": 2, "RCMAP_THROTTLE": 3, "RCMAP_YAW": 4,
        "FRAME_CLASS": 2 if boat else 1, "FRAME_TYPE": 0, "INITIAL_MODE": 0,
        "GUID_OPTIONS": 0, "MIS_DONE_BEHAVE": 0,
        "ARMING_SKIPCHK": 0, "ARMING_REQUIRE": 1, "PILOT_STEER_TYPE": 0,
        # SERIAL1/SERIAL2 (TCP 5762/5763) speak MAVLink 2
        "SERIAL0_PROTOCOL": 2, "SERIAL1_PROTOCOL": 2, "SERIAL2_PROTOCOL": 2,
        "ATC_STR_RAT_MAX": 120.0, "ATC_STR_ACC_MAX": 120.0,
        "ATC_STR_ANG_P": 2.0, "ATC_STR_RAT_IMAX": 0.5, "ATC_STR_RAT_FF": 0.75,
        # speed loop: rover.parm's P; I and IMAX tuned to the simulator's hulls
        "ATC_SPEED_P": 0.1, "ATC_SPEED_I": 0.6 if boat else 0.5,
        "ATC_SPEED_IMAX": 0.5,
        "ATC_ACCEL_MAX": 1.0, "ATC_DECEL_MAX": 0.0, "ATC_STOP_SPEED": 0.1,
        "MOT_THR_MAX": 100.0, "MOT_THR_MIN": 0.0, "MOT_STR_THR_MIX": 0.5,
        "GPS1_TYPE": 1, "GPS1_RATE_MS": 200, "EK3_SRC1_POSXY": 3,
    }
    if boat and not skid:  # a rudder needs flow: more gain on the rate error
        p.update({"ATC_STR_RAT_P": 1.5, "ATC_STR_RAT_I": 0.8})
    else:
        p.update({"ATC_STR_RAT_P": 1.0, "ATC_STR_RAT_I": 0.5})
    for i in range(1, 17):
        p[f"SERVO{i}_FUNCTION"] = FN_NONE
        p[f"SERVO{i}_MIN"] = 1100
        p[f"SERVO{i}_MAX"] = 1900
        p[f"SERVO{i}_TRIM"] = 1500
        p[f"SERVO{i}_REVERSED"] = 0
    for i in range(1, 17):
        p[f"RC{i}_MIN"] = 1100
        p[f"RC{i}_MAX"] = 1900
        p[f"RC{i}_TRIM"] = 1500
        p[f"RC{i}_DZ"] = 30 if i in (1, 3) else 0
    if skid:
        p["SERVO1_FUNCTION"] = FN_THROTTLE_LEFT
        p["SERVO3_FUNCTION"] = FN_THROTTLE_RIGHT
    else:
        p["SERVO1_FUNCTION"] = FN_STEERING
        p["SERVO3_FUNCTION"] = FN_THROTTLE
    return p


def _wrap180(a: float) -> float:
    return (a + 180.0) % 360.0 - 180.0


def _clamp(v: float, lo: float, hi: float) -> float:
    return lo if v < lo else hi if v > hi else v


@dataclass
class _Pid:
    integ: float = 0.0

    def reset(self) -> None:
        self.integ = 0.0


@dataclass
class Outbox:
    """What the autopilot wants said on every link."""

    texts: list[tuple[int, str]] = field(default_factory=list)
    reached: list[int] = field(default_factory=list)
    heartbeat: bool = False  # send a HEARTBEAT at once (after a mode change)
    params: list[str] = field(default_factory=list)  # PARAM_VALUE to broadcast


class Autopilot:
    """Rover firmware logic. Times are seconds on the simulator clock."""

    def __init__(self, *, boat: bool = True, skid: bool = True, boot_time: float = 0.0,
                 timeline: Timeline | None = None, params: dict[str, float] | None = None,
                 latlon: Callable[[float, float], tuple[float, float]] | None = None) -> None:
        self.boat = boat
        # local x, y → (lat, lon) degrees, for the texts that name a place ("Set HOME to ...")
        self.latlon = latlon or (lambda x, y: (0.0, 0.0))
        self.skid = skid
        self.boot_time = boot_time
        self.timeline = timeline or Timeline()
        self.params = default_params(boat, skid)
        if params:
            self.params.update({k.upper(): float(v) for k, v in params.items()})
        self.mode = INITIALISING
        self.armed = False
        self.out = Outbox()
        self.est = Estimate()
        self.home: tuple[float, float] | None = None  # local x, y
        self.ekf_origin: tuple[float, float] | None = None
        self.gps_has_fix = False  # set by the simulator from the GPS model each step
        self._initialised = False
        self._announced: set[str] = set()  # boot events said: home, origin, gps
        self._boot_text = 0  # index of the next timed boot text
        self._boot_times = [self.timeline.map(b.at) for b in BOOT_TEXTS]
        # RC input: the radio's values (SITL: centred), plus overrides with their time stamps.
        self.rc_radio = [1500] * 16
        self.rc_override: list[int | None] = [None] * 18
        self.rc_override_time: list[float] = [0.0] * 18
        # GUIDED state
        self.guided_sub = "stop"  # stop | loiter | wp | heading | rate
        self.guided_target_time = 0.0
        self.have_att_target = False
        self.des_heading = 0.0
        self.des_rate = 0.0  # deg/s
        self.des_speed = 0.0
        self.wp: tuple[float, float] | None = None
        self.wp_notify = False
        self.loiter_point: tuple[float, float] | None = None
        self.guided_speed: float | None = None  # DO_CHANGE_SPEED / DO_REPOSITION, until exit
        # controllers
        self._rate_pid = _Pid()
        self._speed_pid = _Pid()
        self._speed_target = 0.0  # acceleration-limited desired speed
        self._rate_target = 0.0
        self.steering = 0.0  # -1..1 (ArduPilot -4500..4500)
        self.throttle = 0.0  # -1..1 (ArduPilot -100..100)
        self.servo_override: dict[int, int] = {}  # DO_SET_SERVO outputs (1-based)
        self._servo_map: list[tuple[int, int, float, float, float, bool]] | None = None
        # failsafe
        self.gcs_last_seen: float | None = None
        self.failsafe_bits = 0
        self.failsafe_start = 0.0
        self.failsafe_triggered = 0
        self.ekf_failsafe = False
        self._ekf_bad_time = 0.0

    # ------------------------------------------------------------------ start-up timeline
    def uptime(self, now: float) -> float:
        return now - self.boot_time

    def arming_ready(self, now: float) -> bool:
        return self.uptime(now) >= self.timeline.arming

    def position_ok(self) -> bool:
        """Rover::position_ok: the EKF has a position and the EKF failsafe is not active."""
        return self.est.position_ok and not self.ekf_failsafe

    def _text(self, severity: int, text: str) -> None:
        self.out.texts.append((severity, text))

    def update_timeline(self, now: float) -> None:
        """Advance the boot sequence: its texts, the mode after init, home, the EKF origin."""
        up = self.uptime(now)
        if not self._initialised and up >= self.timeline.initialised:
            self._initialised = True
            initial = int(self.params.get("INITIAL_MODE", 0))
            self._set_mode_internal(initial if initial in MODES and initial != INITIALISING
                                    else MANUAL)
        if self.home is None and up >= self.timeline.gps_fix and self.gps_has_fix:
            self.home = (self.est.x, self.est.y)  # AP_GPS's first fix sets home
            self._announced.add("home")
        if self.ekf_origin is None and up >= self.timeline.ekf_origin and self.gps_has_fix:
            self.ekf_origin = (self.est.x, self.est.y)
            self._announced.add("origin")
        if "gps" not in self._announced and up >= self.timeline.ekf_gps and self.gps_has_fix:
            self._announced.add("gps")
        while self._boot_text < len(BOOT_TEXTS):
            b = BOOT_TEXTS[self._boot_text]
            if b.event is not None:
                if b.event not in self._announced:
                    break
            elif up < self._boot_times[self._boot_text]:
                break
            text = b.text
            if b.event == "home" and self.home is not None:
                lat, lon = self.latlon(*self.home)
                text = text.format(lat=lat, lon=lon)
            self._text(b.severity, text)
            self._boot_text += 1

    # ------------------------------------------------------------------ modes
    def base_mode(self) -> int:
        b = MODE_FLAG_CUSTOM
        if self.mode in _MANUAL_INPUT_MODES:
            b |= MODE_FLAG_MANUAL
        if self.mode in _AUTOPILOT_MODES:
            b |= MODE_FLAG_GUIDED
        if self.armed:
            b |= MODE_FLAG_ARMED
        return b

    def system_status(self) -> int:
        """GCS_MAVLINK_Rover::vehicle_system_status: CRITICAL in a GCS or EKF failsafe,
        CALIBRATING while initialising, STANDBY in HOLD, otherwise ACTIVE (armed or not)."""
        if self.failsafe_triggered or self.ekf_failsafe:
            return MAV_STATE_CRITICAL
        if self.mode == INITIALISING:
            return MAV_STATE_CALIBRATING
        if self.mode == HOLD:
            return MAV_STATE_STANDBY
        return MAV_STATE_ACTIVE

    @property
    def mode_name(self) -> str:
        return MODES.get(self.mode, str(self.mode))

    def set_mode(self, number: int, now: float) -> bool:
        """Rover::set_mode: refuses unknown modes and modes whose needs are not met."""
        if number not in MODES:
            self._text(SEVERITY_WARNING, f"No such mode {number}")
            return False
        if number == self.mode:
            return True
        if self.armed:
            if number in _NEEDS_POSITION and not self.position_ok():
                self._text(SEVERITY_WARNING, "Flight mode change failed")
                return False
            if number in _NEEDS_VELOCITY and not self.position_ok():
                self._text(SEVERITY_WARNING, "Flight mode change failed")
                return False
        if number == AUTO:
            # No mission storage in this stand-in: ModeAuto::_enter refuses.
            self._text(SEVERITY_NOTICE, "No Mission. Can't set AUTO.")
            self._text(SEVERITY_WARNING, "Flight mode change failed")
            return False
        if (number == RTL and self.home is None) or (number == SMART_RTL
                                                     and not self.position_ok()):
            # ModeRTL needs home; SmartRTL needs a recorded path (position while armed)
            self._text(SEVERITY_WARNING, "Flight mode change failed")
            return False
        self._set_mode_internal(number)
        return True

    def _set_mode_internal(self, number: int) -> None:
        self.mode = number
        self.out.heartbeat = True
        self._rate_pid.reset()
        self._speed_pid.reset()
        self._speed_target = self.est.forward_speed
        self._rate_target = self.est.yaw_rate
        self.guided_speed = None
        if number == GUIDED:
            self.have_att_target = False
            self.wp = None
            self._guided_idle()
        elif number == LOITER:
            self.loiter_point = (self.est.x, self.est.y)
        elif number in (RTL, SMART_RTL):
            self.wp = self.home or (self.est.x, self.est.y)
            self.wp_notify = False

    def _guided_idle(self) -> None:
        """Boats loiter where they are, rovers stop (ModeGuided::_enter / on arrival)."""
        if self.boat and self.position_ok():
            self.guided_sub = "loiter"
            self.loiter_point = (self.est.x, self.est.y)
        else:
            self.guided_sub = "stop"

    # ------------------------------------------------------------------ arming
    def arm(self, arm: bool, now: float, force: bool = False) -> int:
        """MAV_CMD_COMPONENT_ARM_DISARM: returns a MAV_RESULT and queues refusal texts."""
        if not arm:
            if self.armed:
                self.armed = False
                self._text(SEVERITY_INFO, "Throttle disarmed")
            return RESULT_ACCEPTED
        if self.armed:
            return RESULT_ACCEPTED
        if not self._initialised:
            return RESULT_FAILED
        if not self.arming_ready(now):
            # The IMU consistency check is mandatory, even with force (AP_Arming::mandatory_checks);
            # the real SITL's accelerometers settle first, then its gyros.
            which = "Accels" if self.uptime(now) < self.timeline.gyros else "Gyros"
            self._text(SEVERITY_CRITICAL, f"Arm: {which} inconsistent")
            return RESULT_FAILED
        if not force and int(self.params.get("ARMING_SKIPCHK", 0)) != -1:
            # AP_Arming_Rover::gps_checks only matter in modes that need position/velocity:
            # a Rover arms in MANUAL with no GPS at all.
            needs = self.mode in _NEEDS_POSITION or self.mode in _NEEDS_VELOCITY
            if needs and not self.position_ok():
                self._text(SEVERITY_CRITICAL, "Arm: Need Position Estimate")
                return RESULT_FAILED
        self.armed = True
        self._text(SEVERITY_INFO, "Throttle armed")
        self._rate_pid.reset()
        self._speed_pid.reset()
        if self.mode == GUIDED:
            self._guided_idle()
        return RESULT_ACCEPTED

    # ------------------------------------------------------------------ GUIDED inputs
    def set_attitude_target(self, type_mask: int, q: tuple[float, float, float, float],
                            body_yaw_rate: float, thrust: float, now: float) -> None:
        """SET_ATTITUDE_TARGET: no ACK, ignored outside GUIDED or when thrust is masked."""
        if self.mode != GUIDED or type_mask & ATT_THROTTLE_IGNORE:
            return
        speed = self.params["WP_SPEED"] * _clamp(thrust, -1.0, 1.0)
        if type_mask & ATT_YAW_RATE_IGNORE:
            w, x, y, z = q
            yaw = math.degrees(math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))
            self._set_heading_speed(yaw, speed, now)
        else:
            self._set_rate_speed(math.degrees(body_yaw_rate), speed, now)

    def _set_heading_speed(self, heading: float, speed: float, now: float) -> None:
        if self.guided_sub != "heading":
            self._rate_pid.reset()
        self.guided_sub = "heading"
        self.des_heading = heading % 360.0
        self.des_speed = speed
        self.guided_target_time = now
        self.have_att_target = True

    def _set_rate_speed(self, rate: float, speed: float, now: float) -> None:
        self.guided_sub = "rate"
        self.des_rate = rate
        self.des_speed = speed
        self.guided_target_time = now
        self.have_att_target = True

    def set_position_target(self, *, type_mask: int, frame: str, x: float | None, y: float | None,
                            vx: float, vy: float, yaw: float, yaw_rate: float, now: float,
                            message: str = "SET_POSITION_TARGET_LOCAL_NED") -> None:
        """SET_POSITION_TARGET_LOCAL_NED / GLOBAL_INT after frame conversion.

        x, y are the target in the simulator's local frame (east, north), already converted;
        vx, vy are north, east velocities as in the message (NED), or body forward/right when
        frame == "body". Acceleration targets are not supported: refused with a STATUSTEXT
        naming the message.
        """
        if self.mode != GUIDED:
            return
        pos_ignore = (type_mask & POS_IGNORE) == POS_IGNORE
        vel_ignore = (type_mask & VEL_IGNORE) == VEL_IGNORE
        acc_ignore = (type_mask & ACC_IGNORE) == ACC_IGNORE
        yaw_ignore = bool(type_mask & YAW_IGNORE)
        rate_ignore = bool(type_mask & YAW_RATE_IGNORE)
        if not acc_ignore:
            # GCS_MAVLINK_Rover::send_acc_ignore_must_be_set_message
            self._text(SEVERITY_INFO, f"Ignoring {message}; set ACC_IGNORE in mask")
            return
        speed = 0.0
        heading = 0.0
        if not vel_ignore:
            limit = self.params["WP_SPEED"]
            speed = _clamp(math.hypot(vx, vy), -limit, limit)
            heading = math.degrees(math.atan2(vy, vx))
            if frame == "body":
                heading += self.est.heading
        if not yaw_ignore:
            heading = math.degrees(yaw) + (self.est.heading if frame == "body" else 0.0)
        rate = 0.0 if rate_ignore else math.degrees(yaw_rate)
        direction = -1.0 if (not vel_ignore and (not yaw_ignore or not rate_ignore)
                             and vx < 0) else 1.0
        if not pos_ignore and x is not None and y is not None:
            self.wp = (x, y)
            self.wp_notify = True
            self.guided_sub = "wp"
            self.have_att_target = False
        elif not vel_ignore and yaw_ignore and rate_ignore:
            self._set_heading_speed(heading, direction * speed, now)
        elif not vel_ignore and yaw_ignore and not rate_ignore:
            self._set_rate_speed(rate, direction * speed, now)
        elif not vel_ignore and not yaw_ignore and rate_ignore:
            self._set_heading_speed(heading, direction * speed, now)
        elif vel_ignore and not yaw_ignore and rate_ignore:
            self._set_heading_speed(heading, 0.0, now)
        elif vel_ignore and yaw_ignore and not rate_ignore:
            self._set_rate_speed(rate, 0.0, now)

    def guided_reposition(self, x: float, y: float, speed: float, change_mode: bool,
                          now: float) -> int:
        """MAV_CMD_DO_REPOSITION."""
        if self.mode != GUIDED and not change_mode:
            return RESULT_DENIED
        if self.mode != GUIDED and not self.set_mode(GUIDED, now):
            return RESULT_FAILED
        if speed > 0:
            self.guided_speed = speed
        self.wp = (x, y)
        self.wp_notify = True
        self.guided_sub = "wp"
        return RESULT_ACCEPTED

    # ------------------------------------------------------------------ RC input
    def rc_override_msg(self, sysid: int, values: list[int], now: float) -> None:
        """RC_CHANNELS_OVERRIDE: only from MAV_GCS_SYSID; 0 releases ch1-8, UINT16_MAX ignores;
        ch9-18: 0 and UINT16_MAX ignore, UINT16_MAX-1 releases."""
        if sysid != int(self.params["MAV_GCS_SYSID"]):
            return
        for i, v in enumerate(values[:18]):
            if i < 8:
                if v == 0xFFFF:
                    continue
                if v == 0:
                    self.rc_override[i] = None
                    continue
            else:
                if v in (0, 0xFFFF):
                    continue
                if v == 0xFFFE:
                    self.rc_override[i] = None
                    continue
            self.rc_override[i] = int(v)
            self.rc_override_time[i] = now

    def manual_control_msg(self, sysid: int, y: int, z: int, now: float) -> None:
        """MANUAL_CONTROL: from MAV_GCS_SYSID only; y steers, z throttles (-1000..1000, INT16_MAX
        = no change), mapped onto the RCMAP channels as an override (GCS_MAVLINK::manual_override).
        """
        if sysid != int(self.params["MAV_GCS_SYSID"]):
            return
        for ch, value in ((int(self.params["RCMAP_ROLL"]), y),
                          (int(self.params["RCMAP_THROTTLE"]), z)):
            if value == 0x7FFF:
                continue
            lo = self.params.get(f"RC{ch}_MIN", 1100)
            hi = self.params.get(f"RC{ch}_MAX", 1900)
            self.rc_override[ch - 1] = int(lo + (hi - lo) * (value + 1000) / 2000.0)
            self.rc_override_time[ch - 1] = now

    def rc_in(self, now: float) -> list[int]:
        """Effective RC input per channel (override while fresh, else the radio)."""
        timeout = self.params["RC_OVERRIDE_TIME"]
        out = []
        for i in range(18):
            ov = self.rc_override[i]
            if ov is not None and (timeout < 0 or now - self.rc_override_time[i] <= timeout):
                out.append(ov)
            else:
                if ov is not None:
                    self.rc_override[i] = None
                out.append(self.rc_radio[i] if i < 16 else 0)
        return out

    def _rc_norm(self, ch: int, pwm: int) -> float:
        """-1..1 with dead zone around trim, like RC_Channel::norm_input_dz."""
        lo = self.params.get(f"RC{ch}_MIN", 1100)
        hi = self.params.get(f"RC{ch}_MAX", 1900)
        trim = self.params.get(f"RC{ch}_TRIM", 1500)
        dz = self.params.get(f"RC{ch}_DZ", 0)
        if pwm > trim + dz:
            return _clamp((pwm - trim - dz) / max(hi - trim - dz, 1), -1.0, 1.0)
        if pwm < trim - dz:
            return _clamp((pwm - trim + dz) / max(trim - lo - dz, 1), -1.0, 1.0)
        return 0.0

    def pilot_input(self, now: float) -> tuple[float, float]:
        """(steering, throttle) in -1..1 from the mapped RC channels."""
        rc = self.rc_in(now)
        sch = int(self.params["RCMAP_ROLL"])
        tch = int(self.params["RCMAP_THROTTLE"])
        steer = self._rc_norm(sch, rc[sch - 1])
        thr = self._rc_norm(tch, rc[tch - 1])
        if self.params.get("PILOT_STEER_TYPE", 0) in (0, 1) and thr < 0:
            steer = -steer  # steering reverses when backing up
        return steer, thr

    # ------------------------------------------------------------------ servos
    def servo_functions(self) -> dict[int, int]:
        return {i: int(self.params.get(f"SERVO{i}_FUNCTION", 0)) for i in range(1, 17)}

    def do_set_servo(self, channel: int, pwm: int) -> int:
        """MAV_CMD_DO_SET_SERVO: refused on outputs that already have a function."""
        if not 1 <= channel <= 16:
            return RESULT_FAILED
        fn = int(self.params.get(f"SERVO{channel}_FUNCTION", 0))
        if fn not in (FN_NONE, 1) and not 51 <= fn <= 66:  # none, RCPassThru, RCINn
            self._text(SEVERITY_INFO, f"ServoRelayEvent: Channel {channel} is already in use")
            return RESULT_FAILED
        self.servo_override[channel] = int(pwm)
        return RESULT_ACCEPTED

    def mix(self) -> tuple[float, float, float, float]:
        """(steering, throttle, left, right) after skid-steer mixing; zero when disarmed."""
        if not self.armed:
            return 0.0, 0.0, 0.0, 0.0
        steer, thr = self.steering, self.throttle
        # skid steering saturation (AP_MotorsUGV): MOT_STR_THR_MIX 0.5 scales both fairly,
        # 1.0 gives steering priority; throttle takes what steering leaves
        sat = abs(steer) + abs(thr)
        if self.skid and sat > 1.0:
            mix = _clamp(self.params.get("MOT_STR_THR_MIX", 0.5), 0.0, 1.0)
            if mix >= 0.5:
                steer *= 1.0 / sat + (1.0 - 1.0 / sat) * (mix - 0.5) / 0.5
                thr = math.copysign(max(0.0, 1.0 - abs(steer)), thr)
            else:
                thr *= 1.0 / sat + (1.0 - 1.0 / sat) * (0.5 - mix) / 0.5
                steer = math.copysign(max(0.0, 1.0 - abs(thr)), steer)
        return steer, thr, _clamp(thr + steer, -1, 1), _clamp(thr - steer, -1, 1)

    def servo_map(self) -> list[tuple[int, int, float, float, float, bool]]:
        """(channel, function, min, max, trim, reversed) of the motor outputs; cached until
        a SERVOn_ parameter changes (call invalidate())."""
        if self._servo_map is None:
            p = self.params
            self._servo_map = [
                (ch, int(p.get(f"SERVO{ch}_FUNCTION", 0)), p.get(f"SERVO{ch}_MIN", 1100),
                 p.get(f"SERVO{ch}_MAX", 1900), p.get(f"SERVO{ch}_TRIM", 1500),
                 bool(p.get(f"SERVO{ch}_REVERSED", 0)))
                for ch in range(1, 17)
                if int(p.get(f"SERVO{ch}_FUNCTION", 0)) in _MOTOR_FUNCTIONS]
        return self._servo_map

    def invalidate(self) -> None:
        """Parameters changed: drop cached derived values."""
        self._servo_map = None

    def servo_outputs(self) -> list[int]:
        """SERVO_OUTPUT_RAW values for outputs 1..16."""
        steer, thr, left, right = self.mix()
        value = {FN_STEERING: steer, FN_THROTTLE: thr, FN_THROTTLE_LEFT: left,
                 FN_THROTTLE_RIGHT: right}
        out = [0] * 16
        for ch, pwm in self.servo_override.items():
            out[ch - 1] = pwm
        for ch, fn, lo, hi, trim, rev in self.servo_map():
            v = -value[fn] if rev else value[fn]
            out[ch - 1] = int(round(trim + v * (hi - trim if v >= 0 else trim - lo)))
        return out

    # ------------------------------------------------------------------ GCS failsafe
    def gcs_heartbeat(self, sysid: int, now: float) -> None:
        if sysid == int(self.params["MAV_GCS_SYSID"]):
            self.gcs_last_seen = now

    def _failsafe_check(self, now: float) -> None:
        if not self.params.get("FS_GCS_ENABLE", 0) or self.gcs_last_seen is None:
            on = False
        else:
            on = now - self.gcs_last_seen > self.params.get("FS_GCS_TIMEOUT", 5.0)
        old = self.failsafe_bits
        self.failsafe_bits = 1 if on else 0
        if old == 0 and self.failsafe_bits:
            self.failsafe_start = now
        if self.failsafe_triggered and not self.failsafe_bits:
            self._text(SEVERITY_INFO, "GCS Failsafe Cleared")
        self.failsafe_triggered &= self.failsafe_bits
        in_hold_ok = self.mode != HOLD or int(self.params.get("FS_OPTIONS", 0)) & 1
        if (not self.failsafe_triggered and self.failsafe_bits
                and now - self.failsafe_start > self.params.get("FS_TIMEOUT", 1.5)
                and self.mode != RTL and in_hold_ok):
            self.failsafe_triggered = self.failsafe_bits
            # Rover::failsafe_trigger names whichever check first sees FS_TIMEOUT pass; with
            # FS_THR_ENABLE on (the default) the radio check runs every loop and is nearly
            # always first, so a GCS failsafe is announced as "Radio Failsafe" (measured). The
            # radio itself never fails here (the simulated receiver is always valid).
            who = "Radio" if int(self.params.get("FS_THR_ENABLE", 0)) else "GCS"
            self._text(SEVERITY_WARNING, f"{who} Failsafe")
            self.rc_override = [None] * 18
            if self.mode == AUTO and int(self.params["FS_GCS_ENABLE"]) == 2:
                self._text(SEVERITY_WARNING, "Failsafe - Continuing Auto Mode")
                return
            # FS_ACTION: 0 nothing, 1 RTL, 2 Hold, 3 SmartRTL or RTL, 4 SmartRTL or Hold,
            # 5 terminate (disarm), 6 Loiter or Hold; each falls back to Hold
            action = int(self.params.get("FS_ACTION", 2))
            if action == 0:
                return
            if action == 5:
                self.arm(False, now)
                return
            if action == 6 and self.set_mode(LOITER, now):
                return
            if action in (3, 4) and self.set_mode(SMART_RTL, now):
                return
            if action in (1, 3) and self.set_mode(RTL, now):
                return
            self.set_mode(HOLD, now)

    def _ekf_check(self, now: float, dt: float) -> None:
        """Rover's ekf_check: ~1 s without a usable position while armed → EKF failsafe
        (FS_EKF_ACTION 1: HOLD if the mode needs position; 2: report only; 0: off)."""
        if not self.armed or self.params.get("FS_EKF_THRESH", 0.8) <= 0:
            self._ekf_bad_time = 0.0
            if self.ekf_failsafe and not self.armed:
                self.ekf_failsafe = False
            return
        bad = not self.est.position_ok
        self._ekf_bad_time = _clamp(self._ekf_bad_time + (dt if bad else -dt), 0.0, 1.0)
        if bad and not self.ekf_failsafe and self._ekf_bad_time >= 1.0:
            self.ekf_failsafe = True
            action = int(self.params.get("FS_EKF_ACTION", 1))
            if self.mode in _NEEDS_POSITION and action != 0:
                if action == 1:
                    self.set_mode(HOLD, now)
                self._text(SEVERITY_CRITICAL, "EKF failsafe")
        elif not bad and self.ekf_failsafe and self._ekf_bad_time <= 0.0:
            self.ekf_failsafe = False
            self._text(SEVERITY_CRITICAL, "EKF failsafe cleared")

    # ------------------------------------------------------------------ control loop
    def update(self, now: float, dt: float) -> None:
        """One control-loop pass: timeline, failsafes, then the mode's controllers."""
        self.update_timeline(now)
        self._failsafe_check(now)
        self._ekf_check(now, dt)
        if not self.armed:
            self.steering = 0.0
            self.throttle = 0.0
            self._speed_target = self.est.forward_speed
            self._rate_pid.reset()
            self._speed_pid.reset()
            # GUIDED targets still time out while disarmed
            self._guided_timeout(now)
            return
        m = self.mode
        if m == MANUAL:
            steer, thr = self.pilot_input(now)
            sat = abs(steer) + abs(thr)
            if self.skid and sat > 1.0:
                # Mode::get_pilot_desired_steering_and_throttle: scale both, keep the ratio
                steer, thr = steer / sat, thr / sat
            self.steering, self.throttle = steer, thr
        elif m in (ACRO, STEERING, SIMPLE):
            steer, thr = self.pilot_input(now)
            rate = steer * self.params["ACRO_TURN_RATE"]
            self.steering = self._rate_control(rate, dt)
            self.throttle = self._speed_control(thr * self._speed_max(), dt)
        elif m == HOLD or m == INITIALISING:
            self.steering = 0.0
            self.throttle = 0.0
        elif m == LOITER:
            self._loiter(dt)
        elif m in (RTL, SMART_RTL):
            speed = self.params["RTL_SPEED"] or self.params["WP_SPEED"]
            if self.wp is not None and self._navigate(self.wp, speed, dt):
                self.wp = None
                self._text(SEVERITY_INFO, "Reached destination")
                if self.boat:
                    self.loiter_point = (self.est.x, self.est.y)
            if self.wp is None:
                if self.boat:
                    self._loiter(dt)
                else:
                    self._stop(dt)
        elif m == GUIDED:
            self._guided(now, dt)
        else:  # FOLLOW with no target, AUTO (never entered)
            self._stop(dt)

    def _guided_timeout(self, now: float) -> None:
        """ModeGuided: a heading or rate target not refreshed for 3 s (fixed) stops the vehicle."""
        if (self.guided_sub in ("heading", "rate") and self.have_att_target
                and now - self.guided_target_time > GUIDED_TIMEOUT):
            self._text(SEVERITY_WARNING, GUIDED_TIMEOUT_TEXT)
            self.have_att_target = False

    def _guided(self, now: float, dt: float) -> None:
        sub = self.guided_sub
        if sub in ("heading", "rate"):
            self._guided_timeout(now)
            if self.have_att_target:
                nudge = self._speed_nudge(self.des_speed, now)
                if sub == "heading":
                    self.steering = self._heading_control(self.des_heading, dt)
                else:
                    self.steering = self._rate_control(self.des_rate, dt)
                self.throttle = self._speed_control(nudge, dt)
            elif self.boat and self.position_ok():
                if self.loiter_point is None or sub != "loiter":
                    self.loiter_point = (self.est.x, self.est.y)
                self.guided_sub = "loiter"
                self._loiter(dt)
            else:
                self.guided_sub = "stop"
                self._stop(dt)
        elif sub == "wp" and self.wp is not None:
            if self._navigate(self.wp, self.guided_speed or self.params["WP_SPEED"], dt):
                if self.wp_notify:
                    self.wp_notify = False
                    self.out.reached.append(0)
                self.wp = None
                self._guided_idle()
        elif sub == "loiter":
            self._loiter(dt)
        else:
            self._stop(dt)

    def _speed_nudge(self, target: float, now: float) -> float:
        """Mode::calc_speed_nudge: pilot throttle can raise the speed (even from an override)."""
        ct = self.params["CRUISE_THROTTLE"]
        if ct > 100 or ct < 5:
            return target
        _, thr = self.pilot_input(now)
        pilot = thr * self._speed_max()
        reversed_ = target < 0
        if (pilot > 0 and reversed_) or (pilot < 0 and not reversed_):
            return target
        return min(target, pilot) if reversed_ else max(target, pilot)

    def _speed_max(self) -> float:
        cs, ct = self.params["CRUISE_SPEED"], self.params["CRUISE_THROTTLE"] * 0.01
        if ct > 1.0 or ct < 0.05:
            vmax = cs
        elif self.params.get("SPEED_MAX", 0) > 0:
            vmax = self.params["SPEED_MAX"]
        else:
            vmax = cs / ct
        return _clamp(vmax, 0.0, 30.0)

    def _stop(self, dt: float) -> None:
        self.steering = 0.0
        if abs(self.est.forward_speed) < self.params["ATC_STOP_SPEED"]:
            self._speed_pid.reset()
            self._speed_target = 0.0
            self.throttle = 0.0
        else:
            self.throttle = self._speed_control(0.0, dt)

    def _loiter(self, dt: float) -> None:
        if self.loiter_point is None:
            self.loiter_point = (self.est.x, self.est.y)
        lx, ly = self.loiter_point
        dist = math.hypot(lx - self.est.x, ly - self.est.y)
        radius = self.params["LOIT_RADIUS"]
        if dist <= radius:
            self._stop(dt)
            return
        speed = min(self.params["LOIT_SPEED_GAIN"] * (dist - radius) + 0.3,
                    self.params["WP_SPEED"])
        bearing = math.degrees(math.atan2(lx - self.est.x, ly - self.est.y))
        err = abs(_wrap180(bearing - self.est.heading))
        self.steering = self._heading_control(bearing, dt)
        self.throttle = self._speed_control(speed * max(0.0, math.cos(math.radians(err))), dt)

    def _navigate(self, target: tuple[float, float], speed: float, dt: float) -> bool:
        """Drive toward target; True once within WP_RADIUS or past it."""
        dx, dy = target[0] - self.est.x, target[1] - self.est.y
        dist = math.hypot(dx, dy)
        if dist <= self.params["WP_RADIUS"]:
            return True
        bearing = math.degrees(math.atan2(dx, dy))
        err = abs(_wrap180(bearing - self.est.heading))
        accel = self.params["ATC_ACCEL_MAX"] or 1.0
        v = min(speed, math.sqrt(2.0 * accel * 0.5 * dist))
        v *= max(0.1, math.cos(math.radians(min(err, 90.0))))
        self.steering = self._heading_control(bearing, dt)
        self.throttle = self._speed_control(v, dt)
        return False

    def _heading_control(self, heading: float, dt: float) -> float:
        err = _wrap180(heading - self.est.heading)
        rate = _clamp(err * self.params["ATC_STR_ANG_P"], -self.params["ATC_STR_RAT_MAX"],
                      self.params["ATC_STR_RAT_MAX"])
        return self._rate_control(rate, dt)

    def _rate_control(self, rate: float, dt: float) -> float:
        """AR_AttitudeControl::get_steering_out_rate, in deg/s: FF + PI on the rate error."""
        rmax = self.params["ATC_STR_RAT_MAX"]
        rate = _clamp(rate, -rmax, rmax)
        acc = self.params["ATC_STR_ACC_MAX"] * dt
        if acc > 0:
            rate = _clamp(rate, self._rate_target - acc, self._rate_target + acc)
        self._rate_target = rate
        scale = math.radians(1.0)
        err = (rate - self.est.yaw_rate) * scale
        pid = self._rate_pid
        imax = self.params["ATC_STR_RAT_IMAX"]
        pid.integ = _clamp(pid.integ + err * self.params["ATC_STR_RAT_I"] * dt, -imax, imax)
        ff = rate * scale * self.params["ATC_STR_RAT_FF"]
        return _clamp(ff + err * self.params["ATC_STR_RAT_P"] + pid.integ, -1.0, 1.0)

    def _speed_control(self, speed: float, dt: float) -> float:
        """AR_AttitudeControl::get_throttle_out_speed: accel-limited target, FF + PI."""
        amax = self.params["ATC_ACCEL_MAX"]
        dmax = self.params["ATC_DECEL_MAX"] or amax
        cur = self._speed_target
        if amax > 0:
            lim = (amax if abs(speed) > abs(cur) else dmax) * dt
            speed = _clamp(speed, cur - lim, cur + lim)
        self._speed_target = speed
        err = speed - self.est.forward_speed
        pid = self._speed_pid
        imax = self.params["ATC_SPEED_IMAX"]
        pid.integ = _clamp(pid.integ + err * self.params["ATC_SPEED_I"] * dt, -imax, imax)
        cs = max(self.params["CRUISE_SPEED"], 0.1)
        ff = speed / cs * self.params["CRUISE_THROTTLE"] * 0.01
        thr = ff + err * self.params["ATC_SPEED_P"] + pid.integ
        tmax = self.params["MOT_THR_MAX"] * 0.01
        return _clamp(thr, -tmax, tmax)
