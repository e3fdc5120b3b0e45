"""``MavlinkBridge``: one connection to the autopilot, and its two apps.

It is one connection with two faces in the community's tick order: ``AutopilotInput`` runs
first (MAVLink in → ``GPS_*``, ``INS_*``, ``AP_*``, ``HELM_ONLINE``) and ``AutopilotOutput``
runs after the helm (``DESIRED_*`` → the autopilot), so a mode change that arrives in a tick
stops actuation in that same tick. The work is done by the handlers (in), the link supervisor
(online or not) and the output path (out); this class holds them together.
"""

from __future__ import annotations

from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.bridge.config import BridgeConfig, make_actuation
from mavhelm.companion.bridge.handlers import handle, read_messages
from mavhelm.companion.bridge.output import NAMED_VALUES, OutputPath
from mavhelm.companion.bridge.readings import WheelOdometry
from mavhelm.companion.bridge.senders import SenderGate
from mavhelm.companion.bridge.state import AutopilotState
from mavhelm.companion.bridge.supervisor import LinkSupervisor
from mavhelm.companion.link import AutopilotLink
from mavhelm.companion.mode_request import ModeRequest
from mavhelm.companion.servos import ServoOutputs
from mavhelm.companion.signing import KeyFileError, enable_signing, keep_time, read_key
from mavhelm.core.app import App
from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import boot_ms
from mavhelm.core.errors import SettingError
from mavhelm.core.geodesy import Origin
from mavhelm.core.sender import SenderId
from mavhelm.core.thirdparty import REPLY_VARIABLE

BAD_MESSAGE_ERRORS = (ValueError, TypeError, AttributeError, OverflowError)
"""What a handler raises on a message with impossible values: the message is refused whole."""


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
        self.link.decode_only(read_messages(config))
        self.time_source = time_source
        """Told every autopilot ``time_boot_ms`` (in seconds): the autopilot clock's feed."""
        self.signing = config.signing_key_file is not None
        """Whether the companion signs what it sends (and checks what it reads)."""
        if config.signing_key_file is not None:
            try:
                enable_signing(self.link.mav, read_key(config.signing_key_file))
            except KeyFileError as exc:
                raise SettingError("iMAVLink SigningKeyFile", "the signing key", exc) from None
        self.gate = SenderGate(config.allowed_senders, config.require_signing)
        self.unsigned_ignored = 0
        """Unsigned packets ignored because signing is required."""
        self.actuation = make_actuation(config)
        self.servos = ServoOutputs(tuple(config.servos), config.target_system,
                                   config.target_component)
        self.state = AutopilotState()
        self.wheels = WheelOdometry()
        self.supervisor = LinkSupervisor(self)
        self.send_path = OutputPath(self)
        self.input = AutopilotInput(self)
        self.output = AutopilotOutput(self)
        self.bad_packets = 0
        self.packets = 0
        self._generation = 0
        self._boot_time: float | None = None

    # -- what the others ask -------------------------------------------------------------------

    @property
    def online(self) -> bool:
        return self.supervisor.online

    @property
    def link_up(self) -> bool:
        return self.supervisor.link_up

    @property
    def status(self) -> str | None:
        return self.supervisor.status

    @property
    def mode(self) -> str | None:
        return self.state.mode

    @property
    def armed(self) -> bool:
        return self.state.armed

    @property
    def last_heartbeat(self) -> float | None:
        return self.state.last_heartbeat

    @property
    def handback(self) -> ModeRequest | None:
        return self.send_path.handback

    @property
    def refused_outputs(self) -> int:
        return self.send_path.refused_outputs

    def authorize(self, sender: SenderId, signed: bool, what: str, now: float,
                  guest: bool = False) -> str | None:
        """The one check every command to the companion passes (MAVLink here; a web view's
        control with ``LOCAL_BUS``): None if ``sender`` may give it, else why not, the refusal
        counted and said (``MAVLINK_SENDER_REFUSED``, at most once per sender every few s)."""
        why = self.gate.check(sender, signed, guest)
        if why is not None:
            event = self.gate.refuse(sender, what, why, now)
            if event is not None:
                self.input.notify("MAVLINK_SENDER_REFUSED", event.to_bus())
        return why

    def boot_ms(self, now: float) -> int:
        """The companion's own ``time_boot_ms``: milliseconds since it first ticked."""
        return boot_ms(0.0 if self._boot_time is None else now - self._boot_time)

    # -- input ---------------------------------------------------------------------------------

    def receive(self, now: float) -> None:
        if self._boot_time is None:
            self._boot_time = now
        messages = self.link.poll(now)
        clock = self.bus.clock
        for event in self.link.take_events():
            self.input.notify("MAVLINK_LINK", event)
        if self.link.generation != self._generation:
            self._generation = self.link.generation
            self.state.forget_autopilot()
            self.supervisor.forget_autopilot()
        if self.signing:
            keep_time(self.link.mav)
        for msg in messages:
            # An autopilot clock moves as its stamps are read: a message is heard at the
            # clock's time now, not at the start of the tick (else a live link would look
            # seconds silent while the clock learns how fast the autopilot runs).
            now = max(now, clock.now())
            self.take(msg, now)
        self.supervisor.update(max(now, clock.now()))

    def take(self, msg: mavlink.MAVLink_message, now: float) -> None:
        """One message heard at ``now``: its variables posted, or it is counted as bad. Public
        so a telemetry log (``tlog``) goes through the very conversion a live link does."""
        if msg.get_type() == "BAD_DATA":
            self.bad_packets += 1
            return
        self.packets += 1
        try:
            handle(self, msg, now)
        except BAD_MESSAGE_ERRORS as exc:
            self.bad_packets += 1
            self.bus.notify("MAVLINK_ERROR", f"{msg.get_type()}: {exc}", self.input.name)

    def post_bad_packets(self) -> None:
        """``MAVLINK_BAD_PACKETS`` when the count has changed since it was last posted."""
        self.supervisor.post_bad_packets()

    # -- output --------------------------------------------------------------------------------

    def send(self, mail: list[Message], now: float) -> None:
        """A tick's whole output (commands, then telemetry): a bridge ticked by hand."""
        self.send_path.send(mail, now)

    def send_commands(self, mail: list[Message], now: float) -> None:
        self.send_path.command(mail, now)

    def send_telemetry(self, now: float) -> None:
        self.send_path.telemetry(now)

    def send_statustext(self, text: str, severity: int) -> None:
        self.send_path.send_statustext(text, severity)

    def send_reply(self, reply: str) -> None:
        self.send_path.send_reply(reply)

    def send_tunnel(self, payload_type: int, payload: bytes,
                    target: tuple[int, int] = (0, 0)) -> bool:
        """A TUNNEL (at most 128 bytes) to ``target`` (system, component; (0, 0) for all);
        False, and ``MAVLINK_OUTPUT_REFUSED`` posted, if MAVLink cannot carry it."""
        return self.send_path.send_tunnel(payload_type, payload, target)

    def close(self) -> None:
        self.link.close()


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
        self.bridge.send_commands(self._mail, now)
        self._mail = []

    def idle(self) -> None:
        self.bridge.send_telemetry(self.bus.clock.now())

    def close(self) -> None:
        self.bridge.close()
