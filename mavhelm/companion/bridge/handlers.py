"""MAVLink in: one handler per message type, in two dispatch tables.

``TO_COMPANION`` takes what a ground station or a guest addresses to the companion itself
(COMMAND_LONG, TUNNEL); ``FROM_AUTOPILOT`` turns the autopilot's telemetry into bus variables
(the table in ``mavhelm.companion.bridge``'s docstring). A handler raises ValueError (or
TypeError, AttributeError, OverflowError) for a message whose values are not finite or are
impossible; the bridge then refuses the message whole and counts it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import TYPE_CHECKING

from pymavlink.dialects.v20 import ardupilotmega as mavlink
from pymavlink.dialects.v20.ardupilotmega import MAVLink_message as Msg

from mavhelm.companion.actuation import GCS_SYSID_PARAMS, SUB_PRESSURE_PARAMS, SubGuided
from mavhelm.companion.bridge.config import BridgeConfig, make_actuation
from mavhelm.companion.bridge.lateness import sane
from mavhelm.companion.bridge.readings import (
    DOWNWARD,
    UNKNOWN_U16,
    distance_reading,
    fix_age,
)
from mavhelm.companion.mode_request import modes_for
from mavhelm.companion.signing import send_setup_signing, signature
from mavhelm.core.clock import boot_seconds
from mavhelm.core.geodesy import lat_lon_e7
from mavhelm.core.sender import LOCAL_BUS, SenderId, mavlink_source
from mavhelm.core.thirdparty import REQUEST_VARIABLE, TUNNEL_PAYLOAD_TYPE

if TYPE_CHECKING:
    from mavhelm.companion.bridge.facade import MavlinkBridge
    from mavhelm.companion.bridge.state import AutopilotState

Post = Callable[[str, float | str], None]
"""Posts a variable with the message's one time stamp."""
Handler = Callable[["MavlinkBridge", Msg, float, Post], None]
CompanionHandler = Callable[["MavlinkBridge", Msg], bool]

CMD_RESTART_HELM = mavlink.MAV_CMD_USER_1
"""COMMAND_LONG to the companion: re-read the mission file (spec RESTART_HELM)."""
CMD_REMOTE_FLAG = mavlink.MAV_CMD_USER_2
"""COMMAND_LONG to the companion: post the RemoteFlag numbered param1 (1 = the first)."""

FAR_FROM_ORIGIN_M = 5000.0
"""A GPS fix farther than this from the mission's origin is warned about."""


# -- addressed to the companion ------------------------------------------------------------

def on_command_long(bridge: MavlinkBridge, msg: Msg) -> bool:
    """A ground station's command to the companion (ArduPilot routes COMMAND_LONG for our
    system and component to our link): USER_1 restarts the helm, USER_2 posts a remote
    flag, DO_SET_MODE is asked of the autopilot (the web page's ALL STOP and hand back).
    Answered with COMMAND_ACK like any MAVLink command."""
    src = f"{msg.get_srcSystem()}:{msg.get_srcComponent()}"
    result = mavlink.MAV_RESULT_UNSUPPORTED
    if msg.command == CMD_RESTART_HELM:
        bridge.input.notify("RESTART_HELM", f"MAVLink from {src}")
        result = mavlink.MAV_RESULT_ACCEPTED
    elif msg.command == CMD_REMOTE_FLAG:
        result = _remote_flag(bridge, msg.param1, src)
    elif msg.command == mavlink.MAV_CMD_DO_SET_MODE:
        result = _operator_mode(bridge, msg.param2, src)
    bridge.link.mav.command_ack_send(msg.command, result, 0, 0, msg.get_srcSystem(),
                                     msg.get_srcComponent())
    return True


def _remote_flag(bridge: MavlinkBridge, param1: float, src: str) -> int:
    flags = bridge.config.remote_flags
    index = int(param1) if math.isfinite(param1) else 0
    if not 1 <= index <= len(flags):
        bridge.input.notify("MAVLINK_WARNING", f"remote flag {param1:g} refused: "
                            f"{len(flags)} RemoteFlag lines in iMAVLink")
        return mavlink.MAV_RESULT_DENIED
    flag = flags[index - 1]
    bridge.input.notify(flag, f"GCS {src}")
    bridge.input.notify("REMOTE_FLAG", flag)
    return mavlink.MAV_RESULT_ACCEPTED


