"""``mavhelm check``: a pre-flight checklist, before the boat leaves the pontoon.

It connects as the companion would, asks for the streams and parameters the companion needs,
listens for a few seconds, and prints one line per item — ``ok``, ``WARN`` or ``FAIL`` — each
failure with what to do about it. The decisions (``checklist``) are a pure function of what
was observed, so they are tested without a vehicle; ``observe`` is the thin I/O part.
"""

from __future__ import annotations

import contextlib
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.actuation import GCS_SYSID_PARAMS, engage_clash
from mavhelm.companion.bridge import FAR_FROM_ORIGIN_M, BridgeConfig
from mavhelm.companion.link import AutopilotLink
from mavhelm.companion.mode_request import modes_for
from mavhelm.companion.signing import signature
from mavhelm.core.geodesy import Origin, lat_lon_e7

VEHICLE_TYPES = {mavlink.MAV_TYPE_SURFACE_BOAT: "boat", mavlink.MAV_TYPE_GROUND_ROVER: "rover",
                 mavlink.MAV_TYPE_SUBMARINE: "sub"}


@dataclass
class Observed:
    """What a few seconds on the link showed."""

    connected: bool = False
    link_error: str = ""
    heartbeat: mavlink.MAVLink_heartbeat_message | None = None
    heard: set[str] = field(default_factory=set)
    gps_fix: int | None = None
    position: tuple[float, float] | None = None
    """(lat, lon) of the latest 3D fix."""
    ekf_flags: int | None = None
    params: dict[str, float] = field(default_factory=dict)
    statustexts: list[str] = field(default_factory=list)
    signature: str | None = None
    """The autopilot's latest HEARTBEAT: "valid" (signed with our key), "other" (signed, not
    with our key, or we have none) or "none" (unsigned); None if none was heard."""


@dataclass(frozen=True)
class Line:
    status: str  # "ok", "WARN" or "FAIL"
    text: str

    def __str__(self) -> str:
        return f"{self.status:>4}  {self.text}"


def wanted_params(config: BridgeConfig) -> list[str]:
    names = ["WP_SPEED", "FS_GCS_ENABLE", *GCS_SYSID_PARAMS, "RCMAP_ROLL", "RCMAP_THROTTLE"]
    names += [f"SERVO{s.channel}_FUNCTION" for s in config.servos]
    return names


