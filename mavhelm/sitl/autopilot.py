"""ArduPilot Rover's behaviour, as seen from its MAVLink side: pure logic, no sockets, no clock.

This is the vehicle object (Rover/Rover.cpp, system.cpp, AP_Arming_Rover.cpp): the start-up
timeline, the default parameter table, arming, mode changes through the mode table
(``modes/``, Rover::set_mode), the GUIDED targets decoded from their messages
(GCS_Mavlink.cpp's handlers), and the control-loop pass that runs the failsafes
(``failsafe.py``) and then the current mode. The pieces it owns are modules of their own as
upstream's libraries are: pilot input (``rc_input.py``), outputs and mixing (``motors.py``),
controllers (``attitude_control.py``). Facts were checked against ArduPilot's Rover sources and
the real SITL (docs/sim-autopilot.md); the simulator feeds it an estimate of the vehicle state
and sends what it queues (STATUSTEXT, MISSION_ITEM_REACHED).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from mavhelm.sitl.attitude_control import AttitudeControl, clamp
from mavhelm.sitl.failsafe import Failsafe
from mavhelm.sitl.mavlink_defs import (
    ACC_IGNORE,
    ATT_THROTTLE_IGNORE,
    ATT_YAW_RATE_IGNORE,
    FN_NONE,
    FN_STEERING,
    FN_THROTTLE,
    FN_THROTTLE_LEFT,
    FN_THROTTLE_RIGHT,
    MAV_STATE_ACTIVE,
    MAV_STATE_CALIBRATING,
    MAV_STATE_CRITICAL,
    MAV_STATE_STANDBY,
    MODE_FLAG_ARMED,
    MODE_FLAG_CUSTOM,
    MODE_FLAG_GUIDED,
    MODE_FLAG_MANUAL,
    POS_IGNORE,
    RESULT_ACCEPTED,
    RESULT_DENIED,
    RESULT_FAILED,
    RESULT_TEMPORARILY_REJECTED,
    RESULT_UNSUPPORTED,
    SEVERITY_CRITICAL,
    SEVERITY_INFO,
    SEVERITY_NOTICE,
    SEVERITY_WARNING,
    VEL_IGNORE,
    YAW_IGNORE,
    YAW_RATE_IGNORE,
)
from mavhelm.sitl.modes import (
    ACRO,
    AUTO,
    FOLLOW,
    GUIDED,
    HOLD,
    INITIALISING,
    LOITER,
    MANUAL,
    MODE_CLASSES,
    RTL,
    SIMPLE,
    SMART_RTL,
    STEERING,
    Mode,
    ModeGuided,
)
from mavhelm.sitl.modes.guided import GUIDED_TIMEOUT, GUIDED_TIMEOUT_TEXT
from mavhelm.sitl.motors import MotorsUGV
from mavhelm.sitl.rc_input import RcInput
from mavhelm.sitl.statustext import BOOT_TEXTS

# Rover custom modes by number (Rover/mode.h), from the mode table.
MODES: dict[int, str] = {number: cls.name for number, cls in MODE_CLASSES.items()}
MODE_NUMBERS: dict[str, int] = {v: k for k, v in MODES.items()}

# re-exported: the simulator and telemetry name them through this module
__all__ = [
    "ACC_IGNORE", "ACRO", "ATT_THROTTLE_IGNORE", "ATT_YAW_RATE_IGNORE", "AUTO", "FN_NONE",
    "FN_STEERING", "FN_THROTTLE", "FN_THROTTLE_LEFT", "FN_THROTTLE_RIGHT", "FOLLOW", "GUIDED",
    "GUIDED_TIMEOUT", "GUIDED_TIMEOUT_TEXT", "HOLD", "INITIALISING", "LOITER", "MANUAL",
    "MAV_STATE_ACTIVE", "MAV_STATE_CALIBRATING", "MAV_STATE_CRITICAL", "MAV_STATE_STANDBY",
    "MODES", "MODE_NUMBERS", "POS_IGNORE", "RESULT_ACCEPTED", "RESULT_DENIED", "RESULT_FAILED",
    "RESULT_TEMPORARILY_REJECTED", "RESULT_UNSUPPORTED", "RTL", "SEVERITY_CRITICAL",
    "SEVERITY_INFO", "SEVERITY_NOTICE", "SEVERITY_WARNING", "SIMPLE", "SMART_RTL", "STEERING",
    "VEL_IGNORE", "YAW_IGNORE", "YAW_RATE_IGNORE", "Autopilot", "Estimate", "Outbox",
    "Timeline", "default_params",
]


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
        src, dst = _MEASURED_MILESTONES, self.milestones()
        for i in range(1, len(src)):
            if t_normal <= src[i] or i == len(src) - 1:
                a0, a1, b0, b1 = src[i - 1], src[i], dst[i - 1], dst[i]
                if a1 <= a0:
                    return b1
                return b0 + (t_normal - a0) * (b1 - b0) / (a1 - a0)
        return t_normal


_MEASURED_MILESTONES = Timeline().milestones()


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


# ArduPilot's own (compiled-in) defaults, as the real Rover 4.8-dev SITL answers them when started
# with an empty --defaults file, for the names of default_params() whose value there differs:
# the table below is mavhelm's hulls' (rover.parm's navigation values, controller terms tuned to
# those hulls). AR_AttitudeControl.cpp: AR_ATTCONTROL_STEER_RATE_FF/P/I 0.2, IMAX 1.0;
# AR_ATTCONTROL_THR_SPEED_P/I 0.2, IMAX 1.0; AP_MotorsUGV.cpp: MOT_SPD_SCA_BASE 1;
# Rover/Parameters.cpp: CRUISE_SPEED 2, CRUISE_THROTTLE 50; AR_WPNav: WP_SPEED 2, WP_RADIUS 2.
# Not here, because the model decides them: FRAME_CLASS and SERVO1/3_FUNCTION (the vehicle and
# its outputs; the stock files set them). tests/test_sitl_vehicle_models.py reads every name back
# from the real binary.
ARDUPILOT_DEFAULTS: dict[str, float] = {
    "ATC_STR_RAT_FF": 0.2, "ATC_STR_RAT_P": 0.2, "ATC_STR_RAT_I": 0.2, "ATC_STR_RAT_IMAX": 1.0,
    "ATC_SPEED_P": 0.2, "ATC_SPEED_I": 0.2, "ATC_SPEED_IMAX": 1.0,
    "CRUISE_SPEED": 2.0, "CRUISE_THROTTLE": 50.0, "WP_SPEED": 2.0, "WP_RADIUS": 2.0,
    "MOT_SPD_SCA_BASE": 1.0,
}


def default_params(boat: bool, skid: bool, firmware: bool = False) -> dict[str, float]:
    """The parameter table: the names and values the real Rover 4.8-dev SITL answers with its
    stock rover.parm (WP_SPEED 5, CRUISE_SPEED 5, WP_RADIUS 3, ATC_STR_RAT_FF 0.75, ATC_SPEED_P
    0.1), except a few controller terms tuned to the simulator's hulls (docs/sim-differences.md).
    Names are 4.8's: MAV_SYSID (older firmware: SYSID_THISMAV), GPS1_*, ARMING_SKIPCHK; there is no
    GUID_TIMEOUT.

    ``firmware``: the same names with ArduPilot's own defaults (ARDUPILOT_DEFAULTS), for the
    SITL models (``--model``), which run as the real SITL does: the firmware's defaults, then
    the ``.parm`` files."""
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
        "MOT_THR_MAX": 100.0, "MOT_THR_MIN": 0.0, "MOT_STR_THR_MIX": 0.5, "MOT_SLEWRATE": 100.0,
        # mavhelm's hulls were tuned without steering speed scaling (motors.steering_output)
        "MOT_SPD_SCA_BASE": 0.0,
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
        p[f"RC{i}_DZ"] = 30 if i in (1, 3, 4) else 0  # Rover: steering, throttle, lateral
    if skid:
        p["SERVO1_FUNCTION"] = FN_THROTTLE_LEFT
        p["SERVO3_FUNCTION"] = FN_THROTTLE_RIGHT
    else:
        p["SERVO1_FUNCTION"] = FN_STEERING
        p["SERVO3_FUNCTION"] = FN_THROTTLE
    if firmware:
        p.update(ARDUPILOT_DEFAULTS)
    return p


@dataclass
class Outbox:
    """What the autopilot wants said on every link."""

    texts: list[tuple[int, str]] = field(default_factory=list)
    reached: list[int] = field(default_factory=list)
    heartbeat: bool = False  # send a HEARTBEAT at once (after a mode change)
    params: list[str] = field(default_factory=list)  # PARAM_VALUE to broadcast


class Autopilot:
    """Rover (Rover/Rover.h): the vehicle the modes drive. Times are seconds on the simulator
    clock. ``boat`` is Rover::is_boat (a boat loiters where a rover stops)."""

    def __init__(self, *, boat: bool = True, skid: bool = True, boot_time: float = 0.0,
                 timeline: Timeline | None = None, params: dict[str, float] | None = None,
                 latlon: Callable[[float, float], tuple[float, float]] | None = None,
                 firmware_defaults: bool = False) -> None:
        self.boat = boat
        # local x, y → (lat, lon) degrees, for the texts that name a place ("Set HOME to ...")
        self.latlon = latlon or (lambda x, y: (0.0, 0.0))
        self.skid = skid
        self.boot_time = boot_time
        self.timeline = timeline or Timeline()
        self.params = default_params(boat, skid, firmware_defaults)
        if params:
            self.params.update({k.upper(): float(v) for k, v in params.items()})
        self.armed = False
        self.out = Outbox()
        self.est = Estimate()
        self.home: tuple[float, float] | None = None  # local x, y
        self.ekf_origin: tuple[float, float] | None = None
        self.gps_has_fix = False  # set by the simulator from the GPS model each step
        self._initialised = False
        self._announced: set[str] = set()  # boot events said: home, origin, gps
        self._boot_text = 0  # index of the next timed boot text
        self._boot_done = False  # every boot text said, init done, GPS in use (see home/origin)
        self._boot_times = [self.timeline.map(b.at) for b in BOOT_TEXTS]
        self.rc = RcInput(self.params)
        # navigation targets the modes share (upstream: the waypoint and position controllers)
        self.wp: tuple[float, float] | None = None  # GUIDED destination, RTL home
        self.wp_notify = False  # MISSION_ITEM_REACHED on arrival (GUIDED position targets)
        self.loiter_point: tuple[float, float] | None = None
        self.atc = AttitudeControl(self.params)
        # the mode table (Rover::mode_from_mode_num): one instance per mode
        self.modes: dict[int, Mode] = {n: cls(self) for n, cls in MODE_CLASSES.items()}
        self.current: Mode = self.modes[INITIALISING]
        self.steering = 0.0  # -1..1 (ArduPilot -4500..4500)
        self.throttle = 0.0  # -1..1 (ArduPilot -100..100)
        self.motors = MotorsUGV(self.params, skid, self.text)
        self.failsafe = Failsafe(self)

    # ------------------------------------------------------------------ start-up timeline
    def uptime(self, now: float) -> float:
        return now - self.boot_time

    def arming_ready(self, now: float) -> bool:
        return self.uptime(now) >= self.timeline.arming

    def position_ok(self) -> bool:
        """Rover::position_ok: the EKF has a position and the EKF failsafe is not active."""
        return self.est.position_ok and not self.ekf_failsafe

    def text(self, severity: int, text: str) -> None:
        """Queue a STATUSTEXT for every link."""
        self.out.texts.append((severity, text))

    @property
    def mode(self) -> int:
        """The current mode's number."""
        return self.current.number

    @property
    def guided(self) -> ModeGuided:
        """GUIDED, whose targets arrive by MAVLink in any mode (and are ignored outside it)."""
        mode = self.modes[GUIDED]
        assert isinstance(mode, ModeGuided)
        return mode

    def update_timeline(self, now: float) -> None:
        """Advance the boot sequence: its texts, the mode after init, home, the EKF origin."""
        if self._boot_done and self.home is not None and self.ekf_origin is not None:
            return  # the sequence is over: nothing below can fire again
        up = self.uptime(now)
        if not self._initialised and up >= self.timeline.initialised:
            self._initialise()
        self._gps_events(up)
        self._say_boot_texts(up)
        self._boot_done = (self._initialised and "gps" in self._announced
                           and self._boot_text >= len(BOOT_TEXTS))

    def _initialise(self) -> None:
        """Initialisation done: enter INITIAL_MODE (MANUAL if it names no mode)."""
        self._initialised = True
        initial = int(self.params.get("INITIAL_MODE", 0))
        chosen = initial if initial in MODES and initial != INITIALISING else MANUAL
        # INITIAL_MODE is not checked: the mode is prepared and entered as it is
        self.modes[chosen]._start()
        self._switch(self.modes[chosen])

    def _gps_events(self, up: float) -> None:
        """Home at the first fix, then the EKF origin, then the EKF using GPS, each at its
        time on the timeline."""
        fix = self.gps_has_fix
        if self.home is None and up >= self.timeline.gps_fix and fix:
            self.home = (self.est.x, self.est.y)  # AP_GPS's first fix sets home
            self._announced.add("home")
        if self.ekf_origin is None and up >= self.timeline.ekf_origin and fix:
            self.ekf_origin = (self.est.x, self.est.y)
            self._announced.add("origin")
        if "gps" not in self._announced and up >= self.timeline.ekf_gps and fix:
            self._announced.add("gps")

    def _say_boot_texts(self, up: float) -> None:
        """The boot texts in order: each at its time, or once its event has happened."""
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
            self.text(b.severity, text)
            self._boot_text += 1

    # ------------------------------------------------------------------ modes
    def base_mode(self) -> int:
        b = MODE_FLAG_CUSTOM
        if self.current.has_manual_input():
            b |= MODE_FLAG_MANUAL
        if self.current.is_autopilot_mode():
            b |= MODE_FLAG_GUIDED
        if self.armed:
            b |= MODE_FLAG_ARMED
        return b

    def system_status(self) -> int:
        """GCS_MAVLINK_Rover::vehicle_system_status: CRITICAL in a GCS or EKF failsafe,
        CALIBRATING while initialising, STANDBY in HOLD, otherwise ACTIVE (armed or not)."""
        if self.failsafe.triggered or self.failsafe.ekf:
            return MAV_STATE_CRITICAL
        if self.mode == INITIALISING:
            return MAV_STATE_CALIBRATING
        if self.mode == HOLD:
            return MAV_STATE_STANDBY
        return MAV_STATE_ACTIVE

    @property
    def mode_name(self) -> str:
        return self.current.name

    def set_mode(self, number: int, now: float) -> bool:
        """Rover::set_mode: refuses unknown modes, modes whose needs are not met while armed,
        and modes whose ``_enter`` refuses (each says why)."""
        new = self.modes.get(number)
        if new is None:
            self.text(SEVERITY_WARNING, f"No such mode {number}")
            return False
        if new is self.current:
            return True
        if (self.armed and (new.requires_position() or new.requires_velocity())
                and not self.position_ok()):
            self.text(SEVERITY_WARNING, "Flight mode change failed")
            return False
        if not new._enter():
            return False
        self._switch(new)
        return True

    def _switch(self, new: Mode) -> None:
        """Leave the current mode for ``new`` (already entered); every link hears a HEARTBEAT
        at once. The controllers are not reset (Rover::set_mode and Mode::enter leave them):
        one unused for 0.2 s restarts by itself on its next call (AttitudeControl), so a mode
        that takes over within 0.2 s carries on from the desired speed and integrators the
        last one left, as upstream."""
        self.current._exit()
        self.current = new
        self.out.heartbeat = True

    # ------------------------------------------------------------------ arming
    def arm(self, arm: bool, now: float, force: bool = False) -> int:
        """MAV_CMD_COMPONENT_ARM_DISARM: returns a MAV_RESULT and queues refusal texts."""
        if not arm:
            if self.armed:
                self.armed = False
                self.text(SEVERITY_INFO, "Throttle disarmed")
            return RESULT_ACCEPTED
        if self.armed:
            return RESULT_ACCEPTED
        if not self._initialised or not self.current.allows_arming():
            return RESULT_FAILED
        if not self.arming_ready(now):
            # The IMU consistency check is mandatory, even with force (AP_Arming::mandatory_checks);
            # the real SITL's accelerometers settle first, then its gyros.
            which = "Accels" if self.uptime(now) < self.timeline.gyros else "Gyros"
            self.text(SEVERITY_CRITICAL, f"Arm: {which} inconsistent")
            return RESULT_FAILED
        if not force and int(self.params.get("ARMING_SKIPCHK", 0)) != -1:
            # AP_Arming_Rover::gps_checks only matter in modes that need position/velocity:
            # a Rover arms in MANUAL with no GPS at all.
            needs = self.current.requires_position() or self.current.requires_velocity()
            if needs and not self.position_ok():
                self.text(SEVERITY_CRITICAL, "Arm: Need Position Estimate")
                return RESULT_FAILED
        self.armed = True
        self.text(SEVERITY_INFO, "Throttle armed")
        self.atc.reset_pids()
        if self.mode == GUIDED:
            self.guided.idle()
        return RESULT_ACCEPTED

    # ------------------------------------------------------------------ GUIDED inputs
    def set_attitude_target(self, type_mask: int, q: tuple[float, float, float, float],
                            body_yaw_rate: float, thrust: float, now: float) -> None:
        """SET_ATTITUDE_TARGET: no ACK, ignored outside GUIDED or when thrust is masked."""
        if self.mode != GUIDED or type_mask & ATT_THROTTLE_IGNORE:
            return
        speed = self.params["WP_SPEED"] * clamp(thrust, -1.0, 1.0)
        if type_mask & ATT_YAW_RATE_IGNORE:
            w, x, y, z = q
            yaw = math.degrees(math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)))
            self.guided.set_desired_heading_and_speed(yaw, speed, now)
        else:
            self.guided.set_desired_turn_rate_and_speed(math.degrees(body_yaw_rate), speed, now)

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
        if (type_mask & ACC_IGNORE) != ACC_IGNORE:
            # GCS_MAVLINK_Rover::send_acc_ignore_must_be_set_message
            self.text(SEVERITY_INFO, f"Ignoring {message}; set ACC_IGNORE in mask")
            return
        pos_ignore = (type_mask & POS_IGNORE) == POS_IGNORE
        vel_ignore = (type_mask & VEL_IGNORE) == VEL_IGNORE
        yaw_ignore = bool(type_mask & YAW_IGNORE)
        rate_ignore = bool(type_mask & YAW_RATE_IGNORE)
        if not pos_ignore and x is not None and y is not None:
            self.guided.set_desired_location(x, y)
            return
        speed, heading = (0.0, 0.0) if vel_ignore else self._velocity_target(vx, vy, frame)
        if not yaw_ignore:
            heading = math.degrees(yaw) + (self.est.heading if frame == "body" else 0.0)
        rate = 0.0 if rate_ignore else math.degrees(yaw_rate)
        if not vel_ignore and (not yaw_ignore or not rate_ignore) and vx < 0:
            speed = -speed
        self._guided_velocity_target(vel_ignore, yaw_ignore, rate_ignore, heading, rate, speed,
                                     now)

    def _velocity_target(self, vx: float, vy: float, frame: str) -> tuple[float, float]:
        """(speed, heading in degrees) of a velocity target: the speed within WP_SPEED."""
        limit = self.params["WP_SPEED"]
        speed = clamp(math.hypot(vx, vy), -limit, limit)
        heading = math.degrees(math.atan2(vy, vx))
        if frame == "body":
            heading += self.est.heading
        return speed, heading

    def _guided_velocity_target(self, vel_ignore: bool, yaw_ignore: bool, rate_ignore: bool,
                                heading: float, rate: float, speed: float, now: float) -> None:
        """GCS_MAVLINK_Rover's choice of GUIDED sub-mode by what the mask leaves: a velocity
        with a heading (from the velocity itself or given) or with a turn rate, or a heading
        or turn rate alone at zero speed."""
        g = self.guided
        if not vel_ignore:
            if yaw_ignore and not rate_ignore:
                g.set_desired_turn_rate_and_speed(rate, speed, now)
            elif yaw_ignore or rate_ignore:  # not both a heading and a turn rate
                g.set_desired_heading_and_speed(heading, speed, now)
        elif not yaw_ignore and rate_ignore:
            g.set_desired_heading_and_speed(heading, 0.0, now)
        elif yaw_ignore and not rate_ignore:
            g.set_desired_turn_rate_and_speed(rate, 0.0, now)

    def guided_reposition(self, x: float, y: float, speed: float, change_mode: bool,
                          now: float) -> int:
        """MAV_CMD_DO_REPOSITION."""
        if self.mode != GUIDED and not change_mode:
            return RESULT_DENIED
        if self.mode != GUIDED and not self.set_mode(GUIDED, now):
            return RESULT_FAILED
        if speed > 0:
            self.guided.speed = speed
        self.guided.set_desired_location(x, y)
        return RESULT_ACCEPTED

    # ------------------------------------------------------------------ RC input
    def rc_override_msg(self, sysid: int, values: list[int], now: float) -> None:
        self.rc.override_msg(sysid, values, now)

    def manual_control_msg(self, sysid: int, y: int, z: int, now: float) -> None:
        self.rc.manual_control(sysid, y, z, now)

    def rc_in(self, now: float) -> list[int]:
        """Effective RC input per channel (override while fresh, else the radio)."""
        return self.rc.rc_in(now)

    @property
    def rc_override(self) -> list[int | None]:
        """The ground station's overrides per channel (None: the radio's)."""
        return self.rc.override

    def pilot_input(self, now: float) -> tuple[float, float]:
        """(steering, throttle) in -1..1 from the mapped RC channels."""
        return self.rc.pilot_input(now)

    # ------------------------------------------------------------------ servos
    def do_set_servo(self, channel: int, pwm: int) -> int:
        """MAV_CMD_DO_SET_SERVO: refused on outputs that already have a function."""
        return self.motors.do_set_servo(channel, pwm)

    def mix(self) -> tuple[float, float, float, float]:
        """(steering, throttle, left, right) after skid-steer mixing; zero when disarmed."""
        return self.motors.mix(self.steering, self.throttle, self.armed)

    def servo_map(self) -> list[tuple[int, int, float, float, float, bool]]:
        """(channel, function, min, max, trim, reversed) of the motor outputs."""
        return self.motors.servo_map()

    def invalidate(self) -> None:
        """Parameters changed: drop cached derived values (servo map, RC channels)."""
        self.motors.invalidate()
        self.rc.invalidate()

    def servo_outputs(self) -> list[int]:
        """SERVO_OUTPUT_RAW values for outputs 1..16."""
        return self.motors.outputs(self.steering, self.throttle, self.armed)

    # ------------------------------------------------------------------ failsafes
    def gcs_heartbeat(self, sysid: int, now: float) -> None:
        self.failsafe.gcs_heartbeat(sysid, now)

    @property
    def ekf_failsafe(self) -> bool:
        return self.failsafe.ekf

    # ------------------------------------------------------------------ control loop
    def update(self, now: float, dt: float) -> None:
        """One control-loop pass: timeline, failsafes, then the mode's controllers."""
        self.update_timeline(now)
        self.failsafe.check_gcs(now)
        self.failsafe.check_ekf(now, dt)
        if not self.armed:
            self.steering = 0.0
            self.throttle = 0.0
            self.atc.speed_target = self.est.forward_speed
            self.atc.reset_pids()
            # GUIDED targets still time out while disarmed
            self.guided.check_timeout(now)
            self._output(dt)
            return
        self.current.update(now, dt)
        self._output(dt)

    def _output(self, dt: float) -> None:
        """AP_MotorsUGV::output after the mode: the throttle the outputs carry is the demand
        slew-limited at MOT_SLEWRATE (zero while disarmed), and the motor limits it hit go to
        the speed controller's next pass."""
        m = self.motors
        out = m.output(self.steering, self.throttle, self.armed, dt)
        if self.armed:
            self.throttle = out
        self.steering = m.steering_output(self.steering, self.est.forward_speed, self.armed,
                                          self.current.scales_steering)
        self.atc.motor_limit = m.limit_lower or m.limit_upper
        self.atc.steer_limit = m.limit_steer