def _operator_mode(bridge: MavlinkBridge, custom_mode: float, src: str) -> int:
    """Relay a mode change to the autopilot, confirmed by its HEARTBEAT (``ModeRequest``)."""
    number = int(custom_mode) if math.isfinite(custom_mode) else -1
    mode = modes_for(bridge.state.vehicle_type).get(number)
    if mode is None:
        bridge.input.notify("MAVLINK_WARNING", f"mode {custom_mode:g} from {src} refused: "
                            "not a mode of this autopilot")
        return mavlink.MAV_RESULT_DENIED
    bridge.send_path.request_mode(mode, src)
    return mavlink.MAV_RESULT_ACCEPTED


def on_tunnel(bridge: MavlinkBridge, msg: Msg) -> bool:
    """A guest's third-party request in a TUNNEL (its reply goes back the same way, to its
    system and component), posted with its sender as the source, so the helm can check the
    client it claims is bound to that sender."""
    length = max(0, min(int(msg.payload_length), len(msg.payload)))
    text = bytes(msg.payload[:length]).decode("utf-8", "replace")
    who = text.partition(":")[0].strip()
    system, component = msg.get_srcSystem(), msg.get_srcComponent()
    bridge.state.guests[who] = (system, component)
    bridge.bus.notify(REQUEST_VARIABLE, text, mavlink_source(system, component))
    return True


TO_COMPANION: dict[str, CompanionHandler] = {
    "COMMAND_LONG": on_command_long,
    "TUNNEL": on_tunnel,
}


def _for_companion(bridge: MavlinkBridge, msg: Msg, kind: str) -> bool:
    """Addressed to the companion, and a message it takes (a TUNNEL of another payload
    type is someone else's)."""
    config = bridge.config
    if kind not in TO_COMPANION or (msg.target_system, msg.target_component) != \
            (config.system_id, config.component_id):
        return False
    return kind != "TUNNEL" or msg.payload_type == TUNNEL_PAYLOAD_TYPE


def _command_name(msg: Msg, kind: str) -> str:
    if kind == "TUNNEL":
        return "third-party request"
    entry = mavlink.enums["MAV_CMD"].get(msg.command)
    name = entry.name.removeprefix("MAV_CMD_") if entry is not None else str(msg.command)
    return f"COMMAND_LONG {name}"


def admitted(bridge: MavlinkBridge, msg: Msg, kind: str, now: float) -> bool:
    """The sender check for a message to the companion: True if its sender may give it;
    otherwise it is refused (COMMAND_ACK DENIED for a command, nothing for a TUNNEL),
    counted, and said (rate-limited) naming the sender."""
    sender = SenderId(msg.get_srcSystem(), msg.get_srcComponent())
    why = bridge.authorize(sender, msg.get_signed(), _command_name(msg, kind), now,
                           guest=kind == "TUNNEL")
    if why is None:
        return True
    if kind == "COMMAND_LONG":
        bridge.link.mav.command_ack_send(msg.command, mavlink.MAV_RESULT_DENIED, 0, 0,
                                         sender.system, sender.component)
    return False


def local_command(bridge: MavlinkBridge, msg: Msg, now: float) -> bool:
    """A command from the companion's own side (the web page's control): the same sender check
    as a ground station's, as the local bus, then the same handler. True if it was taken."""
    kind = msg.get_type()
    if kind not in TO_COMPANION or bridge.authorize(LOCAL_BUS, True, _command_name(msg, kind),
                                                    now) is not None:
        return False
    TO_COMPANION[kind](bridge, msg)
    return True


# -- from the autopilot -------------------------------------------------------------------