def checklist(seen: Observed, config: BridgeConfig, origin: Origin | None,
              mission_error: str = "") -> list[Line]:
    """Every item of the pre-flight check, in the order an engineer would fix them."""
    lines: list[Line] = []
    if mission_error:
        lines.append(Line("FAIL", f"mission: {mission_error}"))
    if not seen.connected:
        return [*lines, Line("FAIL", f"no connection to {config.connect}: {seen.link_error} "
                                     "(is the autopilot powered, the address and baud right?)")]
    lines.append(Line("ok", f"connected to {config.connect} (MAVLink 2)"))
    hb = seen.heartbeat
    if hb is None:
        return [*lines, Line("FAIL", f"no HEARTBEAT from system {config.target_system} "
                                     f"component {config.target_component}: check "
                                     "TargetSystem/TargetComponent and the port's protocol "
                                     "(SERIALn_PROTOCOL = 2)")]
    mode = modes_for(hb.type).get(hb.custom_mode, f"mode {hb.custom_mode}")
    armed = bool(hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
    kind = VEHICLE_TYPES.get(hb.type, f"MAV_TYPE {hb.type}")
    lines.append(Line("ok" if hb.type in VEHICLE_TYPES else "WARN",
                      f"autopilot: ArduPilot {kind}, {mode}, {'armed' if armed else 'disarmed'}"))
    missing = [n for n, rate in config.streams.items() if rate > 0 and n not in seen.heard]
    lines.append(Line("FAIL", f"streams not arriving: {', '.join(missing)} (the autopilot "
                              "ignored the rate requests: check its SRn_* parameters)")
                 if missing else Line("ok", "streams arriving: " + ", ".join(config.streams)))
    if seen.gps_fix is None or seen.gps_fix < mavlink.GPS_FIX_TYPE_3D_FIX:
        lines.append(Line("FAIL", "no 3D GPS fix yet (fix type "
                                  f"{seen.gps_fix if seen.gps_fix is not None else 'unknown'}):"
                                  " wait for the sky, or check the GPS"))
    else:
        lines.append(Line("ok", f"GPS fix type {seen.gps_fix}"))
    if seen.ekf_flags is None or not seen.ekf_flags & mavlink.EKF_POS_HORIZ_ABS:
        lines.append(Line("FAIL", "the autopilot's EKF has no position yet: GUIDED will be "
                                  "refused (ArduPilot needs ~45 s after boot)"))
    else:
        lines.append(Line("ok", "EKF has an absolute position"))
    if origin is not None and seen.position is not None:
        x, y = origin.to_local(*seen.position)
        distance = math.hypot(x, y)
        if distance > FAR_FROM_ORIGIN_M:
            lines.append(Line("FAIL", f"the vehicle is {distance / 1000:.1f} km from the "
                                      "mission's origin: wrong mission, or wrong "
                                      "LatOrigin/LongOrigin?"))
        else:
            lines.append(Line("ok", f"the vehicle is {distance:.0f} m from the mission's origin"))
    lines += _param_lines(seen.params, config)
    lines.append(signing_line(seen.signature, config))
    modes = ", ".join(config.online_modes)
    lines.append(Line("ok", f"to hand over: arm, then select {modes}"
                            + (f" and raise RC{config.engage_channel} above "
                               f"{config.engage_pwm}" if config.actuation == "rc_override"
                               else "")))
    return lines


def signing_line(signature: str | None, config: BridgeConfig) -> Line:
    """Whether the link is signed, and whether the autopilot agrees (docs/security.md)."""
    keyed = config.signing_key_file is not None
    setup = ("set SetupSigning = true in iMAVLink, or in MAVProxy `signing setup PASSPHRASE` "
             "with the key file's passphrase")
    if signature == "valid":
        return Line("ok", "link signed: the autopilot signs with the companion's key"
                          + ("" if config.require_signing else
                             " (RequireSigning = true would refuse all unsigned input)"))
    if signature == "other":
        return Line("FAIL", "the autopilot signs with a key the companion does not have: it "
                            "will refuse the companion's packets; "
                            + ("give SigningKeyFile the autopilot's passphrase" if keyed else
                               "set SigningKeyFile in iMAVLink to its passphrase's file"))
    if keyed:
        return Line("FAIL" if config.require_signing else "WARN",
                    "the companion signs, but the autopilot does not: " + setup)
    return Line("WARN", "link not signed: anyone with a radio on its network can command the "
                        "vehicle (docs/security.md)")


def _param_lines(params: dict[str, float], config: BridgeConfig) -> list[Line]:
    lines = []
    if "WP_SPEED" in params:
        lines.append(Line("ok", f"WP_SPEED {params['WP_SPEED']:g} m/s: thrust 100 % asks for "
                                "that speed in GUIDED"))
    else:
        lines.append(Line("WARN", "WP_SPEED not read: the speed thrust asks for is unknown"))
    gcs = next((int(params[n]) for n in GCS_SYSID_PARAMS if n in params), None)
    if config.actuation == "rc_override":
        lines += _rc_lines(params, config, gcs)
    for servo in config.servos:
        name = f"SERVO{servo.channel}_FUNCTION"
        function = params.get(name)
        if function is None:
            lines.append(Line("WARN", f"{name} not read: cannot tell if {servo.name} is free"))
        elif int(function) != 0:
            lines.append(Line("FAIL", f"servo output {servo.channel} ({servo.name}) already "
                                      f"has function {int(function)}: DO_SET_SERVO will be "
                                      "refused; choose a free output"))
        else:
            lines.append(Line("ok", f"servo output {servo.channel} is free for {servo.name}"))
    return lines


def observe(link: AutopilotLink, config: BridgeConfig, seconds: float,
            clock: Callable[[], float] = time.monotonic) -> Observed:
    """Listen on the link for ``seconds``, asking for streams and parameters as it goes."""
    seen = Observed()
    start = clock()
    asked_at = -math.inf
    while (now := clock()) - start < seconds:
        for msg in link.poll(now):
            _record(seen, msg, config)
        if link.connected:
            seen.connected = True
            if now - asked_at >= 2.0:
                asked_at = now
                _ask(link, config)
        time.sleep(0.02)
    events = link.take_events()
    if not seen.connected and events:
        seen.link_error = events[-1]
    return seen


def _ask(link: AutopilotLink, config: BridgeConfig) -> None:
    mav = link.mav
    mav.heartbeat_send(mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                       mavlink.MAV_STATE_ACTIVE)
    for name, rate in config.streams.items():
        mav.command_long_send(config.target_system, config.target_component,
                              mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                              getattr(mavlink, f"MAVLINK_MSG_ID_{name}"),
                              -1 if rate <= 0 else int(1e6 / rate), 0, 0, 0, 0, 0)
    for name in wanted_params(config):
        mav.param_request_read_send(config.target_system, config.target_component,
                                    name.encode(), -1)


def _record(seen: Observed, msg: mavlink.MAVLink_message, config: BridgeConfig) -> None:
    if (msg.get_srcSystem(), msg.get_srcComponent()) != (config.target_system,
                                                          config.target_component):
        return
    kind = msg.get_type()
    seen.heard.add(kind)
    if kind == "HEARTBEAT" and msg.autopilot != mavlink.MAV_AUTOPILOT_INVALID:
        seen.heartbeat = msg
        seen.signature = signature(msg)
    elif kind == "GPS_RAW_INT":
        seen.gps_fix = msg.fix_type
        if msg.fix_type >= mavlink.GPS_FIX_TYPE_3D_FIX:
            with contextlib.suppress(ValueError):  # not on the earth: not a position
                seen.position = lat_lon_e7(msg.lat, msg.lon)
    elif kind == "EKF_STATUS_REPORT":
        seen.ekf_flags = msg.flags
    elif kind == "PARAM_VALUE":
        seen.params[msg.param_id] = float(msg.param_value)
    elif kind == "STATUSTEXT":
        seen.statustexts.append(msg.text)



def _rc_lines(params: dict[str, float], config: BridgeConfig, gcs: int | None) -> list[Line]:
    """rc_override: ArduPilot must obey the companion's override, and the override must not
    land on the engage switch."""
    lines: list[Line] = []
    if gcs is None:
        lines.append(Line("FAIL", "MAV_GCS_SYSID not read: rc_override cannot engage"))
    elif gcs != config.system_id:
        lines.append(Line("FAIL", f"MAV_GCS_SYSID is {gcs} but SystemID is "
                                  f"{config.system_id}: ArduPilot would ignore the RC "
                                  f"override; set SystemID = {gcs} in iMAVLink"))
    else:
        lines.append(Line("ok", f"MAV_GCS_SYSID {gcs} matches the companion's SystemID"))
    assert config.engage_channel is not None
    clash = engage_clash(params, config.engage_channel)
    if clash is not None:
        lines.append(Line("FAIL", clash))
    return lines
