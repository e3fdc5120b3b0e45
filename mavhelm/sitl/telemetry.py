"""The MAVLink messages the simulated vehicle sends, built from the simulator's state.

``Telemetry.build(mid, now, truth, wheels)`` returns one pymavlink message of id ``mid`` as
ArduPilot Rover would send it at ``now`` (or None when Rover has nothing to say yet, e.g.
LOCAL_POSITION_NED before the EKF origin). It reads the autopilot (modes, estimate, servo
outputs), the estimator (GPS fix, EKF status) and the true state; it sends nothing and keeps no
state of its own (but for the few messages that never change, built once), so which messages go
out when stays with the simulator's stream scheduling.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as M

from mavhelm.core.clock import boot_ms
from mavhelm.sitl import autopilot as ap
from mavhelm.sitl.estimator import Estimator
from mavhelm.sitl.flat_earth import Origin
from mavhelm.sitl.modes import GuidedSubMode
from mavhelm.sitl.truth import Truth

HEARTBEAT = M.MAVLINK_MSG_ID_HEARTBEAT
GPS_UNKNOWN_DOP = 65535  # AP_GPS before a receiver is detected
FENCE_ALT_MAX, FENCE_CIRCLE, FENCE_POLYGON, FENCE_ALT_MIN = 1, 2, 4, 8  # FENCE_TYPE bits
GPS_FIX_TYPE_SITL = M.GPS_FIX_TYPE_RTK_FIXED  # SITL's simulated u-blox reports 6

# SYS_STATUS sensor bits as the real Rover 4.8 SITL (motorboat) reports them. Present: gyro,
# accel, mag, baro, GPS, motor outputs, RC receiver, ... (0x1331dc2f, the geofence bit from
# FENCE_TYPE); enabled and healthy before the GPS fix and the AHRS checks: the values it sends
# at boot. GPS, AHRS and pre-arm health are added as they become true (see build()).
SYS_PRESENT = 0x1331DC2F
SYS_ENABLED = 0x1201802F
SYS_HEALTH = 0x0311810F


def wrap_pi(a: float) -> float:
    """An angle in radians wrapped to [-π, π), as ATTITUDE and friends carry yaw."""
    return (a + math.pi) % (2 * math.pi) - math.pi


def fence_status(params: dict[str, float]) -> tuple[bool, bool]:
    """(present, enabled) as AC_Fence reports them in SYS_STATUS. A fence type counts as
    present if it is configured in FENCE_TYPE (the polygon only once one is uploaded, and
    nothing can be uploaded here); enabled needs FENCE_ENABLE and an action other than
    report-only."""
    p = params
    present = bool(int(p.get("FENCE_TYPE", 0))
                   & (FENCE_ALT_MAX | FENCE_CIRCLE | FENCE_ALT_MIN))
    enabled = (present and int(p.get("FENCE_ENABLE", 0)) != 0
               and int(p.get("FENCE_ACTION", 0)) != 0)
    return present, enabled


class Telemetry:
    """Builds the vehicle's outgoing messages.

    autopilot and estimator are read at build time (never copied), so the messages always
    show their current state; home is the local frame's origin, boot the sim time of power-on
    and epoch the Unix time of sim t = 0 (GPS and SYSTEM_TIME clocks).
    """

    def __init__(self, autopilot: ap.Autopilot, estimator: Estimator, *, home: Origin,
                 boot: float, epoch: float, mav_type: int) -> None:
        self.autopilot = autopilot
        self.estimator = estimator
        self.home = home
        self.boot = boot
        self.epoch = epoch
        self.mav_type = mav_type  # HEARTBEAT type: the vehicle model's
        self._constant: dict[int, Any] = {}  # the CONSTANT messages, built once

    def boot_ms(self, now: float) -> int:
        """Milliseconds since boot, wrapped to uint32 like time_boot_ms."""
        return boot_ms(now - self.boot)

    def latlon(self, x: float, y: float) -> tuple[int, int]:
        """A local position as MAVLink's degE7 integers."""
        lat, lon = self.home.to_global(x, y)
        return int(round(lat * 1e7)), int(round(lon * 1e7))

    def build(self, mid: int, now: float, truth: Truth, wheels: list[float]) -> Any:
        """One telemetry message of id mid as of now, or None if it has nothing to say (or no
        builder is known for mid): a lookup in ``BUILDERS``.

        truth is the vehicle's true state (SIMSTATE, IMU, depth) and wheels the two wheel
        odometers in m (WHEEL_DISTANCE)."""
        msg = self._constant.get(mid)
        if msg is not None:
            return msg
        builder = BUILDERS.get(mid)
        if builder is None:
            return None
        msg = builder(self, now, truth, wheels)
        if mid in CONSTANT:
            self._constant[mid] = msg
        return msg

    # ------------------------------------------------------------------ one builder a message
    def _heartbeat(self, _now: float, _tr: Truth, _wheels: list[float]) -> Any:
        a = self.autopilot
        return M.MAVLink_heartbeat_message(self.mav_type, M.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                           a.base_mode(), a.mode, a.system_status(), 3)

    def _attitude(self, now: float, tr: Truth, _wheels: list[float]) -> Any:
        a = self.autopilot
        est = a.est
        boot_ms = self.boot_ms(now)
        return M.MAVLink_attitude_message(boot_ms, math.radians(tr.roll),
                                          math.radians(tr.pitch),
                                          wrap_pi(math.radians(est.heading)), 0.0, 0.0,
                                          math.radians(est.yaw_rate))

    def _gps_raw_int(self, now: float, _tr: Truth, _wheels: list[float]) -> Any:
        return self.gps_raw(now)

    def _global_position_int(self, now: float, _tr: Truth, _wheels: list[float]) -> Any:
        a = self.autopilot
        est = a.est
        boot_ms = self.boot_ms(now)
        if a.ekf_origin is None:
            lat = lon = 0
        else:
            lat, lon = self.latlon(est.x, est.y)
        hdg = int(round(est.heading * 100)) % 36000
        return M.MAVLink_global_position_int_message(
            boot_ms, lat, lon, 0, 0, int(round(est.vy * 100)), int(round(est.vx * 100)), 0,
            hdg)

    def _local_position_ned(self, now: float, _tr: Truth, _wheels: list[float]) -> Any:
        a = self.autopilot
        est = a.est
        boot_ms = self.boot_ms(now)
        if a.ekf_origin is None:
            return None
        ox, oy = a.ekf_origin
        return M.MAVLink_local_position_ned_message(boot_ms, est.y - oy, est.x - ox, 0.0,
                                                    est.vy, est.vx, 0.0)

    def _vfr_hud(self, _now: float, _tr: Truth, _wheels: list[float]) -> Any:
        a = self.autopilot
        est = a.est
        spd = math.hypot(est.vx, est.vy)
        return M.MAVLink_vfr_hud_message(spd, spd, int(est.heading) % 360,
                                         int(round(abs(a.mix()[1]) * 100)), 0.0, 0.0)

    def _sys_status(self, now: float, _tr: Truth, _wheels: list[float]) -> Any:
        a = self.autopilot
        fence = M.MAV_SYS_STATUS_GEOFENCE
        present, enabled, health = SYS_PRESENT & ~fence, SYS_ENABLED & ~fence, SYS_HEALTH
        if self.estimator.gps is not None:  # a receiver was detected
            enabled |= M.MAV_SYS_STATUS_SENSOR_GPS
        if a.gps_has_fix:
            health |= M.MAV_SYS_STATUS_SENSOR_GPS
        if a.arming_ready(now):
            # the AHRS is reported (enabled, healthy) once its checks settle, and the
            # pre-arm checks pass then (Rover 4.8 SITL: 23 s, seen in the 1 Hz SYS_STATUS
            # at 23-24 s); an EKF failsafe takes the AHRS health away
            enabled |= M.MAV_SYS_STATUS_AHRS
            if not a.ekf_failsafe:
                health |= M.MAV_SYS_STATUS_AHRS
            health |= M.MAV_SYS_STATUS_PREARM_CHECK
        fence_present, fence_enabled = fence_status(a.params)
        if fence_present:
            present |= M.MAV_SYS_STATUS_GEOFENCE
        if fence_enabled:
            enabled |= M.MAV_SYS_STATUS_GEOFENCE
        # healthy unless the fence has failed (breached); no fence is ever breached here
        health |= M.MAV_SYS_STATUS_GEOFENCE
        return M.MAVLink_sys_status_message(present, enabled, health, 150, 12600, 150, 90,
                                            0, 0, 0, 0, 0, 0)

    def _extended_sys_state(self, _now: float, _tr: Truth, _wheels: list[float]) -> Any:
        return M.MAVLink_extended_sys_state_message(M.MAV_VTOL_STATE_UNDEFINED,
                                                    M.MAV_LANDED_STATE_UNDEFINED)

    def _system_time(self, now: float, _tr: Truth, _wheels: list[float]) -> Any:
        boot_ms = self.boot_ms(now)
        unix = int((now + self.epoch) * 1e6) if self.estimator.ever_fix else 0
        return M.MAVLink_system_time_message(unix, boot_ms)

    def _raw_imu(self, now: float, tr: Truth, _wheels: list[float]) -> Any:
        xm, ym, zm = self.mag()
        return M.MAVLink_raw_imu_message(int((now - self.boot) * 1e6), 0, 0, -1000, 0, 0,
                                         int(math.radians(tr.yaw_rate) * 1000), xm, ym, zm,
                                         0, 0)

    def _scaled_imu2(self, now: float, tr: Truth, _wheels: list[float]) -> Any:
        boot_ms = self.boot_ms(now)
        xm, ym, zm = self.mag()
        return M.MAVLink_scaled_imu2_message(boot_ms, 0, 0, -1000, 0, 0,
                                             int(math.radians(tr.yaw_rate) * 1000), xm, ym,
                                             zm, 0)

    def _scaled_pressure(self, now: float, _tr: Truth, _wheels: list[float]) -> Any:
        boot_ms = self.boot_ms(now)
        return M.MAVLink_scaled_pressure_message(boot_ms, 1013.25, 0.0, 2000, 0)

    def _servo_output_raw(self, now: float, _tr: Truth, _wheels: list[float]) -> Any:
        a = self.autopilot
        o = a.servo_outputs()
        return M.MAVLink_servo_output_raw_message(int((now - self.boot) * 1e6) & 0xFFFFFFFF,
                                                  0, *o)

    def _rc_channels(self, now: float, _tr: Truth, _wheels: list[float]) -> Any:
        a = self.autopilot
        boot_ms = self.boot_ms(now)
        rc = a.rc_in(now)
        return M.MAVLink_rc_channels_message(boot_ms, 16, *rc[:18], 255)

    def _ekf_status_report(self, now: float, _tr: Truth, _wheels: list[float]) -> Any:
        a = self.autopilot
        est = a.est
        flags, var = self.estimator.ekf_flags(now, est, a.gps_has_fix)
        return M.MAVLink_ekf_status_report_message(flags, var, var, 0.01, 0.02, 0.0, 0.0)

    def _distance_sensor(self, now: float, tr: Truth, _wheels: list[float]) -> Any:
        boot_ms = self.boot_ms(now)
        depth_cm = int(round(tr.water_depth * 100))
        return M.MAVLink_distance_sensor_message(boot_ms, 20, 10000, min(depth_cm, 10000),
                                                 M.MAV_DISTANCE_SENSOR_ULTRASOUND, 0,
                                                 M.MAV_SENSOR_ROTATION_PITCH_270, 0)

    def _rangefinder(self, _now: float, tr: Truth, _wheels: list[float]) -> Any:
        return M.MAVLink_rangefinder_message(min(tr.water_depth, 100.0), 0.0)

    def _wheel_distance(self, now: float, _tr: Truth, wheels: list[float]) -> Any:
        d = wheels + [0.0] * 14
        return M.MAVLink_wheel_distance_message(int((now - self.boot) * 1e6), 2, d)

    def _simstate(self, _now: float, tr: Truth, _wheels: list[float]) -> Any:
        lat, lon = self.latlon(tr.x, tr.y)
        return M.MAVLink_simstate_message(math.radians(tr.roll), math.radians(tr.pitch),
                                          wrap_pi(math.radians(tr.heading)), 0.0, 0.0,
                                          -9.81, 0.0, 0.0, math.radians(tr.yaw_rate),
                                          lat, lon)

    def _ahrs2(self, _now: float, _tr: Truth, _wheels: list[float]) -> Any:
        a = self.autopilot
        est = a.est
        lat, lon = self.latlon(est.x, est.y) if a.ekf_origin is not None else (0, 0)
        return M.MAVLink_ahrs2_message(0.0, 0.0, wrap_pi(math.radians(est.heading)), 0.0,
                                       lat, lon)

    def _ahrs(self, _now: float, _tr: Truth, _wheels: list[float]) -> Any:
        return M.MAVLink_ahrs_message(0.0, 0.0, 0.0, 0.0, 0.0, 0.001, 0.001)

    def _power_status(self, _now: float, _tr: Truth, _wheels: list[float]) -> Any:
        return M.MAVLink_power_status_message(5000, 0, 0)

    def _meminfo(self, _now: float, _tr: Truth, _wheels: list[float]) -> Any:
        return M.MAVLink_meminfo_message(0, 65535, 131072)

    def _mission_current(self, _now: float, _tr: Truth, _wheels: list[float]) -> Any:
        return M.MAVLink_mission_current_message(0, 0, 0, 0)

    def _nav_controller_output(self, _now: float, _tr: Truth, _wheels: list[float]) -> Any:
        return self.nav_controller()

    def _battery_status(self, _now: float, _tr: Truth, _wheels: list[float]) -> Any:
        return M.MAVLink_battery_status_message(0, 0, 0, 32767, [12600] + [65535] * 9, 150,
                                                -1, -1, 90)

    def _vibration(self, now: float, _tr: Truth, _wheels: list[float]) -> Any:
        return M.MAVLink_vibration_message(int((now - self.boot) * 1e6), 0.01, 0.01, 0.01,
                                           0, 0, 0)

    def _home_position(self, _now: float, _tr: Truth, _wheels: list[float]) -> Any:
        a = self.autopilot
        if a.home is None:
            return None
        lat, lon = self.latlon(*a.home)
        ox, oy = a.ekf_origin or a.home
        return M.MAVLink_home_position_message(lat, lon, 0, a.home[1] - oy, a.home[0] - ox,
                                               0.0, [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, 0.0)

    def _gps_global_origin(self, _now: float, _tr: Truth, _wheels: list[float]) -> Any:
        a = self.autopilot
        if a.ekf_origin is None:
            return None
        lat, lon = self.latlon(*a.ekf_origin)
        return M.MAVLink_gps_global_origin_message(lat, lon, 0)

    def _autopilot_version(self, _now: float, _tr: Truth, _wheels: list[float]) -> Any:
        caps = (M.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT | M.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
                | M.MAV_PROTOCOL_CAPABILITY_MISSION_INT | M.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
                | M.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
                | M.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
                | M.MAV_PROTOCOL_CAPABILITY_SET_ATTITUDE_TARGET
                | M.MAV_PROTOCOL_CAPABILITY_MAVLINK2)
        version = (4 << 24) | (8 << 16) | (0 << 8) | 0  # 4.8.0-dev, the measured build
        return M.MAVLink_autopilot_version_message(caps, version, 0, 0, 0, [0] * 8, [0] * 8,
                                                   [0] * 8, 0, 0, 0)

    def _position_target_global_int(self, now: float, _tr: Truth, _wheels: list[float]) -> Any:
        a = self.autopilot
        boot_ms = self.boot_ms(now)
        if a.mode != ap.GUIDED or a.wp is None:
            return None
        lat, lon = self.latlon(*a.wp)
        return M.MAVLink_position_target_global_int_message(
            boot_ms, M.MAV_FRAME_GLOBAL, 0xFF8, lat, lon, 0.0, 0, 0, 0, 0, 0, 0, 0, 0)


    def mag(self) -> tuple[int, int, int]:
        """Raw magnetometer (mGauss) consistent with the heading the autopilot believes."""
        h = math.radians(self.autopilot.est.heading)
        return int(200 * math.cos(h)), int(-200 * math.sin(h)), 400

    def gps_raw(self, now: float) -> Any:
        """GPS_RAW_INT from the receiver's latest sample (AP_GPS's view, not the EKF's)."""
        e = self.estimator
        g = e.gps
        if g is None:
            return M.MAVLink_gps_raw_int_message(0, M.GPS_FIX_TYPE_NO_GPS, 0, 0, 0,
                                                 GPS_UNKNOWN_DOP, GPS_UNKNOWN_DOP, 0, 0, 0)
        # time_usec: the sample's time since boot, as the real SITL sends it
        t_us = int(max(0.0, g.t - self.boot) * 1e6)
        if g.fix < 3:
            lat, lon = self.latlon(g.x, g.y) if e.ever_fix else (0, 0)
            return M.MAVLink_gps_raw_int_message(t_us, M.GPS_FIX_TYPE_NO_FIX, lat, lon, 0,
                                                 g.eph, g.eph, 0, 0, 0)
        lat, lon = self.latlon(g.x, g.y)
        vel = math.hypot(g.vx, g.vy)
        cog = int(round(math.degrees(math.atan2(g.vx, g.vy)) * 100)) % 36000 if vel > 0.05 else 0
        return M.MAVLink_gps_raw_int_message(t_us, GPS_FIX_TYPE_SITL, lat, lon, 0, g.eph,
                                             200, int(round(vel * 100)), cog, g.sats, 0, 300,
                                             500, 150, 0, 0)

    def nav_controller(self) -> Any:
        """NAV_CONTROLLER_OUTPUT: bearing and distance to the current target, if any."""
        a = self.autopilot
        tgt = a.wp if a.mode in (ap.GUIDED, ap.RTL, ap.SMART_RTL) and a.wp else None
        g = a.guided
        loitering = a.mode == ap.LOITER or (a.mode == ap.GUIDED
                                            and g.sub == GuidedSubMode.LOITER)
        if tgt is None and loitering:
            tgt = a.loiter_point
        if tgt is None:
            bearing = (int(g.desired_heading) if g.sub == GuidedSubMode.HEADING_AND_SPEED
                       else 0)
            return M.MAVLink_nav_controller_output_message(0.0, 0.0, bearing, 0, 0, 0.0, 0.0, 0.0)
        dx, dy = tgt[0] - a.est.x, tgt[1] - a.est.y
        b = int(round(math.degrees(math.atan2(dx, dy))))
        return M.MAVLink_nav_controller_output_message(0.0, 0.0, b, b,
                                                       min(int(math.hypot(dx, dy)), 65535),
                                                       0.0, 0.0, 0.0)


# The message-builder table: MAVLink message id → the Telemetry method that builds it.
BUILDERS: dict[int, Callable[[Telemetry, float, Truth, list[float]], Any]] = {
    HEARTBEAT: Telemetry._heartbeat,
    M.MAVLINK_MSG_ID_ATTITUDE: Telemetry._attitude,
    M.MAVLINK_MSG_ID_GPS_RAW_INT: Telemetry._gps_raw_int,
    M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: Telemetry._global_position_int,
    M.MAVLINK_MSG_ID_LOCAL_POSITION_NED: Telemetry._local_position_ned,
    M.MAVLINK_MSG_ID_VFR_HUD: Telemetry._vfr_hud,
    M.MAVLINK_MSG_ID_SYS_STATUS: Telemetry._sys_status,
    M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: Telemetry._extended_sys_state,
    M.MAVLINK_MSG_ID_SYSTEM_TIME: Telemetry._system_time,
    M.MAVLINK_MSG_ID_RAW_IMU: Telemetry._raw_imu,
    M.MAVLINK_MSG_ID_SCALED_IMU2: Telemetry._scaled_imu2,
    M.MAVLINK_MSG_ID_SCALED_PRESSURE: Telemetry._scaled_pressure,
    M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW: Telemetry._servo_output_raw,
    M.MAVLINK_MSG_ID_RC_CHANNELS: Telemetry._rc_channels,
    M.MAVLINK_MSG_ID_EKF_STATUS_REPORT: Telemetry._ekf_status_report,
    M.MAVLINK_MSG_ID_DISTANCE_SENSOR: Telemetry._distance_sensor,
    M.MAVLINK_MSG_ID_RANGEFINDER: Telemetry._rangefinder,
    M.MAVLINK_MSG_ID_WHEEL_DISTANCE: Telemetry._wheel_distance,
    M.MAVLINK_MSG_ID_SIMSTATE: Telemetry._simstate,
    M.MAVLINK_MSG_ID_AHRS2: Telemetry._ahrs2,
    M.MAVLINK_MSG_ID_AHRS: Telemetry._ahrs,
    M.MAVLINK_MSG_ID_POWER_STATUS: Telemetry._power_status,
    M.MAVLINK_MSG_ID_MEMINFO: Telemetry._meminfo,
    M.MAVLINK_MSG_ID_MISSION_CURRENT: Telemetry._mission_current,
    M.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT: Telemetry._nav_controller_output,
    M.MAVLINK_MSG_ID_BATTERY_STATUS: Telemetry._battery_status,
    M.MAVLINK_MSG_ID_VIBRATION: Telemetry._vibration,
    M.MAVLINK_MSG_ID_HOME_POSITION: Telemetry._home_position,
    M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN: Telemetry._gps_global_origin,
    M.MAVLINK_MSG_ID_AUTOPILOT_VERSION: Telemetry._autopilot_version,
    M.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: Telemetry._position_target_global_int,
}
# Messages whose content never changes: built once and sent again as they are (their packets
# differ only in sequence number, see links.Link.send_again).
CONSTANT = frozenset({
    M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, M.MAVLINK_MSG_ID_AHRS, M.MAVLINK_MSG_ID_POWER_STATUS,
    M.MAVLINK_MSG_ID_MEMINFO, M.MAVLINK_MSG_ID_MISSION_CURRENT,
    M.MAVLINK_MSG_ID_BATTERY_STATUS, M.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
})
