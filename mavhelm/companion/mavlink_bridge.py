"""The MAVLink bridge: the autopilot seen as variables on the bus, and helm output sent back.

It is one connection with two faces in the community's tick order: ``AutopilotInput`` runs
first (MAVLink in → ``GPS_*``, ``INS_*``, ``AP_*``, ``HELM_ONLINE``) and ``AutopilotOutput``
runs after the helm (``DESIRED_*`` → SET_ATTITUDE_TARGET), so a mode change that arrives in a
tick stops actuation in that same tick.

The helm is online only while the link is up (a HEARTBEAT from the autopilot within
``LinkTimeOut``), the autopilot is armed and its mode is one of ``OnlineModes``: the operator's
ground-station mode switch is the spec's iRemote. In GUIDED, ArduPilot ignores RC override, so
the ``guided`` actuation profile sends body yaw rate + thrust (type_mask 0x03), which Rover turns
into turn rate and speed = thrust × WP_SPEED.

What the autopilot's telemetry becomes (local frame of the mission's origin: X east, Y north):

====================  ================================================================
HEARTBEAT             ``AP_MODE`` (Rover mode name), ``AP_ARMED`` 1/0
GPS_RAW_INT           ``GPS_FIX``; with a 3-D fix ``GPS_X``, ``GPS_Y`` (m), ``GPS_SPEED``
                      (m/s), ``GPS_HEADING`` (deg, course over ground)
ATTITUDE              ``INS_YAW`` (rad, yaw = −heading), ``INS_HEADING`` (deg),
                      ``INS_PITCH``, ``INS_ROLL`` (rad), ``INS_YAW_VEL`` (rad/s)
GLOBAL_POSITION_INT   ``AP_X``, ``AP_Y`` (m), ``AP_SPEED`` (m/s), ``AP_HEADING`` (deg),
                      ``AP_YAW`` (rad): the autopilot's EKF, while it has a position
DISTANCE_SENSOR       pointing down (orientation 25, PITCH_270): ``AP_ALTITUDE`` (m above
                      the bottom, or the ground); any other way: ``AP_DISTANCE_<n>`` (m),
                      ``n`` the MAV_SENSOR_ORIENTATION number, as in ``RNGFNDx_ORIENT``
                      (``AP_DISTANCE_0`` forward, ``AP_DISTANCE_24`` up)
WHEEL_DISTANCE        ``WHEEL_VX_BODY`` (m/s, forward): the wheels' mean distance change
                      over the time since the previous message
SIMSTATE              ``TRUTH_X``, ``TRUTH_Y`` (m), ``TRUTH_HEADING`` (deg): a simulator's
                      ground truth, logged for accuracy reports on SITL
STATUSTEXT            ``AP_STATUSTEXT``; COMMAND_ACK: ``AP_COMMAND_ACK``
====================  ================================================================

DISTANCE_SENSOR, WHEEL_DISTANCE and SIMSTATE are not in the default streams (a boat without a
sounder would be warned about them every time): ArduPilot lists DISTANCE_SENSOR in its EXTRA3
stream, SIMSTATE in EXTRA1 and WHEEL_DISTANCE in EXTRA1 or EXTRA3 (by version), sent at its
SRn_EXTRA* rates; or ask with ``Stream = DISTANCE_SENSOR@5``. ArduPilot's SITL has a
rangefinder with ``RNGFND1_TYPE 100`` (``RNGFND1_ORIENT 25`` down; the rover model reads 1.0 m
down and forward, the motorboat has no data) and wheel encoders with ``WENC_TYPE 10``,
``WENC2_TYPE 10`` and ``WENC_POS_Y``/``WENC2_POS_Y`` set; but Rover 4.8-dev sends no
WHEEL_DISTANCE, in any stream, and refuses SET_MESSAGE_INTERVAL for it ("No ap_message for
mavlink id (9000)"), so wheel odometry from ArduPilot is untested against the binary.
A message whose values are not finite or are impossible is refused whole (``MAVLINK_ERROR``,
counted in ``MAVLINK_BAD_PACKETS``), like any other bad input.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.actuation import (
    GCS_SYSID_PARAMS,
    Actuation,
    AutopilotView,
    Guided,
    RcOverride,
)
from mavhelm.companion.link import AutopilotLink, transport_for
from mavhelm.companion.servos import Servo, ServoOutputs, ServoSpec
from mavhelm.core.app import App
from mavhelm.core.bus import Bus, Message
from mavhelm.core.geodesy import Origin
from mavhelm.core.mission import Block, Entry
from mavhelm.core.params import Choice, ChoiceList, Kind, Number, Param, Schema, Text, Word
from mavhelm.core.thirdparty import (
    MAX_LENGTH,
    REPLY_VARIABLE,
    REQUEST_VARIABLE,
    TUNNEL_PAYLOAD_TYPE,
)

ROVER_MODES: dict[int, str] = dict(mavutil.mode_mapping_rover)
ROVER_MODE_NUMBERS: dict[str, int] = {name: number for number, name in ROVER_MODES.items()}

COMPANION_COMPONENT = mavlink.MAV_COMP_ID_ONBOARD_COMPUTER
_UNKNOWN_U16 = 65535

DEFAULT_STREAMS: dict[str, float] = {
    "GPS_RAW_INT": 5.0,
    "ATTITUDE": 10.0,
    "GLOBAL_POSITION_INT": 5.0,
    "EKF_STATUS_REPORT": 1.0,
    "SYS_STATUS": 1.0,
}


NAMED_VALUES: dict[str, str] = {
    "NAV_X": "NAV_X", "NAV_Y": "NAV_Y", "NAV_HEADING": "NAV_HDG", "NAV_SPEED": "NAV_SPEED",
    "DESIRED_RUDDER": "DES_RUDDER", "DESIRED_THRUST": "DES_THRUST",
}
"""Bus variable → NAMED_VALUE_FLOAT name (MAVLink allows 10 characters)."""

STATUSTEXT_MAX = 200
"""Longest line sent to the ground station (four chunks)."""

FLOAT32_MAX = 3.4e38
"""A MAVLink float field holds no more (and nothing non-finite is ever sent)."""

CMD_RESTART_HELM = mavlink.MAV_CMD_USER_1
"""COMMAND_LONG to the companion: re-read the mission file (spec RESTART_HELM)."""
CMD_REMOTE_FLAG = mavlink.MAV_CMD_USER_2
"""COMMAND_LONG to the companion: post the RemoteFlag numbered param1 (1 = the first)."""

FAR_FROM_ORIGIN_M = 5000.0
"""A GPS fix farther than this from the mission's origin is warned about."""

