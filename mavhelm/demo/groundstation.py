"""A scripted operator's ground station: what QGroundControl or MAVProxy would send.

It speaks as system 255 (ArduPilot's default MAV_GCS_SYSID), sends a heartbeat each second,
and arms and switches modes with COMMAND_LONG exactly as an operator's ground station does;
the demo and the tests use it to hand control to the helm and take it back.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

GCS_SYSTEM_ID = 255
GCS_COMPONENT_ID = mavlink.MAV_COMP_ID_MISSIONPLANNER
ROVER_MODE_NUMBERS = {name: number for number, name in mavutil.mode_mapping_rover.items()}


@dataclass
class GroundStation:
    conn: mavutil.mavfile
    target_system: int = 1
    target_component: int = 1
    mode: str | None = None
    armed: bool = False
    acks: list[tuple[float, int, int]] = field(default_factory=list)
    statustexts: list[tuple[float, str]] = field(default_factory=list)
    heartbeats: int = 0
    _next_heartbeat: float = 0.0
    _chunks: dict[tuple[int, int], list[str]] = field(default_factory=dict)

    @classmethod
    def connect(cls, device: str) -> GroundStation:
        conn = mavutil.mavlink_connection(device, source_system=GCS_SYSTEM_ID,
                                          source_component=GCS_COMPONENT_ID,
                                          dialect="ardupilotmega")
        return cls(conn)

    def tick(self, now: float) -> None:
        if now >= self._next_heartbeat:
            self._next_heartbeat = now + 1.0
            self.conn.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID,
                                         0, 0, mavlink.MAV_STATE_ACTIVE)
        for msg in self._read_all():
            self._handle(msg, now)

    def _read_all(self) -> list[mavlink.MAVLink_message]:
        """Everything that has arrived, read in bulk (one syscall per 64 KiB, not two per
        message as ``recv_msg`` does): a scripted operator wants every message."""
        messages: list[mavlink.MAVLink_message] = []
        while data := self.conn.recv(65536):
            messages.extend(self.conn.mav.parse_buffer(data) or [])
        return messages

    def _handle(self, msg, now: float) -> None:
        """The autopilot's state from its own messages (component 1); acknowledgements and
        texts from any component of the vehicle (the companion is 191), as a GCS shows them."""
        if msg.get_srcSystem() != self.target_system:
            return
        kind = msg.get_type()
        if msg.get_srcComponent() != 1 and kind not in ("COMMAND_ACK", "STATUSTEXT"):
            return
        if kind == "HEARTBEAT" and msg.type != mavlink.MAV_TYPE_GCS:
            self.heartbeats += 1
            self.mode = mavutil.mode_mapping_rover.get(msg.custom_mode, str(msg.custom_mode))
            self.armed = bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        elif kind == "COMMAND_ACK":
            self.acks.append((now, msg.command, msg.result))
        elif kind == "STATUSTEXT":
            self._statustext(msg, now)

    def _statustext(self, msg, now: float) -> None:
        """Lines of more than 50 bytes come in chunks with one id (MAVLink 2): join them."""
        chunk_id = getattr(msg, "id", 0)
        if not chunk_id:
            self.statustexts.append((now, msg.text))
            return
        parts = self._chunks.setdefault((msg.get_srcComponent(), chunk_id), [])
        parts.append(msg.text)
        if len(msg.text) < 50:
            self.statustexts.append((now, "".join(parts)))
            del self._chunks[(msg.get_srcComponent(), chunk_id)]

    def command(self, command: int, *params: float) -> None:
        values = list(params) + [0.0] * (7 - len(params))
        self.conn.mav.command_long_send(self.target_system, self.target_component, command, 0,
                                        *values)

    def arm(self, arm: bool = True) -> None:
        self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0 if arm else 0.0)

    def set_mode(self, name: str) -> None:
        self.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                     float(ROVER_MODE_NUMBERS[name.upper()]))

    def rc_override(self, channel: int, pwm: int) -> None:
        """Move one RC channel as a pilot's switch would (from this GCS's system id, which
        ArduPilot obeys only if it is MAV_GCS_SYSID); every other channel left alone."""
        values = [0xFFFF] * 8  # this MAVLink 1 connection carries channels 1-8
        values[channel - 1] = pwm
        self.conn.mav.rc_channels_override_send(self.target_system, self.target_component,
                                                *values)

    def last_ack(self, command: int) -> int | None:
        for _, cmd, result in reversed(self.acks):
            if cmd == command:
                return result
        return None

    def close(self) -> None:
        self.conn.close()


class Operator:
    """Hands the vehicle to the helm: arm when the autopilot allows it, then switch to GUIDED.

    Retries every ``retry`` seconds of simulated time, as a person clicking again would, since
    ArduPilot refuses to arm or enter GUIDED until its EKF has a position.
    """

    def __init__(self, gcs: GroundStation, mode: str = "GUIDED", retry: float = 2.0) -> None:
        self.gcs = gcs
        self.mode = mode
        self.retry = retry
        self._next_try = 0.0
        self.handed_over_at: float | None = None
        self.switch: tuple[int, int] | None = None
        """An RC channel and PWM the operator holds (an engage switch), refreshed every 1 s."""
        self._next_switch = 0.0

    def hold_switch(self, channel: int, pwm: int) -> None:
        self.switch = (channel, pwm)
        self._next_switch = 0.0

    def tick(self, now: float) -> None:
        self.gcs.tick(now)
        if self.switch is not None and now >= self._next_switch:
            self._next_switch = now + 1.0
            self.gcs.rc_override(*self.switch)
        if self.handed_over_at is not None or self.gcs.mode is None:
            return
        if self.gcs.armed and self.gcs.mode == self.mode:
            self.handed_over_at = now
            return
        if now < self._next_try:
            return
        self._next_try = now + self.retry
        if not self.gcs.armed:
            self.gcs.arm()
        else:
            self.gcs.set_mode(self.mode)