def on_heartbeat(bridge: MavlinkBridge, msg: Msg, now: float, post: Post) -> None:
    if msg.type == mavlink.MAV_TYPE_GCS or msg.autopilot == mavlink.MAV_AUTOPILOT_INVALID:
        return
    state = bridge.state
    state.last_heartbeat = now
    if state.vehicle_type != msg.type:
        bridge.link.decode_only(read_messages(bridge.config, msg.type))
    state.vehicle_type = msg.type
    submarine = msg.type == mavlink.MAV_TYPE_SUBMARINE
    if bridge.config.actuation == "guided" and submarine != isinstance(bridge.actuation,
                                                                       SubGuided):
        bridge.actuation = make_actuation(bridge.config, msg.type)
    state.mode = modes_for(msg.type).get(msg.custom_mode, f"MODE{msg.custom_mode}")
    state.armed = bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
    handback = bridge.send_path.handback
    if handback is not None and handback.heartbeat(state.mode):
        post("HELM_HANDBACK_DONE", state.mode)
    post("AP_MODE", state.mode)
    post("AP_ARMED", 1.0 if state.armed else 0.0)


def on_gps_raw_int(bridge: MavlinkBridge, msg: Msg, now: float, post: Post) -> None:
    post("GPS_FIX", float(msg.fix_type))
    if msg.fix_type < mavlink.GPS_FIX_TYPE_3D_FIX:
        return
    state = bridge.state
    if msg.time_usec > 0 and msg.time_usec == state.gps_fix_usec:
        state.gps_repeats += 1
        return
    state.gps_fix_usec = msg.time_usec
    x, y = bridge.origin.to_local(*lat_lon_e7(msg.lat, msg.lon))
    _check_distance(bridge, x, y)
    post("GPS_X", x)
    post("GPS_Y", y)
    age = fix_age(_heard_on_autopilot_clock(state), msg.time_usec)
    if age is not None:
        post("GPS_AGE", age)
    if msg.vel != UNKNOWN_U16:
        post("GPS_SPEED", msg.vel / 100.0)
    if msg.cog != UNKNOWN_U16:
        post("GPS_HEADING", msg.cog / 100.0)


def _heard_on_autopilot_clock(state: AutopilotState) -> float | None:
    """The autopilot's clock when the message being handled was heard: as the least late
    recent message lines the clocks up, never before the newest clock read."""
    known = [t for t in (state.boot_s, None if state.heard_at is None
                         else state.lateness.autopilot_time(state.heard_at)) if t is not None]
    return max(known) if known else None


def _check_distance(bridge: MavlinkBridge, x: float, y: float) -> None:
    """Say once if the vehicle is far from the mission's origin: the wrong mission file,
    or an origin typed wrong, would otherwise steer for a point kilometres away."""
    distance = math.hypot(x, y)
    if distance > FAR_FROM_ORIGIN_M and not bridge.state.warned_far:
        bridge.state.warned_far = True
        bridge.input.notify("MAVLINK_WARNING", f"the vehicle is {distance / 1000:.1f} km from "
                            "the mission's origin (LatOrigin/LongOrigin): wrong mission, or a "
                            "wrong origin?")


def on_attitude(bridge: MavlinkBridge, msg: Msg, now: float, post: Post) -> None:
    """The attitude and turn rate, and ``INS_AGE``: how much later than its time_boot_ms it
    was heard (``lateness``), so a reader can place the sample when the autopilot took it."""
    if not all(math.isfinite(v) for v in (msg.roll, msg.pitch, msg.yaw, msg.yawspeed)):
        raise ValueError("non-finite attitude")
    late = sane(bridge.state.late)
    if late is not None:  # first: a reader takes it with the turn rate and heading after it
        post("INS_AGE", late)
    post("INS_YAW", 0.0 - msg.yaw)
    post("INS_HEADING", math.degrees(msg.yaw) % 360.0)
    post("INS_PITCH", msg.pitch)
    post("INS_ROLL", msg.roll)
    post("INS_YAW_VEL", 0.0 - msg.yawspeed)