DOWNWARD = mavlink.MAV_SENSOR_ROTATION_PITCH_270
"""DISTANCE_SENSOR orientation of a sounder or a ground rangefinder: it gives AP_ALTITUDE."""

WHEEL_MAX_SPEED = 50.0
"""m/s: a wheel-distance speed beyond this is a counter that jumped, not a vehicle moving."""
WHEEL_MAX_DISTANCE = 1e9
"""m: a cumulative wheel distance beyond this is garbage."""
WHEEL_MAX_INTERVAL_S = 5.0
"""A mean over a longer gap is not the vehicle's speed now: the clock starts again instead."""

STREAM_GRACE_S = 5.0
"""How long after the link comes up every requested stream must have been heard once."""

MAX_STREAM_HZ = 50.0
MIN_STREAM_HZ = 0.1


class StreamRate(Kind):
    """``MESSAGE_NAME@rate``: a MAVLink message of the ardupilotmega dialect and its rate in
    Hz, 0 to switch it off or within [0.1, 50]."""

    def describe(self) -> str:
        return (f"MESSAGE_NAME@Hz, rate 0 (off) or in [{MIN_STREAM_HZ:g}, {MAX_STREAM_HZ:g}]")

    def parse(self, entry: Entry) -> tuple[str, float]:
        name, sep, rate_text = entry.value.partition("@")
        name = name.strip().upper()
        if not sep or not hasattr(mavlink, f"MAVLINK_MSG_ID_{name}"):
            raise entry.error(f"Stream expects MESSAGE_NAME@rate_hz, got {entry.value!r}")
        rate = Number(0.0, MAX_STREAM_HZ).parse_text(rate_text, entry, f"Stream {name} rate")
        if 0.0 < rate < MIN_STREAM_HZ:
            raise entry.error(f"Stream {name} rate must be 0 (off) or at least "
                              f"{MIN_STREAM_HZ:g} Hz, got {rate_text.strip()}")
        return name, rate


class LinkAddress(Text):
    """Where the autopilot is: ``tcp:HOST:PORT``, ``udp:HOST:PORT`` (listen),
    ``udpout:HOST:PORT`` or a serial device (``/dev/ttyAMA0`` or ``/dev/ttyAMA0,921600``)."""

    def describe(self) -> str:
        return "tcp:HOST:PORT, udp:HOST:PORT, udpout:HOST:PORT or a serial device"

    def parse(self, entry: Entry) -> str:
        text = super().parse(entry)
        try:
            transport_for(text, 57600)
        except ValueError as exc:
            raise entry.error(f"{entry.key}: {exc}") from None
        return text


MAVLINK_ID = Number(1, 255, integer=True)

IMAVLINK_SCHEMA = Schema("iMAVLink", (
    Param("Connect", LinkAddress(), "tcp:127.0.0.1:5760",
          doc="the autopilot link: tcp:HOST:PORT, udp:HOST:PORT or a serial device; "
              "`mavhelm run --connect` overrides it"),
    Param("Baud", Number(300, 12_000_000, integer=True), 57600, "bit/s",
          "serial speed (serial devices only)"),
    Param("SystemID", MAVLINK_ID, 1, doc="the companion's own MAVLink system id",
          attr="system_id"),
    Param("ComponentID", MAVLINK_ID, COMPANION_COMPONENT,
          doc="the companion's component id (191: onboard computer)", attr="component_id"),
    Param("TargetSystem", MAVLINK_ID, 1, doc="the autopilot's system id", attr="target_system"),
    Param("TargetComponent", MAVLINK_ID, 1, doc="the autopilot's component id",
          attr="target_component"),
    Param("OnlineModes", ChoiceList(Choice(tuple(ROVER_MODE_NUMBERS))), ("GUIDED",),
          doc="the helm drives only while the autopilot is armed in one of these",
          attr="online_modes"),
    Param("Actuation", Choice(("guided", "rc_override")), "guided",
          doc="guided: SET_ATTITUDE_TARGET in GUIDED; rc_override: RC_CHANNELS_OVERRIDE in "
              "MANUAL, engaged by an RC switch (see docs/actuation.md)"),
    Param("EngageChannel", Number(1, 16, integer=True), None,
          doc="rc_override: the RC channel whose switch hands the vehicle to the helm "
              "(required with rc_override)", attr="engage_channel"),
    Param("EngagePWM", Number(900, 2200, integer=True), 1800, "µs",
          "rc_override: the helm may drive while the engage channel is at or above this",
          attr="engage_pwm"),
    Param("RemoteFlag", Word(), [], repeat=True, attr="remote_flags",
          doc="a flag a ground station may post: COMMAND_LONG MAV_CMD_USER_2 to the companion "
              "with param1 = its number (1 = the first RemoteFlag line)"),
    Param("GcsTimeOut", Number(1.0, 60.0), 5.0, "s",
          "rc_override: offline (and released) when no ground station HEARTBEAT is heard "
          "for this long", attr="gcs_timeout"),
    Param("Servo", ServoSpec(), [], repeat=True, attr="servos",
          doc="a named auxiliary actuator on a servo output: DESIRED_<NAME> in percent "
              "(-100..100) becomes DO_SET_SERVO with PWM min..max"),
    Param("MaxTurnRate", Number(0.0, 360.0, lo_open=True), 45.0, "deg/s",
          "turn rate commanded at full rudder (MAXRUDDER)", attr="max_turn_rate"),
    Param("LinkTimeOut", Number(1.0, 60.0), 3.0, "s",
          "no autopilot HEARTBEAT for this long takes the helm offline", attr="link_timeout"),
    Param("Stream", StreamRate(), [], repeat=True, attr="stream_rates",
          doc="a telemetry rate to ask for, on top of the defaults "
              "(" + ", ".join(f"{k}@{v:g}" for k, v in DEFAULT_STREAMS.items()) + ")"),
))


