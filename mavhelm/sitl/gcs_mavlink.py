"""The autopilot's MAVLink front (libraries/GCS_MAVLink/GCS_Common.cpp, Rover/GCS_Mavlink.cpp):
every message a client sends is routed on to the other links, then obeyed through two dispatch
tables, one of message handlers by message type and one of command handlers by MAV_CMD.

A handler decodes the message (frames, units, masks) and hands the autopilot (``autopilot.py``)
or the simulator's parameter table and streams what it means; nothing here steps the world.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from pymavlink.dialects.v20 import ardupilotmega as M

from mavhelm.core.geodesy import lat_lon_e7
from mavhelm.sitl import autopilot as ap
from mavhelm.sitl.ftp import ftp_reply
from mavhelm.sitl.links import Link
from mavhelm.sitl.modes import GuidedSubMode
from mavhelm.sitl.statustext import BANNER
from mavhelm.sitl.telemetry import BUILDERS, HEARTBEAT

if TYPE_CHECKING:
    from mavhelm.sitl.simulator import Simulator

# Streams as ArduPilot groups them (Rover/GCS_Mavlink.cpp), for REQUEST_DATA_STREAM.
STREAMS: dict[int, tuple[int, ...]] = {
    M.MAV_DATA_STREAM_RAW_SENSORS: (M.MAVLINK_MSG_ID_RAW_IMU, M.MAVLINK_MSG_ID_SCALED_IMU2,
                                    M.MAVLINK_MSG_ID_SCALED_PRESSURE),
    M.MAV_DATA_STREAM_EXTENDED_STATUS: (
        M.MAVLINK_MSG_ID_SYS_STATUS, M.MAVLINK_MSG_ID_POWER_STATUS, M.MAVLINK_MSG_ID_MEMINFO,
        M.MAVLINK_MSG_ID_MISSION_CURRENT, M.MAVLINK_MSG_ID_GPS_RAW_INT,
        M.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT, M.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT),
    M.MAV_DATA_STREAM_POSITION: (M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
                                 M.MAVLINK_MSG_ID_LOCAL_POSITION_NED),
    M.MAV_DATA_STREAM_RC_CHANNELS: (M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW,
                                    M.MAVLINK_MSG_ID_RC_CHANNELS),
    M.MAV_DATA_STREAM_EXTRA1: (M.MAVLINK_MSG_ID_ATTITUDE, M.MAVLINK_MSG_ID_SIMSTATE,
                               M.MAVLINK_MSG_ID_AHRS2),
    M.MAV_DATA_STREAM_EXTRA2: (M.MAVLINK_MSG_ID_VFR_HUD,),
    M.MAV_DATA_STREAM_EXTRA3: (
        M.MAVLINK_MSG_ID_AHRS, M.MAVLINK_MSG_ID_SYSTEM_TIME, M.MAVLINK_MSG_ID_RANGEFINDER,
        M.MAVLINK_MSG_ID_DISTANCE_SENSOR, M.MAVLINK_MSG_ID_BATTERY_STATUS,
        M.MAVLINK_MSG_ID_EKF_STATUS_REPORT, M.MAVLINK_MSG_ID_VIBRATION,
        M.MAVLINK_MSG_ID_WHEEL_DISTANCE),
}
BOAT_ONLY = {M.MAVLINK_MSG_ID_RANGEFINDER, M.MAVLINK_MSG_ID_DISTANCE_SENSOR}
ROVER_ONLY = {M.MAVLINK_MSG_ID_WHEEL_DISTANCE}
# Fixed emission order (deterministic): heartbeat first, then stream order.
ORDER = [HEARTBEAT] + [m for s in STREAMS.values() for m in s]
ORDER_INDEX = {m: i for i, m in enumerate(ORDER)}

# Every message Telemetry can build: the streams, plus HOME_POSITION, GPS_GLOBAL_ORIGIN,
# AUTOPILOT_VERSION and EXTENDED_SYS_STATE (in no Rover stream but, like every vehicle, sent on
# request). ArduPilot answers FAILED for ids it has no ap_message for.
KNOWN = frozenset(BUILDERS)

FORCE_ARM_MAGIC = (2989, 21196)  # COMPONENT_ARM_DISARM param2 that skips the arming checks

MessageHandler = Callable[["GcsMavlink", Link, Any, float], None]
# (self, link, msg, now, params 1-7, frame or None for COMMAND_LONG) → (result, replies)
CommandHandler = Callable[["GcsMavlink", Link, Any, float, list[float], "int | None"],
                          tuple[int, list[Any]]]


class GcsMavlink:
    """GCS_MAVLINK_Rover for every link of one simulator: routing, then the dispatch tables
    ``MESSAGE_HANDLERS`` and ``COMMAND_HANDLERS`` (filled in below the class)."""

    MESSAGE_HANDLERS: dict[str, MessageHandler] = {}
    COMMAND_HANDLERS: dict[int, CommandHandler] = {}

    def __init__(self, sim: Simulator) -> None:
        self.sim = sim

    # ------------------------------------------------------------------ routing
    def handle(self, link: Link, msg: Any, now: float) -> None:
        """One message from a link: remember who spoke there, route it on, then obey it if
        it is ours (a HEARTBEAT is heard whatever its target)."""
        src = msg.get_srcSystem()
        link.systems_seen.add((src, msg.get_srcComponent()))
        self._forward(link, msg)
        t = msg.get_type()
        if t == "HEARTBEAT":
            self.sim.autopilot.gcs_heartbeat(src, now)
            return
        if not self._for_us(msg):
            return
        handler = self.MESSAGE_HANDLERS.get(t)
        if handler is not None:
            handler(self, link, msg, now)

    def _for_us(self, msg: Any) -> bool:
        ts = getattr(msg, "target_system", 0)
        tc = getattr(msg, "target_component", 0)
        return ts in (0, self.sim.sysid) and tc in (0, 1)

    def _forward(self, link: Link, msg: Any) -> None:
        """MAVLink routing: broadcasts go to every other link; targeted ones to where the
        target system was seen."""
        ts = getattr(msg, "target_system", getattr(msg, "target", None))
        tc = getattr(msg, "target_component", 0)
        raw = None
        for other in self.sim.hub.links:
            if other is link:
                continue
            seen = other.systems_seen
            if (ts is None or ts == 0 or (ts, tc) in seen
                    or (tc == 0 and any(s == ts for s, _ in seen))):
                if raw is None:
                    raw = bytes(msg.get_msgbuf())
                other.send_raw(raw)

    # ------------------------------------------------------------------ messages
    def _command_long(self, link: Link, msg: Any, now: float) -> None:
        self._command(link, msg, now, msg.command,
                      [msg.param1, msg.param2, msg.param3, msg.param4, msg.param5,
                       msg.param6, msg.param7], None)

    def _command_int(self, link: Link, msg: Any, now: float) -> None:
        self._command(link, msg, now, msg.command,
                      [msg.param1, msg.param2, msg.param3, msg.param4, msg.x, msg.y, msg.z],
                      msg.frame)

    def _set_mode(self, link: Link, msg: Any, now: float) -> None:
        if msg.base_mode & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            self.sim.autopilot.set_mode(int(msg.custom_mode), now)

    def _set_attitude_target(self, link: Link, msg: Any, now: float) -> None:
        self.sim.autopilot.set_attitude_target(msg.type_mask, tuple(msg.q), msg.body_yaw_rate,
                                               msg.thrust, now)

    def _rc_channels_override(self, link: Link, msg: Any, now: float) -> None:
        vals = [getattr(msg, f"chan{i}_raw", 0) for i in range(1, 19)]
        self.sim.autopilot.rc_override_msg(msg.get_srcSystem(), vals, now)

    def _param_request_list(self, link: Link, msg: Any, now: float) -> None:
        # GCS_MAVLINK::handle_param_request_list sends the banner first, on this link
        for text in BANNER:
            link.send(M.MAVLink_statustext_message(ap.SEVERITY_INFO, text.encode(), 0, 0))
        table = self.sim.param_table
        for name in table.names:
            link.send(table.value_message(name))

    def _param_request_read(self, link: Link, msg: Any, now: float) -> None:
        table = self.sim.param_table
        name = _param_name(msg.param_id)
        by_index = table.name_at(msg.param_index)
        if by_index is not None:
            name = by_index
        if name in table:
            link.send(table.value_message(name))

    def _param_set(self, link: Link, msg: Any, now: float) -> None:
        name = _param_name(msg.param_id)
        if self.sim.set_param(name, msg.param_value):
            self.sim.broadcast(self.sim.param_table.value_message(name))

    def _request_data_stream(self, link: Link, msg: Any, now: float) -> None:
        rate = msg.req_message_rate if msg.start_stop else 0
        ids = (STREAMS.keys() if msg.req_stream_id == M.MAV_DATA_STREAM_ALL
               else [msg.req_stream_id])
        for sid in ids:
            for mid in STREAMS.get(sid, ()):
                if mid in self.sim.absent:
                    continue
                if rate > 0:
                    link.set_interval(mid, 1.0 / rate,
                                      min(link.next_due.get(mid, now), now + 1.0 / rate))
                else:
                    link.set_interval(mid, 0.0, now)

    def _mission_request_list(self, link: Link, msg: Any, now: float) -> None:
        link.send(M.MAVLink_mission_count_message(msg.get_srcSystem(), msg.get_srcComponent(),
                                                  0, getattr(msg, "mission_type", 0)))

    def _manual_control(self, link: Link, msg: Any, now: float) -> None:
        if msg.target in (0, self.sim.sysid):
            self.sim.autopilot.manual_control_msg(msg.get_srcSystem(), msg.y, msg.z, now)

    def _timesync(self, link: Link, msg: Any, now: float) -> None:
        if msg.tc1 == 0:  # a request: answer with our clock, echoing theirs
            link.send(M.MAVLink_timesync_message(int((now - self.sim.boot) * 1e9), msg.ts1))

    def _file_transfer_protocol(self, link: Link, msg: Any, now: float) -> None:
        reply = ftp_reply(bytes(msg.payload))
        if reply is not None:
            link.send(M.MAVLink_file_transfer_protocol_message(
                0, msg.get_srcSystem(), msg.get_srcComponent(), list(reply)))

    def _position_target_local(self, link: Link, msg: Any, now: float) -> None:
        a = self.sim.autopilot
        if a.mode != ap.GUIDED or a.ekf_origin is None:
            return
        f = msg.coordinate_frame
        if f not in (M.MAV_FRAME_LOCAL_NED, M.MAV_FRAME_LOCAL_OFFSET_NED, M.MAV_FRAME_BODY_NED,
                     M.MAV_FRAME_BODY_OFFSET_NED):
            return
        body = f in (M.MAV_FRAME_BODY_NED, M.MAV_FRAME_BODY_OFFSET_NED)
        est = a.est
        if f == M.MAV_FRAME_LOCAL_NED:
            ox, oy = a.ekf_origin
            x, y = ox + msg.y, oy + msg.x
        elif f == M.MAV_FRAME_LOCAL_OFFSET_NED:
            x, y = est.x + msg.y, est.y + msg.x
        else:
            h = math.radians(est.heading)
            north = msg.x * math.cos(h) - msg.y * math.sin(h)
            east = msg.x * math.sin(h) + msg.y * math.cos(h)
            x, y = est.x + east, est.y + north
        a.set_position_target(type_mask=msg.type_mask, frame="body" if body else "ned", x=x, y=y,
                              vx=msg.vx, vy=msg.vy, yaw=msg.yaw, yaw_rate=msg.yaw_rate, now=now)

    def _position_target_global(self, link: Link, msg: Any, now: float) -> None:
        a = self.sim.autopilot
        if a.mode != ap.GUIDED:
            return
        if msg.coordinate_frame not in (0, 3, 5, 6, 10, 11):
            return
        x = y = None
        if (msg.type_mask & ap.POS_IGNORE) != ap.POS_IGNORE:
            try:
                x, y = self.sim.home.to_local(*lat_lon_e7(msg.lat_int, msg.lon_int))
            except ValueError:
                return
        a.set_position_target(type_mask=msg.type_mask, frame="ned", x=x, y=y, vx=msg.vx,
                              vy=msg.vy, yaw=msg.yaw, yaw_rate=msg.yaw_rate, now=now,
                              message="SET_POSITION_TARGET_GLOBAL_INT")

    # ------------------------------------------------------------------ commands
    def _command(self, link: Link, msg: Any, now: float, cmd: int, p: list[float],
                 frame: int | None) -> None:
        """COMMAND_LONG/INT: the handler's result is ACKed on the asking link, then its
        replies (None: nothing to say yet) follow; an unknown command is UNSUPPORTED."""
        handler = self.COMMAND_HANDLERS.get(cmd)
        result, after = (ap.RESULT_UNSUPPORTED, []) if handler is None else handler(
            self, link, msg, now, p, frame)
        link.send(M.MAVLink_command_ack_message(cmd, result, 0, 0, msg.get_srcSystem(),
                                                msg.get_srcComponent()))
        for m in after:
            if m is not None:
                link.send(m)

    def _do_set_mode(self, link: Link, msg: Any, now: float, p: list[float],
                     frame: int | None) -> tuple[int, list[Any]]:
        # GCS_MAVLINK::_set_mode_common: only custom modes; anything else is DENIED
        if not int(p[0]) & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return ap.RESULT_DENIED, []
        ok = self.sim.autopilot.set_mode(int(p[1]), now)
        return (ap.RESULT_ACCEPTED if ok else ap.RESULT_FAILED), []

    def _arm_disarm(self, link: Link, msg: Any, now: float, p: list[float],
                    frame: int | None) -> tuple[int, list[Any]]:
        force = int(round(p[1])) in FORCE_ARM_MAGIC
        return self.sim.autopilot.arm(p[0] > 0.5, now, force=force), []

    def _do_set_servo(self, link: Link, msg: Any, now: float, p: list[float],
                      frame: int | None) -> tuple[int, list[Any]]:
        return self.sim.autopilot.do_set_servo(int(p[0]), int(p[1])), []

    def _set_message_interval(self, link: Link, msg: Any, now: float, p: list[float],
                              frame: int | None) -> tuple[int, list[Any]]:
        mid, us = int(p[0]), p[1]
        if mid not in KNOWN:
            self.sim.autopilot.text(ap.SEVERITY_INFO, f"No ap_message for mavlink id ({mid})")
            return ap.RESULT_FAILED, []
        if us < 0:
            iv = 0.0
        elif us == 0:
            iv = self.sim.stream_defaults.get(mid, 0.0)
        else:
            iv = us / 1e6
        link.set_interval(mid, iv, now + iv)
        return ap.RESULT_ACCEPTED, []

    def _get_message_interval(self, link: Link, msg: Any, now: float, p: list[float],
                              frame: int | None) -> tuple[int, list[Any]]:
        mid = int(p[0])
        iv = link.intervals.get(mid, 0.0)
        return ap.RESULT_ACCEPTED, [M.MAVLink_message_interval_message(
            mid, int(iv * 1e6) if iv > 0 else -1)]

    def _request_message(self, link: Link, msg: Any, now: float, p: list[float],
                         frame: int | None) -> tuple[int, list[Any]]:
        mid = int(p[0])
        if mid not in KNOWN:
            return ap.RESULT_FAILED, []
        return ap.RESULT_ACCEPTED, [self.sim.build(mid, now)]  # None: nothing to say yet

    def _request_autopilot_capabilities(self, link: Link, msg: Any, now: float,
                                        p: list[float], frame: int | None
                                        ) -> tuple[int, list[Any]]:
        return ap.RESULT_ACCEPTED, [self.sim.build(M.MAVLINK_MSG_ID_AUTOPILOT_VERSION, now)]

    def _get_home_position(self, link: Link, msg: Any, now: float, p: list[float],
                           frame: int | None) -> tuple[int, list[Any]]:
        # GCS_MAVLINK::handle_command_get_home_position: FAILED until home is set
        if self.sim.autopilot.home is None:
            return ap.RESULT_FAILED, []
        return ap.RESULT_ACCEPTED, [self.sim.build(M.MAVLINK_MSG_ID_HOME_POSITION, now),
                                    self.sim.build(M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN, now)]

    def _return_to_launch(self, link: Link, msg: Any, now: float, p: list[float],
                          frame: int | None) -> tuple[int, list[Any]]:
        ok = self.sim.autopilot.set_mode(ap.RTL, now)
        return (ap.RESULT_ACCEPTED if ok else ap.RESULT_FAILED), []

    def _mission_start(self, link: Link, msg: Any, now: float, p: list[float],
                       frame: int | None) -> tuple[int, list[Any]]:
        ok = self.sim.autopilot.set_mode(ap.AUTO, now)
        return (ap.RESULT_ACCEPTED if ok else ap.RESULT_FAILED), []

    def _do_change_speed(self, link: Link, msg: Any, now: float, p: list[float],
                         frame: int | None) -> tuple[int, list[Any]]:
        a = self.sim.autopilot
        g = a.guided
        if a.mode == ap.GUIDED and g.sub in (GuidedSubMode.WP, GuidedSubMode.LOITER) \
                and p[1] > 0:
            g.speed = float(p[1])
            return ap.RESULT_ACCEPTED, []
        return ap.RESULT_FAILED, []

    def _do_reposition(self, link: Link, msg: Any, now: float, p: list[float],
                       frame: int | None) -> tuple[int, list[Any]]:
        if frame is None:  # COMMAND_INT only
            return ap.RESULT_UNSUPPORTED, []
        try:
            lat, lon = lat_lon_e7(int(p[4]), int(p[5]))
        except ValueError:
            return ap.RESULT_DENIED, []
        if lat == 0 and lon == 0:
            return ap.RESULT_DENIED, []
        x, y = self.sim.home.to_local(lat, lon)
        change = bool(int(p[1]) & M.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE)
        return self.sim.autopilot.guided_reposition(x, y, p[0], change, now), []


def _param_name(raw: str | bytes) -> str:
    name = raw if isinstance(raw, str) else raw.decode()
    return name.rstrip("\x00")


GcsMavlink.MESSAGE_HANDLERS.update({
    "COMMAND_LONG": GcsMavlink._command_long,
    "COMMAND_INT": GcsMavlink._command_int,
    "SET_MODE": GcsMavlink._set_mode,
    "SET_ATTITUDE_TARGET": GcsMavlink._set_attitude_target,
    "SET_POSITION_TARGET_LOCAL_NED": GcsMavlink._position_target_local,
    "SET_POSITION_TARGET_GLOBAL_INT": GcsMavlink._position_target_global,
    "RC_CHANNELS_OVERRIDE": GcsMavlink._rc_channels_override,
    "PARAM_REQUEST_LIST": GcsMavlink._param_request_list,
    "PARAM_REQUEST_READ": GcsMavlink._param_request_read,
    "PARAM_SET": GcsMavlink._param_set,
    "REQUEST_DATA_STREAM": GcsMavlink._request_data_stream,
    "MISSION_REQUEST_LIST": GcsMavlink._mission_request_list,
    "MANUAL_CONTROL": GcsMavlink._manual_control,
    "TIMESYNC": GcsMavlink._timesync,
    "FILE_TRANSFER_PROTOCOL": GcsMavlink._file_transfer_protocol,
})
GcsMavlink.COMMAND_HANDLERS.update({
    M.MAV_CMD_DO_SET_MODE: GcsMavlink._do_set_mode,
    M.MAV_CMD_COMPONENT_ARM_DISARM: GcsMavlink._arm_disarm,
    M.MAV_CMD_DO_SET_SERVO: GcsMavlink._do_set_servo,
    M.MAV_CMD_SET_MESSAGE_INTERVAL: GcsMavlink._set_message_interval,
    M.MAV_CMD_GET_MESSAGE_INTERVAL: GcsMavlink._get_message_interval,
    M.MAV_CMD_REQUEST_MESSAGE: GcsMavlink._request_message,
    M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: GcsMavlink._request_autopilot_capabilities,
    M.MAV_CMD_GET_HOME_POSITION: GcsMavlink._get_home_position,
    M.MAV_CMD_NAV_RETURN_TO_LAUNCH: GcsMavlink._return_to_launch,
    M.MAV_CMD_MISSION_START: GcsMavlink._mission_start,
    M.MAV_CMD_DO_CHANGE_SPEED: GcsMavlink._do_change_speed,
    M.MAV_CMD_DO_REPOSITION: GcsMavlink._do_reposition,
})