def on_global_position_int(bridge: MavlinkBridge, msg: Msg, now: float,
                           post: Post) -> None:
    """The autopilot's EKF position, only while it says it has an absolute one; on ArduSub
    also its depth, whatever the horizontal position (the pressure sensor needs no GPS)."""
    if bridge.state.vehicle_type == mavlink.MAV_TYPE_SUBMARINE:
        post_depth(post, "AP", msg.relative_alt / 1000.0)
    if bridge.state.ekf_position_ok is False or (msg.lat == 0 and msg.lon == 0):
        return
    x, y = bridge.origin.to_local(*lat_lon_e7(msg.lat, msg.lon))
    post("AP_X", x)
    post("AP_Y", y)
    post("AP_SPEED", math.hypot(msg.vx, msg.vy) / 100.0)
    if msg.hdg != UNKNOWN_U16:
        post("AP_HEADING", msg.hdg / 100.0)
        post("AP_YAW", -math.radians(msg.hdg / 100.0))


MAX_DEPTH_M = 11_000.0
"""Deeper than the deepest ocean (or above the surface by as much) is not a reading."""


def post_depth(post: Post, source: str, height: float) -> None:
    """ArduSub's altitude is metres above the sea surface (negative under water): post
    ``<source>_DEPTH`` (m, down) and ``<source>_Z`` (m, up). The Z = 0 plane is the surface,
    an artificial tide of 0 (spec 2.3.1), so depth = tide − Z = −Z."""
    if not math.isfinite(height) or abs(height) > MAX_DEPTH_M:
        raise ValueError(f"impossible depth {-height!r} m")
    post(f"{source}_DEPTH", 0.0 - height)
    post(f"{source}_Z", height)


def on_vfr_hud(bridge: MavlinkBridge, msg: Msg, now: float, post: Post) -> None:
    """ArduSub's VFR_HUD altitude is its depth sensor's reading (Rover's is not a depth)."""
    if bridge.state.vehicle_type == mavlink.MAV_TYPE_SUBMARINE:
        post_depth(post, "VFR", float(msg.alt))


GRAVITY = 9.80665
WATER_DENSITY = 1000.0
"""kg/m³ of fresh water: times BARO_SPEC_GRAV, the water ArduSub is told it is in."""


def on_scaled_pressure(bridge: MavlinkBridge, msg: Msg, now: float, post: Post) -> None:
    """ArduSub's depth sensor (barometer 1) as ``BARO_DEPTH``: the pressure above its surface
    reading over ρ g, as ArduSub computes its own depth, once both parameters are known."""
    params = bridge.state.view.params
    if bridge.state.vehicle_type != mavlink.MAV_TYPE_SUBMARINE \
            or not all(name in params for name in SUB_PRESSURE_PARAMS):
        return
    surface_pa, gravity = (params[name] for name in SUB_PRESSURE_PARAMS)
    if not (math.isfinite(msg.press_abs) and surface_pa > 0 and gravity > 0):
        raise ValueError(f"impossible pressure {msg.press_abs!r} hPa")
    depth = (msg.press_abs * 100.0 - surface_pa) / (WATER_DENSITY * gravity * GRAVITY)
    post_depth(post, "BARO", -depth)


def on_distance_sensor(bridge: MavlinkBridge, msg: Msg, now: float, post: Post) -> None:
    reading = distance_reading(msg)
    if reading is not None:
        post("AP_ALTITUDE" if msg.orientation == DOWNWARD
             else f"AP_DISTANCE_{int(msg.orientation)}", reading)


def on_wheel_distance(bridge: MavlinkBridge, msg: Msg, now: float, post: Post) -> None:
    speed = bridge.wheels.speed(int(msg.time_usec), int(msg.count), list(msg.distance))
    if speed is not None:
        post("WHEEL_VX_BODY", speed)


def on_simstate(bridge: MavlinkBridge, msg: Msg, now: float, post: Post) -> None:
    """A simulator's true pose, for judging the navigator on SITL (never steered by)."""
    if msg.lat == 0 and msg.lng == 0:
        return
    lat, lon = lat_lon_e7(msg.lat, msg.lng)
    if not math.isfinite(msg.yaw):
        raise ValueError("non-finite yaw")
    x, y = bridge.origin.to_local(lat, lon)
    post("TRUTH_X", x)
    post("TRUTH_Y", y)
    post("TRUTH_HEADING", math.degrees(msg.yaw) % 360.0)