@dataclass
class BridgeConfig:
    """The ``iMAVLink`` ProcessConfig block (see ``IMAVLINK_SCHEMA``) and the helm's MAXRUDDER."""

    connect: str = "tcp:127.0.0.1:5760"
    baud: int = 57600
    system_id: int = 1
    component_id: int = COMPANION_COMPONENT
    target_system: int = 1
    target_component: int = 1
    online_modes: tuple[str, ...] = ("GUIDED",)
    actuation: str = "guided"
    engage_channel: int | None = None
    engage_pwm: int = 1800
    gcs_timeout: float = 5.0
    servos: list[Servo] = field(default_factory=list)
    remote_flags: list[str] = field(default_factory=list)
    max_turn_rate: float = 45.0
    max_rudder: float = 20.0
    link_timeout: float = 3.0
    streams: dict[str, float] = field(default_factory=lambda: dict(DEFAULT_STREAMS))

    @classmethod
    def from_block(cls, block: Block | None, max_rudder: float = 20.0) -> BridgeConfig:
        block = block or Block("ProcessConfig", "iMAVLink", "", 0)
        settings = IMAVLINK_SCHEMA.read(block)
        rates = settings.pop("stream_rates")
        cfg = cls(max_rudder=max_rudder, **settings)
        cfg.streams.update(rates)
        if cfg.actuation == "rc_override":
            if cfg.engage_channel is None:
                raise block.error("Actuation = rc_override needs EngageChannel: the RC switch "
                                  "that hands the vehicle to the helm in MANUAL")
            if block.entry("OnlineModes") is None:
                cfg.online_modes = ("MANUAL",)
            cfg.streams.setdefault("RC_CHANNELS", 5.0)
        seen: dict[str, Servo] = {}
        for entry, servo in zip(block.all("Servo"), cfg.servos, strict=True):
            for other in seen.values():
                if other.name == servo.name or other.channel == servo.channel:
                    raise entry.error(f"Servo {servo.name}@{servo.channel} clashes with "
                                      f"{other.name}@{other.channel}: one name per output")
            seen[servo.name] = servo
        return cfg


def distance_reading(msg: mavlink.MAVLink_distance_sensor_message) -> float | None:
    """A DISTANCE_SENSOR's range in metres, or None when it has no reading to give.

    A reading outside the sensor's own [min_distance, max_distance] is the sensor saying it
    sees nothing within its range (too close, or nothing there), and 65535 or a max_distance of
    0 means "no reading": none of these is a distance, and a rangefinder out of range is normal
    (a sounder over deep water), not an error, so they are left out without a word.
    """
    current = int(msg.current_distance)
    if current == _UNKNOWN_U16 or msg.max_distance == 0:
        return None
    if not msg.min_distance <= current <= msg.max_distance:
        return None
    return current / 100.0


@dataclass
class WheelOdometry:
    """WHEEL_DISTANCE's cumulative wheel distances turned into a forward speed.

    The speed is the mean over the wheels of their distance change, divided by the time between
    two messages: wheels on either side of a turning vehicle cancel out in the mean. The first
    message only starts the clock; so does a time going backwards (the autopilot rebooted, or
    on a 32-bit board ArduPilot's ``1000UL * millis()`` wrapped, every 71.6 minutes), a
    repeated time, a change in the number of wheels or a gap over WHEEL_MAX_INTERVAL_S.
    """

    last: tuple[int, tuple[float, ...]] | None = None

    def speed(self, time_usec: int, count: int, distance: list[float]) -> float | None:
        """Forward speed (m/s) since the previous message; raises ValueError on a message no
        wheel could produce."""
        if not 0 <= count <= len(distance):
            raise ValueError(f"WHEEL_DISTANCE count {count} (at most {len(distance)} wheels)")
        wheels = tuple(float(d) for d in distance[:count])
        if not all(math.isfinite(d) and abs(d) <= WHEEL_MAX_DISTANCE for d in wheels):
            raise ValueError(f"wheel distances {wheels} are not finite metres")
        previous, self.last = self.last, (time_usec, wheels)
        if previous is None or not wheels or len(previous[1]) != len(wheels):
            return None
        dt = (time_usec - previous[0]) / 1e6
        if not 0.0 < dt <= WHEEL_MAX_INTERVAL_S:
            return None
        moved = sum(d - p for d, p in zip(wheels, previous[1], strict=True)) / len(wheels)
        speed = moved / dt
        if abs(speed) > WHEEL_MAX_SPEED:
            raise ValueError(f"wheel speed {speed:.1f} m/s in {dt:g} s: a counter jumped")
        return speed


