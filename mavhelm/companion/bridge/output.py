"""MAVLink out: the helm's demands, what the ground station sees, and replies.

Every tick while online the ``DESIRED_*`` demands through the actuation profile and the servo
outputs; after the tick, in its idle time, the companion's HEARTBEAT once a second and
NAMED_VALUE_FLOAT at ``NamedValueRate``.
Nothing non-finite or out of range is ever sent: 0 goes instead and ``MAVLINK_OUTPUT_REFUSED``
says why. Also the end-of-mission hand-back (a ``ModeRequest``), STATUSTEXT lines, third-party
replies and TUNNEL payloads.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.mode_request import ModeRequest, Step, mode_numbers_for
from mavhelm.core.bus import Message
from mavhelm.core.thirdparty import MAX_LENGTH, REPLY_VARIABLE, TUNNEL_PAYLOAD_TYPE

if TYPE_CHECKING:
    from mavhelm.companion.bridge.facade import MavlinkBridge

NAMED_VALUES: dict[str, str] = {
    "NAV_X": "NAV_X", "NAV_Y": "NAV_Y", "NAV_HEADING": "NAV_HDG", "NAV_SPEED": "NAV_SPEED",
    "DESIRED_RUDDER": "DES_RUDDER", "DESIRED_THRUST": "DES_THRUST", "NAV_DEPTH": "NAV_DEPTH",
}
"""Bus variable → NAMED_VALUE_FLOAT name (MAVLink allows 10 characters). NAV_DEPTH goes only
where pNav has one (an underwater vehicle)."""

STATUSTEXT_MAX = 200
"""Longest line sent to the ground station (four chunks)."""
STATUSTEXT_CHUNK = 50
"""Bytes of text in one MAVLink 2 STATUSTEXT."""

FLOAT32_MAX = 3.4e38
"""A MAVLink float field holds no more (and nothing non-finite is ever sent)."""

TUNNEL_MAX = 128
"""Bytes of payload in one TUNNEL message."""

HANDBACK_TRIES = 3
HANDBACK_RETRY_S = 1.0
TIME_EPSILON_S = 1e-6
"""Times this close count as equal (ticks on a 0.1 s grid do not add up exactly)."""


class OutputPath:
    """What the bridge sends; ``send`` runs once a tick after the helm."""

    def __init__(self, bridge: MavlinkBridge) -> None:
        self.bridge = bridge
        self.handback: ModeRequest | None = None
        self.operator_mode: ModeRequest | None = None
        """A mode an operator asked the companion for (DO_SET_MODE to it): ALL STOP."""
        self.refused_outputs = 0
        self.named_values: dict[str, float] = {}
        self.next_named_values = -math.inf
        self.statustext_id = 0
        self.next_heartbeat = 0.0

    def send(self, mail: list[Message], now: float) -> None:
        """A whole tick's output: the commands, then the telemetry."""
        self.command(mail, now)
        self.telemetry(now)

    def telemetry(self, now: float) -> None:
        """What only the ground station reads, and can wait for the tick's idle time: the
        companion's HEARTBEAT once a second and the NAMED_VALUE_FLOATs at their rate."""
        bridge = self.bridge
        if now >= self.next_heartbeat:
            self.next_heartbeat = now + 1.0
            bridge.link.mav.heartbeat_send(
                mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                mavlink.MAV_STATE_ACTIVE)
        rate = bridge.config.named_value_rate
        if rate > 0.0 and now >= self.next_named_values - TIME_EPSILON_S:
            period = 1.0 / rate
            self.next_named_values += period  # on a grid: a tick's jitter does not slow it
            if self.next_named_values <= now:
                self.next_named_values = now + period
            self.send_named_values(now)

    def command(self, mail: list[Message], now: float) -> None:
        """What the tick sends at once: the helm's demands, a hand-back or an operator's
        mode request, replies to guests; the values the telemetry will show are noted."""
        bridge = self.bridge
        for m in mail:
            if m.name in NAMED_VALUES and m.is_double:
                self.named_values[NAMED_VALUES[m.name]] = m.double
        for m in mail:
            if m.name == "HELM_HANDBACK":
                self.request_handback(m.string)
            elif m.name == REPLY_VARIABLE:
                self.send_reply(m.string)
        self.drive_handback(now)
        self.drive_operator_mode(now)
        if not bridge.online:
            for name in ("DES_RUDDER", "DES_THRUST"):
                self.named_values.pop(name, None)  # not driving: no demand to show
            return
        self.drive({m.name: m.double for m in mail if m.is_double}, now)

    def drive(self, desired: dict[str, float], now: float) -> None:
        """One online tick's demands to the autopilot: servos, then rudder and thrust."""
        bridge = self.bridge
        # an autopilot clock moves while the tick runs: the refresh is timed, and logged, by
        # the moment of sending, so the log shows the interval the autopilot saw
        sent_at = bridge.bus.clock.now()
        for servo, pwm in bridge.servos.update(bridge.link.mav, desired, sent_at):
            bridge.output.notify(f"AP_CMD_SERVO{servo.channel}", float(pwm), sent_at)
        if "DESIRED_RUDDER" not in desired and "DESIRED_THRUST" not in desired:
            return
        rudder = self.guard("DESIRED_RUDDER", desired.get("DESIRED_RUDDER", 0.0),
                            bridge.config.max_rudder)
        thrust = self.guard("DESIRED_THRUST", desired.get("DESIRED_THRUST", 0.0), 100.0)
        elevator = self.guard("DESIRED_ELEVATOR", desired.get("DESIRED_ELEVATOR", 0.0),
                              bridge.config.max_elevator)
        sent = bridge.actuation.drive(bridge.link.mav, bridge.state.view, rudder, thrust,
                                      bridge.boot_ms(now), elevator=elevator)
        for name, value in sent.items():
            bridge.output.notify(name, value)

    def guard(self, name: str, value: float | str, limit: float) -> float:
        """The last line of defence: a demand that is not a finite number within ±limit is
        never sent; the safe value 0 (no turn, no thrust) goes instead, and it is reported."""
        if isinstance(value, float) and math.isfinite(value) and abs(value) <= limit:
            return value
        self.refused_outputs += 1
        self.bridge.output.notify("MAVLINK_OUTPUT_REFUSED", f"{name}={value} is not a finite "
                                  f"number within ±{limit:g}: sent 0")
        return 0.0

    def send_named_values(self, now: float) -> None:
        """The helm's view as NAMED_VALUE_FLOAT (what ground stations list and graph, and what
        ``mavhelm remote`` shows): pose from pNav, desired actuators."""
        mav = self.bridge.link.mav
        stamp = self.bridge.boot_ms(now)
        for name, value in self.named_values.items():
            if math.isfinite(value) and abs(value) < FLOAT32_MAX:
                mav.named_value_float_send(stamp, name.encode(), value)

    def request_handback(self, mode: str) -> None:
        """EndMission asks to give the vehicle back to the autopilot in ``mode``; only done if
        the helm has the vehicle, never over an operator who has taken it back."""
        bridge = self.bridge
        if not bridge.online:
            bridge.output.notify("HELM_HANDBACK_ERROR", f"mission ended while the helm was "
                                 f"offline: the operator's mode {bridge.mode} is left alone")
            return
        try:
            self.handback = ModeRequest(mode, HANDBACK_TRIES, HANDBACK_RETRY_S,
                                        retry_refused=True,
                                        numbers=mode_numbers_for(bridge.state.vehicle_type))
        except ValueError as exc:
            bridge.output.notify("HELM_HANDBACK_ERROR", f"HandBack = {mode} cannot be asked "
                                 f"of this autopilot: {exc}; the helm keeps the end values")

    def drive_handback(self, now: float) -> None:
        """Ask (again) for the mode until the HEARTBEAT shows it, it is refused, or the tries
        are spent; a failure is said once."""
        hb = self.handback
        if hb is None or hb.done:
            return
        step = hb.step(now)
        if step is Step.SEND:
            config = self.bridge.config
            self.bridge.link.mav.send(hb.message(config.target_system, config.target_component))
        elif step is Step.FAILED:
            said = self.bridge.state.last_statustext
            said = f"; it said: {said}" if said else ""
            self.bridge.output.notify(
                "HELM_HANDBACK_ERROR", f"ArduPilot did not take the vehicle in {hb.mode} "
                f"({hb.why()}{said}): the helm keeps the end values")

    def request_mode(self, mode: str, who: str) -> None:
        """An operator asks for ``mode`` through the companion; the newest request wins."""
        self.operator_mode = ModeRequest(mode, HANDBACK_TRIES, HANDBACK_RETRY_S)
        self.bridge.output.notify("AP_MODE_REQUEST", f"{mode} for {who}")

    def drive_operator_mode(self, now: float) -> None:
        """Send the operator's mode request until the HEARTBEAT shows it or it fails."""
        request = self.operator_mode
        if request is None or request.done:
            return
        request.heartbeat(self.bridge.state.mode)
        step = request.step(now)
        if step is Step.SEND:
            config = self.bridge.config
            self.bridge.link.mav.send(request.message(config.target_system,
                                                      config.target_component))
        elif step is Step.FAILED:
            self.bridge.output.notify("AP_MODE_REQUEST_WARNING", f"the autopilot did not take "
                                      f"{request.mode}: {request.why()}")

    def send_statustext(self, text: str, severity: int) -> None:
        """A line for the ground station's message pane. MAVLink 2 carries 50 bytes a message;
        a longer line goes in chunks sharing an id, which ground stations put back together."""
        mav = self.bridge.link.mav
        data = text.encode("utf-8", "replace")[:STATUSTEXT_MAX]
        if len(data) <= STATUSTEXT_CHUNK:
            mav.statustext_send(severity, data)
            return
        self.statustext_id = self.statustext_id % 65535 + 1
        for seq, start in enumerate(range(0, len(data), STATUSTEXT_CHUNK)):
            mav.statustext_send(severity, data[start:start + STATUSTEXT_CHUNK],
                                self.statustext_id, seq)

    def send_reply(self, reply: str) -> None:
        """A third-party reply to the guest that asked over MAVLink (others read the bus)."""
        guest = self.bridge.state.guests.get(reply.partition(":")[0])
        if guest is None:
            return
        self.send_tunnel(TUNNEL_PAYLOAD_TYPE, reply.encode("utf-8")[:MAX_LENGTH], guest)

    def send_tunnel(self, payload_type: int, payload: bytes,
                    target: tuple[int, int] = (0, 0)) -> bool:
        """A TUNNEL message (``target`` (0, 0): broadcast); True if sent. A payload type
        outside uint16, a payload over 128 bytes or a target outside 0-255 is not sent but
        posted as ``MAVLINK_OUTPUT_REFUSED``: a caller's mistake must not stop the companion."""
        why = None
        if not 0 <= payload_type <= 0xFFFF:
            why = f"payload type {payload_type} is not a uint16"
        elif len(payload) > TUNNEL_MAX:
            why = f"{len(payload)} bytes of payload (at most {TUNNEL_MAX})"
        elif len(target) != 2 or not all(0 <= v <= 255 for v in target):
            why = f"target {target} is not a system, component pair"
        if why is not None:
            self.refused_outputs += 1
            self.bridge.output.notify("MAVLINK_OUTPUT_REFUSED", f"TUNNEL not sent: {why}")
            return False
        self.bridge.link.mav.tunnel_send(target[0], target[1], payload_type, len(payload),
                                         payload.ljust(TUNNEL_MAX, b"\0"))
        return True