def on_ekf_status_report(bridge: MavlinkBridge, msg: Msg, now: float,
                         post: Post) -> None:
    bridge.state.ekf_position_ok = bool(msg.flags & mavlink.EKF_POS_HORIZ_ABS)


def on_param_value(bridge: MavlinkBridge, msg: Msg, now: float, post: Post) -> None:
    name = msg.param_id.rstrip("\x00") if isinstance(msg.param_id, str) else ""
    if name and math.isfinite(msg.param_value):
        bridge.state.view.params[name] = float(msg.param_value)
        if name in GCS_SYSID_PARAMS and 1 <= msg.param_value <= 255:
            bridge.gate.gcs_sysid = int(msg.param_value)


_RC_FIELDS = tuple(f"chan{i}_raw" for i in range(1, 19))


def on_rc_channels(bridge: MavlinkBridge, msg: Msg, now: float, post: Post) -> None:
    count = max(0, min(18, int(msg.chancount)))
    bridge.state.view.rc = [int(getattr(msg, name)) for name in _RC_FIELDS[:count]]


def on_command_ack(bridge: MavlinkBridge, msg: Msg, now: float, post: Post) -> None:
    if (msg.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
            and msg.result == mavlink.MAV_RESULT_ACCEPTED):
        bridge.state.streams_acked = True
    handback = bridge.send_path.handback
    if msg.command == mavlink.MAV_CMD_DO_SET_MODE and handback is not None:
        handback.acknowledged(msg.result)
    operator = bridge.send_path.operator_mode
    if msg.command == mavlink.MAV_CMD_DO_SET_MODE and operator is not None:
        operator.acknowledged(msg.result)
    if msg.command == mavlink.MAV_CMD_DO_SET_SERVO:
        report = bridge.servos.acknowledged(msg.result)
        if report is not None:
            post("MAVLINK_WARNING", report)
    post("AP_COMMAND_ACK", f"command={msg.command},result={msg.result}")


def on_statustext(bridge: MavlinkBridge, msg: Msg, now: float, post: Post) -> None:
    bridge.state.last_statustext = msg.text
    post("AP_STATUSTEXT", msg.text)


FROM_AUTOPILOT: dict[str, Handler] = {
    "HEARTBEAT": on_heartbeat,
    "GPS_RAW_INT": on_gps_raw_int,
    "ATTITUDE": on_attitude,
    "GLOBAL_POSITION_INT": on_global_position_int,
    "DISTANCE_SENSOR": on_distance_sensor,
    "VFR_HUD": on_vfr_hud,
    "SCALED_PRESSURE": on_scaled_pressure,
    "WHEEL_DISTANCE": on_wheel_distance,
    "SIMSTATE": on_simstate,
    "EKF_STATUS_REPORT": on_ekf_status_report,
    "PARAM_VALUE": on_param_value,
    "RC_CHANNELS": on_rc_channels,
    "COMMAND_ACK": on_command_ack,
    "STATUSTEXT": on_statustext,
}


# -- routing ------------------------------------------------------------------------------

def _autopilot_heartbeat(bridge: MavlinkBridge, msg: Msg) -> None:
    """Note whether the autopilot signs; with ``SetupSigning``, give an autopilot that sends
    no signature at all the key (once a connection), as MAVProxy's ``signing setup`` does. One
    signed with another key is left alone: the key is the operator's to change."""
    state = bridge.state
    how = signature(msg)
    state.signed = how == "valid"
    if bridge.gate.require_signing and not state.signed:
        _warn_unsigned(bridge, how)
    if how != "none" or not bridge.signing or not bridge.config.setup_signing \
            or state.signing_sent:
        return
    config = bridge.config
    mav = bridge.link.mav
    assert mav.signing.secret_key is not None
    state.signing_sent = True
    send_setup_signing(mav, (config.target_system, config.target_component),
                       mav.signing.secret_key)
    bridge.input.notify("MAVLINK_LINK", "the autopilot is unsigned: signing key sent to it "
                        "(SETUP_SIGNING)")