@dataclass
class HandBack:
    """Giving the vehicle back to the autopilot at the end of the mission: DO_SET_MODE,
    confirmed by the HEARTBEAT, tried three times a second apart."""

    mode: str
    tries: int = 0
    next_try: float = -math.inf
    refused: int | None = None
    done: bool = False
    TRIES = 3

    def due(self, now: float) -> bool:
        if self.tries >= self.TRIES or now < self.next_try:
            return False
        self.tries += 1
        self.next_try = now + 1.0
        return True

    def confirm(self, mode: str | None) -> bool:
        """True the first time the HEARTBEAT shows the asked-for mode."""
        if self.done or mode != self.mode:
            return False
        self.done = True
        return True

    def acknowledged(self, result: int) -> None:
        if result != mavlink.MAV_RESULT_ACCEPTED:
            self.refused = result

    def failed(self, now: float) -> bool:
        return self.tries >= self.TRIES and now >= self.next_try

    def why(self) -> str:
        if self.refused is not None:
            return f"DO_SET_MODE refused, result {self.refused}"
        return f"no HEARTBEAT in {self.mode} after {self.TRIES} requests"


class MavlinkBridge:
    """One MAVLink connection to the autopilot; ``input`` and ``output`` are its two apps."""

    def __init__(self, bus: Bus, config: BridgeConfig, origin: Origin,
                 link: AutopilotLink | None = None,
                 time_source: Callable[[float], None] | None = None) -> None:
        self.bus = bus
        self.config = config
        self.origin = origin
        self.link = link if link is not None else AutopilotLink(
            config.connect, config.baud, config.system_id, config.component_id,
            config.target_system, config.target_component)
        self.time_source = time_source
        """Told every autopilot ``time_boot_ms`` (in seconds): the autopilot clock's feed."""
        self.actuation = make_actuation(config)
        self.servos = ServoOutputs(tuple(config.servos), config.target_system,
                                   config.target_component)
        self.view = AutopilotView()
        self._params_requested_at: float | None = None
        self._warned_far = False
        self.handback: HandBack | None = None
        self._named_values: dict[str, float] = {}
        self._statustext_id = 0
        self._gcs_heard_at: float | None = None
        self._guests: dict[str, tuple[int, int]] = {}
        """job@client → (system, component) of guests that asked over MAVLink."""
        self._last_statustext = ""
        self.input = AutopilotInput(self)
        self.output = AutopilotOutput(self)
        self.mode: str | None = None
        self.armed = False
        self.last_heartbeat: float | None = None
        self.link_up = False
        self.online = False
        self.status: str | None = None
        self.bad_packets = 0
        self.refused_outputs = 0
        self.packets = 0
        self.ekf_position_ok: bool | None = None
        self._generation = 0
        self._bad_packets_posted = 0
        self._streams_acked = False
        self._streams_requested_at: float | None = None
        self._up_since: float | None = None
        self._heard: set[str] = set()
        self._streams_checked = False
        self._next_heartbeat = 0.0
        self._boot_time: float | None = None
        self.wheels = WheelOdometry()

    # -- input -----------------------------------------------------------------------------

    def receive(self, now: float) -> None:
        if self._boot_time is None:
            self._boot_time = now
        messages = self.link.poll(now)
        clock = self.bus.clock
        for event in self.link.take_events():
            self.input.notify("MAVLINK_LINK", event)
        if self.link.generation != self._generation:
            self._forget_autopilot()
        for msg in messages:
            # An autopilot clock moves as its stamps are read: a message is heard at the
            # clock's time now, not at the start of the tick (else a live link would look
            # seconds silent while the clock learns how fast the autopilot runs).
            now = max(now, clock.now())
            self.take(msg, now)
        self._update_link(max(now, clock.now()))

    def take(self, msg: mavlink.MAVLink_message, now: float) -> None:
        """One message heard at ``now``: its variables posted, or it is counted as bad. Public
        so a telemetry log (``tlog``) goes through the very conversion a live link does."""
        if msg.get_type() == "BAD_DATA":
            self.bad_packets += 1
            return
        self.packets += 1
        try:
            self._handle(msg, now)
        except (ValueError, TypeError, AttributeError, OverflowError) as exc:
            self.bad_packets += 1
            self.bus.notify("MAVLINK_ERROR", f"{msg.get_type()}: {exc}", self.input.name)

    def _forget_autopilot(self) -> None:
        """A new or restored connection: nothing heard before it counts. No actuation until a
        fresh HEARTBEAT in an online mode arrives on this very link."""
        self._generation = self.link.generation
        self.last_heartbeat = None
        self.mode = None
        self.armed = False
        self.view = AutopilotView()
        self._params_requested_at = None

    def _for_us(self, msg: mavlink.MAVLink_message) -> bool:
        return (msg.target_system == self.config.system_id
                and msg.target_component == self.config.component_id)

    def _command(self, msg: mavlink.MAVLink_message) -> None:
        """A ground station's command to the companion (ArduPilot routes COMMAND_LONG for our
        system and component to our link): USER_1 restarts the helm, USER_2 posts a remote
        flag. Answered with COMMAND_ACK like any MAVLink command."""
        result = mavlink.MAV_RESULT_UNSUPPORTED
        if msg.command == CMD_RESTART_HELM:
            self.input.notify("RESTART_HELM", f"MAVLink from {msg.get_srcSystem()}:"
                              f"{msg.get_srcComponent()}")
            result = mavlink.MAV_RESULT_ACCEPTED
        elif msg.command == CMD_REMOTE_FLAG:
            index = int(msg.param1) if math.isfinite(msg.param1) else 0
            if 1 <= index <= len(self.config.remote_flags):
                flag = self.config.remote_flags[index - 1]
                self.input.notify(flag, f"GCS {msg.get_srcSystem()}:{msg.get_srcComponent()}")
                self.input.notify("REMOTE_FLAG", flag)
                result = mavlink.MAV_RESULT_ACCEPTED
            else:
                result = mavlink.MAV_RESULT_DENIED
                self.input.notify("MAVLINK_WARNING", f"remote flag {msg.param1:g} refused: "
                                  f"{len(self.config.remote_flags)} RemoteFlag lines in iMAVLink")
        self.link.mav.command_ack_send(msg.command, result, 0, 0, msg.get_srcSystem(),
                                       msg.get_srcComponent())

    def _third_party_request(self, msg: mavlink.MAVLink_message) -> None:
        """A guest's request in a TUNNEL (its reply goes back the same way, to its system and
        component)."""
        length = max(0, min(int(msg.payload_length), len(msg.payload)))
        text = bytes(msg.payload[:length]).decode("utf-8", "replace")
        who = text.partition(":")[0].strip()
        self._guests[who] = (msg.get_srcSystem(), msg.get_srcComponent())
        self.input.notify(REQUEST_VARIABLE, text)

    def send_reply(self, reply: str) -> None:
        """A third-party reply to the guest that asked over MAVLink (others read the bus)."""
        guest = self._guests.get(reply.partition(":")[0])
        if guest is None:
            return
        payload = reply.encode("utf-8")[:MAX_LENGTH]
        self.link.mav.tunnel_send(guest[0], guest[1], TUNNEL_PAYLOAD_TYPE, len(payload),
                                  payload.ljust(MAX_LENGTH, b"\0"))

    def _from_autopilot(self, msg: mavlink.MAVLink_message) -> bool:
        return (msg.get_srcSystem() == self.config.target_system
                and msg.get_srcComponent() == self.config.target_component)

    def _handle(self, msg: mavlink.MAVLink_message, now: float) -> None:
        kind = msg.get_type()
        if kind == "HEARTBEAT" and msg.type == mavlink.MAV_TYPE_GCS \
                and (msg.get_srcSystem(), msg.get_srcComponent()) != \
                (self.config.system_id, self.config.component_id):
            self._gcs_heard_at = now
            return
        if kind == "COMMAND_LONG" and self._for_us(msg):
            self._command(msg)
            return
        if kind == "TUNNEL" and self._for_us(msg) and msg.payload_type == TUNNEL_PAYLOAD_TYPE:
            self._third_party_request(msg)
            return
        if not self._from_autopilot(msg):
            return
        self._heard.add(kind)
        boot_ms = getattr(msg, "time_boot_ms", None)
        if boot_ms is not None and self.time_source is not None:
            self.time_source(boot_ms / 1000.0)
        # one stamp for every variable of a message: an autopilot clock moves between two
        # posts, and GPS_X and GPS_Y stamped microseconds apart are not one fix to pNav (it
        # dropped 22-83 % of the fixes on the real SITL at x5)
        stamp = self.bus.clock.now()

        def post(name: str, value: float | str) -> None:
            self.input.notify(name, value, stamp)
        if kind == "HEARTBEAT":
            if msg.type == mavlink.MAV_TYPE_GCS or msg.autopilot == mavlink.MAV_AUTOPILOT_INVALID:
                return
            self.last_heartbeat = now
            self.mode = ROVER_MODES.get(msg.custom_mode, f"MODE{msg.custom_mode}")
            self.armed = bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            if self.handback is not None and self.handback.confirm(self.mode):
                post("HELM_HANDBACK_DONE", self.mode)
            post("AP_MODE", self.mode)
            post("AP_ARMED", 1.0 if self.armed else 0.0)
        elif kind == "GPS_RAW_INT":
            post("GPS_FIX", float(msg.fix_type))
            if msg.fix_type >= mavlink.GPS_FIX_TYPE_3D_FIX:
                if abs(msg.lat) > 900_000_000 or abs(msg.lon) > 1_800_000_000:
                    raise ValueError(f"lat/lon {msg.lat}/{msg.lon} (1e-7 deg) is not on the earth")
                x, y = self.origin.to_local(msg.lat * 1e-7, msg.lon * 1e-7)
                self._check_distance(x, y)
                post("GPS_X", x)
                post("GPS_Y", y)
                if msg.vel != _UNKNOWN_U16:
                    post("GPS_SPEED", msg.vel / 100.0)
                if msg.cog != _UNKNOWN_U16:
                    post("GPS_HEADING", msg.cog / 100.0)
        elif kind == "ATTITUDE":
            if not all(math.isfinite(v) for v in (msg.roll, msg.pitch, msg.yaw, msg.yawspeed)):
                raise ValueError("non-finite attitude")
            post("INS_YAW", 0.0 - msg.yaw)
            post("INS_HEADING", math.degrees(msg.yaw) % 360.0)
            post("INS_PITCH", msg.pitch)
            post("INS_ROLL", msg.roll)
            post("INS_YAW_VEL", 0.0 - msg.yawspeed)
        elif kind == "GLOBAL_POSITION_INT":
            if self.ekf_position_ok is False or (msg.lat == 0 and msg.lon == 0):
                return
            if abs(msg.lat) > 900_000_000 or abs(msg.lon) > 1_800_000_000:
                raise ValueError(f"lat/lon {msg.lat}/{msg.lon} (1e-7 deg) is not on the earth")
            x, y = self.origin.to_local(msg.lat * 1e-7, msg.lon * 1e-7)
            post("AP_X", x)
            post("AP_Y", y)
            post("AP_SPEED", math.hypot(msg.vx, msg.vy) / 100.0)
            if msg.hdg != _UNKNOWN_U16:
                post("AP_HEADING", msg.hdg / 100.0)
                post("AP_YAW", -math.radians(msg.hdg / 100.0))
        elif kind == "DISTANCE_SENSOR":
            reading = distance_reading(msg)
            if reading is not None:
                post("AP_ALTITUDE" if msg.orientation == DOWNWARD
                     else f"AP_DISTANCE_{int(msg.orientation)}", reading)
        elif kind == "WHEEL_DISTANCE":
            speed = self.wheels.speed(int(msg.time_usec), int(msg.count), list(msg.distance))
            if speed is not None:
                post("WHEEL_VX_BODY", speed)
        elif kind == "SIMSTATE":
            self._truth(msg, post)
        elif kind == "EKF_STATUS_REPORT":
            self.ekf_position_ok = bool(msg.flags & mavlink.EKF_POS_HORIZ_ABS)
        elif kind == "PARAM_VALUE":
            name = msg.param_id.rstrip("\x00") if isinstance(msg.param_id, str) else ""
            if name and math.isfinite(msg.param_value):
                self.view.params[name] = float(msg.param_value)
        elif kind == "RC_CHANNELS":
            count = max(0, min(18, int(msg.chancount)))
            self.view.rc = [int(getattr(msg, f"chan{i}_raw")) for i in range(1, count + 1)]
        elif kind == "COMMAND_ACK":
            if (msg.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
                    and msg.result == mavlink.MAV_RESULT_ACCEPTED):
                self._streams_acked = True
            if msg.command == mavlink.MAV_CMD_DO_SET_MODE and self.handback is not None:
                self.handback.acknowledged(msg.result)
            if msg.command == mavlink.MAV_CMD_DO_SET_SERVO:
                report = self.servos.acknowledged(msg.result)
                if report is not None:
                    post("MAVLINK_WARNING", report)
            post("AP_COMMAND_ACK", f"command={msg.command},result={msg.result}")
        elif kind == "STATUSTEXT":
            self._last_statustext = msg.text
            post("AP_STATUSTEXT", msg.text)

    def _truth(self, msg: mavlink.MAVLink_simstate_message,
               post: Callable[[str, float | str], None]) -> None:
        """A simulator's true pose, for judging the navigator on SITL (never steered by)."""
        if msg.lat == 0 and msg.lng == 0:
            return
        if abs(msg.lat) > 900_000_000 or abs(msg.lng) > 1_800_000_000:
            raise ValueError(f"lat/lng {msg.lat}/{msg.lng} (1e-7 deg) is not on the earth")
        if not math.isfinite(msg.yaw):
            raise ValueError("non-finite yaw")
        x, y = self.origin.to_local(msg.lat * 1e-7, msg.lng * 1e-7)
        post("TRUTH_X", x)
        post("TRUTH_Y", y)
        post("TRUTH_HEADING", math.degrees(msg.yaw) % 360.0)

    def _check_distance(self, x: float, y: float) -> None:
        """Say once if the vehicle is far from the mission's origin: the wrong mission file,
        or an origin typed wrong, would otherwise steer for a point kilometres away."""
        distance = math.hypot(x, y)
        if distance > FAR_FROM_ORIGIN_M and not self._warned_far:
            self._warned_far = True
            self.input.notify("MAVLINK_WARNING", f"the vehicle is {distance / 1000:.1f} km from "
                              "the mission's origin (LatOrigin/LongOrigin): wrong mission, or a "
                              "wrong origin?")

    def _update_link(self, now: float) -> None:
        heard = self.last_heartbeat
        up = (self.link.connected and heard is not None
              and now - heard <= self.config.link_timeout)
        if up != self.link_up:
            self.link_up = up
            self.input.notify("AP_LINK", 1.0 if up else 0.0)
            if up:
                self._up_since = now
                self._heard = set()
                self._streams_checked = False
                self._request_streams(now)
            else:
                self._streams_acked = False
                if heard is not None:
                    why = (f"no HEARTBEAT for {self.config.link_timeout:g} s"
                           if self.link.connected else "the connection dropped")
                    self.input.notify("MAVLINK_WARNING", f"autopilot link lost: {why}")
        elif up and not self._streams_acked and self._streams_requested_at is not None \
                and now - self._streams_requested_at >= 2.0:
            self._request_streams(now)
        if up and not self._streams_checked and self._up_since is not None \
                and now - self._up_since >= STREAM_GRACE_S:
            self._streams_checked = True
            missing = [n for n, rate in self.config.streams.items()
                       if rate > 0 and n not in self._heard]
            if missing:
                self.input.notify("MAVLINK_WARNING", f"no {', '.join(missing)} from the "
                                  f"autopilot {STREAM_GRACE_S:g} s after the link came up: "
                                  "check its stream rates (SRn_* parameters)")
        if up:
            self._request_params(now)
        self.view.gcs_silent_s = (math.inf if self._gcs_heard_at is None
                                  else now - self._gcs_heard_at)
        refusal = self.actuation.refusal(self.view) if up else None
        online = (up and self.armed and self.mode in self.config.online_modes
                  and refusal is None)
        if online != self.online:
            self.online = online
            self.input.notify("HELM_ONLINE", 1.0 if online else 0.0)
            if not online and self.link.connected:
                self.actuation.release(self.link.mav)
        status = self._status(up, refusal)
        if status != self.status:
            self.status = status
            self.input.notify("HELM_STATUS", status)
        self.post_bad_packets()

    def post_bad_packets(self) -> None:
        """``MAVLINK_BAD_PACKETS`` when the count has changed since it was last posted."""
        if self.bad_packets != self._bad_packets_posted:
            self._bad_packets_posted = self.bad_packets
            self.input.notify("MAVLINK_BAD_PACKETS", float(self.bad_packets))

    def _request_params(self, now: float) -> None:
        """Ask for the parameters the actuation profile needs; again every 2 s until known."""
        wanted = [n for n in self.actuation.wanted_params() if n not in self.view.params]
        if isinstance(self.actuation, RcOverride):
            wanted += [n for n in self.actuation.missing(self.view.params)
                       if n not in wanted and n not in GCS_SYSID_PARAMS]
            if any(n in self.view.params for n in GCS_SYSID_PARAMS):
                wanted = [n for n in wanted if n not in GCS_SYSID_PARAMS]
        if not wanted or (self._params_requested_at is not None
                          and now - self._params_requested_at < 2.0):
            return
        self._params_requested_at = now
        for name in wanted:
            self.link.mav.param_request_read_send(self.config.target_system,
                                                  self.config.target_component,
                                                  name.encode(), -1)

    def _status(self, up: bool, refusal: str | None = None) -> str:
        """Whether the helm may drive, and if not, the one reason an operator can act on."""
        modes = ", ".join(self.config.online_modes)
        if self.online:
            return f"ONLINE: autopilot armed in {self.mode}"
        if not up:
            if not self.link.connected:
                return f"offline: no connection to the autopilot at {self.link.url}"
            if self.last_heartbeat is None:
                return "offline: connected, waiting for the autopilot's HEARTBEAT"
            return (f"offline: no HEARTBEAT from the autopilot for "
                    f"{self.config.link_timeout:g} s")
        no_fix = ("; its EKF has no position yet, so ArduPilot will refuse GUIDED"
                  if self.ekf_position_ok is False and "GUIDED" in self.config.online_modes
                  else "")
        if not self.armed:
            return (f"offline: autopilot disarmed (arm it and select {modes} to hand over)"
                    + no_fix)
        if self.mode not in self.config.online_modes:
            return f"offline: autopilot in {self.mode}; select {modes} to hand over" + no_fix
        return f"offline: {refusal}"

    def _request_streams(self, now: float) -> None:
        """Ask for each stream at its rate; repeated every 2 s until the autopilot ACKs."""
        self._streams_requested_at = now
        for name, rate in self.config.streams.items():
            msg_id = getattr(mavlink, f"MAVLINK_MSG_ID_{name}")
            interval_us = -1 if rate <= 0 else int(1e6 / rate)
            self.link.mav.command_long_send(
                self.config.target_system, self.config.target_component,
                mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, msg_id, interval_us, 0, 0, 0, 0, 0)

    # -- output ----------------------------------------------------------------------------

    def send(self, mail: list[Message], now: float) -> None:
        for m in mail:
            if m.name in NAMED_VALUES and m.is_double:
                self._named_values[NAMED_VALUES[m.name]] = m.double
        if now >= self._next_heartbeat:
            self._next_heartbeat = now + 1.0
            self.link.mav.heartbeat_send(
                mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                mavlink.MAV_STATE_ACTIVE)
            self._send_named_values(now)
        for m in mail:
            if m.name == "HELM_HANDBACK":
                self._request_handback(m.string, now)
            elif m.name == REPLY_VARIABLE:
                self.send_reply(m.string)
        if self.handback is not None:
            self._drive_handback(now)
        if not self.online:
            for name in ("DES_RUDDER", "DES_THRUST"):
                self._named_values.pop(name, None)  # not driving: no demand to show
            return
        desired = {m.name: m.value for m in mail if m.is_double}
        # an autopilot clock moves while the tick runs: the refresh is timed, and logged, by
        # the moment of sending, so the log shows the interval the autopilot saw
        sent_at = self.bus.clock.now()
        for servo, pwm in self.servos.update(self.link.mav, desired, sent_at):
            self.output.notify(f"AP_CMD_SERVO{servo.channel}", float(pwm), sent_at)
        if "DESIRED_RUDDER" not in desired and "DESIRED_THRUST" not in desired:
            return
        rudder = self._guard("DESIRED_RUDDER", desired.get("DESIRED_RUDDER", 0.0),
                             self.config.max_rudder)
        thrust = self._guard("DESIRED_THRUST", desired.get("DESIRED_THRUST", 0.0), 100.0)
        boot = now if self._boot_time is None else self._boot_time
        boot_ms = int(max(0.0, now - boot) * 1000) & 0xFFFFFFFF
        sent = self.actuation.drive(self.link.mav, self.view, rudder, thrust, boot_ms)
        for name, value in sent.items():
            self.output.notify(name, value)

    def _send_named_values(self, now: float) -> None:
        """Once a second, the helm's view as NAMED_VALUE_FLOAT (what ground stations list and
        graph, and what ``mavhelm remote`` shows): pose from pNav, desired actuators."""
        boot = now if self._boot_time is None else self._boot_time
        boot_ms = int(max(0.0, now - boot) * 1000) & 0xFFFFFFFF
        for name, value in self._named_values.items():
            if math.isfinite(value) and abs(value) < FLOAT32_MAX:
                self.link.mav.named_value_float_send(boot_ms, name.encode(), value)

    def _request_handback(self, mode: str, now: float) -> None:
        """EndMission asks to give the vehicle back to the autopilot in ``mode``; only done if
        the helm has the vehicle, never over an operator who has taken it back."""
        if not self.online:
            self.output.notify("HELM_HANDBACK_ERROR", f"mission ended while the helm was "
                               f"offline: the operator's mode {self.mode} is left alone")
            return
        self.handback = HandBack(mode)

    def _drive_handback(self, now: float) -> None:
        """Ask (again) for the mode until the HEARTBEAT shows it or three tries have failed."""
        hb = self.handback
        assert hb is not None
        if hb.done:
            return
        if hb.failed(now):
            hb.done = True
            said = f"; it said: {self._last_statustext}" if self._last_statustext else ""
            self.output.notify("HELM_HANDBACK_ERROR", f"ArduPilot did not take the vehicle in "
                               f"{hb.mode} ({hb.why()}{said}): the helm keeps the end values")
            return
        if hb.due(now):
            self.link.mav.command_long_send(
                self.config.target_system, self.config.target_component,
                mavlink.MAV_CMD_DO_SET_MODE, 0, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                ROVER_MODE_NUMBERS[hb.mode], 0, 0, 0, 0, 0)

    def _guard(self, name: str, value: float | str, limit: float) -> float:
        """The last line of defence: a demand that is not a finite number within ±limit is
        never sent; the safe value 0 (no turn, no thrust) goes instead, and it is reported."""
        if isinstance(value, float) and math.isfinite(value) and abs(value) <= limit:
            return value
        self.refused_outputs += 1
        self.output.notify("MAVLINK_OUTPUT_REFUSED",
                           f"{name}={value} is not a finite number within ±{limit:g}: sent 0")
        return 0.0

    def send_statustext(self, text: str, severity: int) -> None:
        """A line for the ground station's message pane. MAVLink 2 carries 50 bytes a message;
        a longer line goes in chunks sharing an id, which ground stations put back together."""
        data = text.encode("utf-8", "replace")[:STATUSTEXT_MAX]
        if len(data) <= 50:
            self.link.mav.statustext_send(severity, data)
            return
        self._statustext_id = self._statustext_id % 65535 + 1
        for seq, start in enumerate(range(0, len(data), 50)):
            self.link.mav.statustext_send(severity, data[start:start + 50],
                                          self._statustext_id, seq)

    def close(self) -> None:
        self.link.close()

    def send_tunnel(self, payload_type: int, payload: bytes,
                    target: tuple[int, int] = (0, 0)) -> None:
        """A TUNNEL message of ``payload_type`` to ``target`` ((0, 0): every listener)."""
        data = bytes(payload)[:MAX_LENGTH]
        self.link.mav.tunnel_send(target[0], target[1], payload_type, len(data),
                                  data.ljust(MAX_LENGTH, b"\0"))


