"""The ``iMAVLink`` block: every setting declared once in ``IMAVLINK_SCHEMA``.

``BridgeConfig`` takes its attributes, defaults and refusals from the schema, and
``docs/parameters.md`` is generated from it, so adding a setting is adding one ``Param``. What
the schema cannot say alone (a setting that needs another, settings that must differ) is
checked in ``BridgeConfig.from_block`` with the offending line.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.actuation import (
    DEFAULT_STEER_CHANNEL,
    DEFAULT_THROTTLE_CHANNEL,
    Actuation,
    Guided,
    RcOverride,
    SubGuided,
)
from mavhelm.companion.link import transport_for
from mavhelm.companion.mode_request import ALL_MODE_NAMES
from mavhelm.companion.servos import Servo, ServoSpec
from mavhelm.companion.signing import KeyFileError, read_key
from mavhelm.core.mission import Block, Entry, MissionError
from mavhelm.core.moos import APP_PARAMS
from mavhelm.core.params import (
    Boolean,
    Choice,
    ChoiceList,
    Kind,
    Number,
    Param,
    PathName,
    Schema,
    Text,
    Word,
)
from mavhelm.core.sender import SenderId, parse_sender

COMPANION_COMPONENT = mavlink.MAV_COMP_ID_ONBOARD_COMPUTER

DEFAULT_STREAMS: dict[str, float] = {
    "GPS_RAW_INT": 5.0,
    "ATTITUDE": 10.0,
    "GLOBAL_POSITION_INT": 5.0,
    "EKF_STATUS_REPORT": 1.0,
    "SYS_STATUS": 1.0,
}

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


class KeyFile(PathName):
    """The signing key's file, relative to the mission's folder: read and checked at load
    (owner-only, one passphrase), so a bad one is refused before anything starts. Only the
    path is kept; the key is read again when the link is set up, and never logged."""

    def describe(self) -> str:
        return "a path to a file readable by its owner only, holding one passphrase"

    def parse(self, entry: Entry) -> str:
        text = super().parse(entry)
        path = Path(text).expanduser()
        if not path.is_absolute() and entry.file:
            path = Path(entry.file).parent / path
        try:
            read_key(path)
        except KeyFileError as exc:
            raise entry.error(f"{entry.key}: {exc}") from None
        return str(path)


class SenderList(Kind):
    """``SYSTEM``, ``SYSTEM:COMPONENT`` or ``local``, separated by commas."""

    def describe(self) -> str:
        return "SYSTEM, SYSTEM:COMPONENT or local (the companion's bus), comma separated"

    def check_value(self, value: Any) -> bool:
        return isinstance(value, tuple) and all(isinstance(v, SenderId) for v in value)

    def parse(self, entry: Entry) -> tuple[SenderId, ...]:
        senders = []
        for word in entry.value.split(","):
            try:
                senders.append(parse_sender(word))
            except ValueError as exc:
                raise entry.error(f"{entry.key}: {exc}") from None
        return tuple(senders)


MAVLINK_ID = Number(1, 255, integer=True)
RC_CHANNEL = Number(1, 16, integer=True)

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
    Param("OnlineModes", ChoiceList(Choice(ALL_MODE_NAMES)), ("GUIDED",),
          doc="the helm drives only while the autopilot is armed in one of these",
          attr="online_modes"),
    Param("Actuation", Choice(("guided", "rc_override")), "guided",
          doc="guided: targets in GUIDED (Rover: SET_ATTITUDE_TARGET; ArduSub: body velocity "
              "and yaw rate); rc_override: RC_CHANNELS_OVERRIDE in MANUAL, engaged by an RC "
              "switch (Rover; see docs/actuation.md)"),
    Param("EngageChannel", RC_CHANNEL, None,
          doc="rc_override: the RC channel whose switch hands the vehicle to the helm "
              "(required with rc_override; not a steering or throttle channel)",
          attr="engage_channel"),
    Param("EngagePWM", Number(900, 2200, integer=True), 1800, "µs",
          "rc_override: the helm may drive while the engage channel is at or above this",
          attr="engage_pwm"),
    Param("SteerChannel", RC_CHANNEL, DEFAULT_STEER_CHANNEL,
          doc="rc_override: the autopilot's steering input (its RCMAP_ROLL); the helm refuses "
              "to engage if the autopilot's RCMAP puts steering or throttle on the engage "
              "channel", attr="steer_channel"),
    Param("ThrottleChannel", RC_CHANNEL, DEFAULT_THROTTLE_CHANNEL,
          doc="rc_override: the autopilot's throttle input (its RCMAP_THROTTLE)",
          attr="throttle_channel"),
    Param("RemoteFlag", Word(), [], repeat=True, attr="remote_flags",
          doc="a flag a ground station may post: COMMAND_LONG MAV_CMD_USER_2 to the companion "
              "with param1 = its number (1 = the first RemoteFlag line)"),
    Param("GcsTimeOut", Number(1.0, 60.0), 5.0, "s",
          "rc_override: offline (and released) when no ground station HEARTBEAT is heard "
          "for this long", attr="gcs_timeout"),
    Param("Servo", ServoSpec(), [], repeat=True, attr="servos",
          doc="a named auxiliary actuator on a servo output: DESIRED_<NAME> in percent "
              "(-100..100) becomes DO_SET_SERVO with PWM min..max"),
    Param("MaxTurnRate", Number(0.0, 360.0, lo_open=True), 90.0, "deg/s",
          "turn rate commanded at full rudder (MAXRUDDER)", attr="max_turn_rate"),
    Param("MaxSpeed", Number(0.0, 20.0, lo_open=True), 1.0, "m/s",
          "ArduSub: forward speed asked at full thrust (Rover uses its WP_SPEED)",
          attr="max_speed"),
    Param("MaxDepthRate", Number(0.0, 5.0, lo_open=True), 0.5, "m/s",
          "ArduSub: vertical speed asked at full elevator (ArduSub limits it to its "
          "PILOT_SPEED_UP/DN)", attr="max_depth_rate"),
    Param("LinkTimeOut", Number(1.0, 60.0), 3.0, "s",
          "no autopilot HEARTBEAT for this long takes the helm offline", attr="link_timeout"),
    Param("NamedValueRate", Number(0.0, 10.0), 1.0, "Hz",
          "how often the helm's view (NAV_X ... DES_THRUST) goes to the ground station as "
          "NAMED_VALUE_FLOAT; 0 sends none (a thin radio link)", attr="named_value_rate"),
    Param("Stream", StreamRate(), [], repeat=True, attr="stream_rates",
          doc="a telemetry rate to ask for, on top of the defaults "
              "(" + ", ".join(f"{k}@{v:g}" for k, v in DEFAULT_STREAMS.items()) + ")"),
    Param("SigningKeyFile", KeyFile(), None, attr="signing_key_file",
          doc="MAVLink 2 signing: the file holding the passphrase (MAVProxy's `signing setup` "
              "word; chmod 600); the companion then signs all it sends (docs/security.md)"),
    Param("RequireSigning", Boolean(), False, attr="require_signing",
          doc="obey only signed packets: unsigned commands are refused and unsigned telemetry "
              "ignored (needs SigningKeyFile, and the autopilot set up to sign)"),
    Param("SetupSigning", Boolean(), False, attr="setup_signing",
          doc="send the key to the autopilot (SETUP_SIGNING, as MAVProxy's `signing setup`) "
              "when it is heard unsigned; needs SigningKeyFile"),
    Param("AllowedSenders", SenderList(), None, attr="allowed_senders",
          doc="who may command the companion (restart, remote flags, third-party requests); "
              "default: the autopilot's MAV_GCS_SYSID and local"),
), moos=APP_PARAMS)


def schema_defaults(schema: Schema) -> dict[str, Any]:
    """attribute → default of every parameter (a fresh list for a repeated one)."""
    return {p.attribute: list(p.default) if p.repeat else p.default for p in schema.params}


class BridgeConfig:
    """The ``iMAVLink`` block, with the helm's MAXRUDDER: one attribute per schema parameter
    (its default from the schema), plus ``streams``, the defaults with the block's ``Stream``
    lines on top. The annotations below only type them; the schema is the declaration."""

    connect: str
    baud: int
    system_id: int
    component_id: int
    target_system: int
    target_component: int
    online_modes: tuple[str, ...]
    actuation: str
    engage_channel: int | None
    engage_pwm: int
    steer_channel: int
    throttle_channel: int
    remote_flags: list[str]
    gcs_timeout: float
    servos: list[Servo]
    max_turn_rate: float
    link_timeout: float
    named_value_rate: float
    stream_rates: list[tuple[str, float]]
    max_speed: float
    max_depth_rate: float
    signing_key_file: str | None
    require_signing: bool
    setup_signing: bool
    allowed_senders: tuple[SenderId, ...] | None
    max_rudder: float
    max_elevator: float
    streams: dict[str, float]

    def __init__(self, max_rudder: float = 20.0, streams: dict[str, float] | None = None,
                 max_elevator: float = 30.0, **settings: Any) -> None:
        values = schema_defaults(IMAVLINK_SCHEMA)
        unknown = sorted(set(settings) - set(values))
        if unknown:
            raise TypeError(f"BridgeConfig has no setting {', '.join(unknown)}")
        values.update(settings)
        for name, value in values.items():
            setattr(self, name, value)
        self.max_rudder = max_rudder
        self.max_elevator = max_elevator
        self.streams = dict(DEFAULT_STREAMS if streams is None else streams)
        self.streams.update(dict(self.stream_rates))

    def replace(self, **changes: Any) -> BridgeConfig:
        """A copy with ``changes`` (attribute names) applied."""
        copy = object.__new__(BridgeConfig)
        unknown = sorted(set(changes) - set(vars(self)))
        if unknown:
            raise TypeError(f"BridgeConfig has no setting {', '.join(unknown)}")
        vars(copy).update(vars(self), **changes)
        return copy

    def __getattr__(self, name: str) -> Any:
        """Only reached for a name that is not an attribute: a setting added to the schema
        without an annotation here is still read (typed Any)."""
        raise AttributeError(f"BridgeConfig has no setting {name!r}")

    def __repr__(self) -> str:
        return f"BridgeConfig({vars(self)!r})"

    def __eq__(self, other: object) -> bool:
        return isinstance(other, BridgeConfig) and vars(self) == vars(other)

    @classmethod
    def from_block(cls, block: Block | None, max_rudder: float = 20.0,
                   max_elevator: float = 30.0) -> BridgeConfig:
        block = block or Block("ProcessConfig", "iMAVLink", "", 0)
        cfg = cls(max_rudder=max_rudder, max_elevator=max_elevator,
                  **IMAVLINK_SCHEMA.read(block))
        if cfg.actuation == "rc_override":
            if cfg.engage_channel is None:
                raise block.error("Actuation = rc_override needs EngageChannel: the RC switch "
                                  "that hands the vehicle to the helm in MANUAL")
            check_rc_channels(cfg, block)
            if block.entry("OnlineModes") is None:
                cfg.online_modes = ("MANUAL",)
            cfg.streams.setdefault("RC_CHANNELS", 5.0)
        check_servos(cfg, block)
        for name, wanted in (("RequireSigning", cfg.require_signing),
                             ("SetupSigning", cfg.setup_signing)):
            if wanted and cfg.signing_key_file is None:
                raise block.require(name).error(f"{name} needs SigningKeyFile: the key to "
                                                "sign with")
        return cfg


def check_rc_channels(cfg: BridgeConfig, block: Block) -> None:
    """The engage switch, steering and throttle are three different RC channels: an override
    written on the engage channel would hold the switch that hands the vehicle to the helm."""
    named = [("EngageChannel", cfg.engage_channel), ("SteerChannel", cfg.steer_channel),
             ("ThrottleChannel", cfg.throttle_channel)]
    for i, (name, channel) in enumerate(named):
        for other, other_channel in named[:i]:
            if channel == other_channel:
                raise _clash(block, (other, name), channel)


def _clash(block: Block, names: tuple[str, str], channel: int | None) -> MissionError:
    """The refusal of two settings on one channel, at the later line the mission wrote."""
    given = [(entry.line, name) for name in names if (entry := block.entry(name)) is not None]
    first = max(given)[1] if given else names[0]
    second = names[1] if first == names[0] else names[0]
    note = ("" if block.entry(second) is not None
            else " by default (ArduPilot's default RCMAP: steering 1, throttle 3)")
    why = ("the RC override would drive the switch that engages the helm"
           if "EngageChannel" in names else "steering and throttle need their own channels")
    entry = block.entry(first)
    return (entry or block).error(f"{first} = {channel} is also the {second}{note}: {why}; "
                                  "choose another channel")


def check_servos(cfg: BridgeConfig, block: Block) -> None:
    """One name and one output per servo."""
    seen: dict[str, Servo] = {}
    for entry, servo in zip(block.all("Servo"), cfg.servos, strict=True):
        for other in seen.values():
            if other.name == servo.name or other.channel == servo.channel:
                raise entry.error(f"Servo {servo.name}@{servo.channel} clashes with "
                                  f"{other.name}@{other.channel}: one name per output")
        seen[servo.name] = servo


def make_actuation(config: BridgeConfig, vehicle_type: int | None = None) -> Actuation:
    """The profile the iMAVLink block asks for, for the vehicle whose HEARTBEAT type is
    ``vehicle_type`` (None: not heard yet). ``guided`` on ArduSub is ``SubGuided``."""
    if config.actuation == "guided" and vehicle_type == mavlink.MAV_TYPE_SUBMARINE:
        return SubGuided(config.target_system, config.target_component, config.max_rudder,
                         config.max_turn_rate, config.max_elevator, config.max_speed,
                         config.max_depth_rate)
    if config.actuation == "rc_override":
        assert config.engage_channel is not None
        return RcOverride(config.target_system, config.target_component, config.max_rudder,
                          config.system_id, config.engage_channel, config.engage_pwm,
                          config.gcs_timeout)
    return Guided(config.target_system, config.target_component, config.max_rudder,
                  config.max_turn_rate)