UNSIGNED_HEARTBEATS_WARNED = 3
"""Unsigned autopilot HEARTBEATs (on one connection) before the operator is told why the
helm hears nothing: time for SETUP_SIGNING to take effect first."""


def _warn_unsigned(bridge: MavlinkBridge, how: str) -> None:
    """RequireSigning and an autopilot that does not sign with the key: everything it says
    is ignored, so the helm stays offline; say so once a connection, with the remedy."""
    state = bridge.state
    state.unsigned_heartbeats += 1
    if state.unsigned_heartbeats != UNSIGNED_HEARTBEATS_WARNED:
        return
    what = "not signed" if how == "none" else "not validly signed (another key?)"
    bridge.input.notify("MAVLINK_WARNING", f"the autopilot's packets are {what}: all are "
                        "ignored, as RequireSigning is on; set the autopilot up (SetupSigning "
                        "= true, or MAVProxy `signing setup`) with the key file's passphrase")


SUBMARINE_ONLY = frozenset({"VFR_HUD", "SCALED_PRESSURE"})
"""Messages whose handlers read something only on ArduSub (its depth)."""


def read_messages(config: BridgeConfig, vehicle_type: int | None = None) -> frozenset[str]:
    """Every message the bridge reads (its handlers', and the streams it asks for, which it
    checks are heard): the link decodes only these. Once the autopilot's type is known, a
    surface vehicle's link leaves ArduSub's depth messages undecoded."""
    read = frozenset(FROM_AUTOPILOT) | frozenset(TO_COMPANION)
    if vehicle_type is not None and vehicle_type != mavlink.MAV_TYPE_SUBMARINE:
        read -= SUBMARINE_ONLY
    return read | frozenset(config.streams)


def _autopilot_time(bridge: MavlinkBridge, msg: Msg) -> float:
    """Feed the autopilot's clock from the message's time_boot_ms (if it has one) and note
    how late the message is heard on it; returns the message's one stamp. One for every
    variable of a message: an autopilot clock moves between two posts, and GPS_X and GPS_Y
    stamped microseconds apart are not one fix to pNav (it dropped 22-83 % of the fixes on
    the real SITL at x5)."""
    state = bridge.state
    time_boot_ms = getattr(msg, "time_boot_ms", None)
    if time_boot_ms is not None:
        state.boot_s = boot_seconds(time_boot_ms)
        if bridge.time_source is not None:
            bridge.time_source(state.boot_s)
    stamp = state.heard_at = bridge.bus.clock.now()
    state.late = None if state.boot_s is None or time_boot_ms is None \
        else state.lateness.heard(stamp, state.boot_s)
    return stamp


def handle(bridge: MavlinkBridge, msg: Msg, now: float) -> None:
    """Route one message heard at ``now`` to its handler."""
    kind = msg.get_type()
    config = bridge.config
    src = (msg.get_srcSystem(), msg.get_srcComponent())
    if _for_companion(bridge, msg, kind):
        if admitted(bridge, msg, kind, now):
            TO_COMPANION[kind](bridge, msg)
        return
    from_autopilot = src == (config.target_system, config.target_component)
    if from_autopilot and kind == "HEARTBEAT":
        _autopilot_heartbeat(bridge, msg)
    if bridge.gate.require_signing and not msg.get_signed():
        bridge.unsigned_ignored += 1
        return
    if kind == "HEARTBEAT" and msg.type == mavlink.MAV_TYPE_GCS \
            and src != (config.system_id, config.component_id):
        bridge.state.gcs_heard_at = now
        return
    if not from_autopilot:
        return
    bridge.state.heard.add(kind)
    stamp = _autopilot_time(bridge, msg)
    handler = FROM_AUTOPILOT.get(kind)
    if handler is None:
        return

    notify, source = bridge.bus.notify, bridge.input.name

    def post(name: str, value: float | str) -> None:
        notify(name, value, source, stamp)
    handler(bridge, msg, now, post)