class AutopilotInput(App):
    name = "iMAVLink"

    def __init__(self, bridge: MavlinkBridge) -> None:
        super().__init__(bridge.bus)
        self.bridge = bridge

    def iterate(self, now: float) -> None:
        self.bridge.receive(now)


class AutopilotOutput(App):
    name = "iMAVLinkOut"

    def __init__(self, bridge: MavlinkBridge) -> None:
        super().__init__(bridge.bus)
        self.bridge = bridge
        self._mail: list[Message] = []
        self._subscriptions = frozenset({
            "DESIRED_RUDDER", "DESIRED_THRUST", "DESIRED_ELEVATOR", "HELM_HANDBACK",
            REPLY_VARIABLE, *NAMED_VALUES, *bridge.servos.variables()})

    def subscriptions(self) -> frozenset[str]:
        return self._subscriptions

    def on_mail(self, mail: list[Message], now: float) -> None:
        self._mail = mail

    def iterate(self, now: float) -> None:
        self.bridge.send(self._mail, now)
        self._mail = []

    def close(self) -> None:
        self.bridge.close()


def make_actuation(config: BridgeConfig) -> Actuation:
    """The profile the iMAVLink block asks for."""
    if config.actuation == "rc_override":
        assert config.engage_channel is not None
        return RcOverride(config.target_system, config.target_component, config.max_rudder,
                          config.system_id, config.engage_channel, config.engage_pwm,
                          config.gcs_timeout)
    return Guided(config.target_system, config.target_component, config.max_rudder,
                  config.max_turn_rate)
