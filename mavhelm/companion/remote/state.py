"""What ``mavhelm remote`` knows and what its keys do: MAVLink in, MAVLink out, no I/O.

The autopilot's state comes from its HEARTBEAT, VFR_HUD, COMMAND_ACKs and STATUSTEXTs; the
helm's from the companion's typed status channel (TUNNEL, ``status_wire.py``), decoded and
applied with the companion's own reducer, so nothing here reads English. The companion's
STATUSTEXT lines are listed as text for the operator, and NAMED_VALUE_FLOATs give NAV_X …
DES_THRUST. Every method takes the time ``now`` (monotonic seconds) and returns the messages
to send, in order.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any, TypeAlias

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.bridge import (
    CMD_RESTART_HELM,
    COMPANION_COMPONENT,
)
from mavhelm.companion.mode_request import ModeRequest, Step, mode_numbers_for, modes_for
from mavhelm.companion.status import CompanionStatus, MissionEnded
from mavhelm.companion.status_text import line
from mavhelm.companion.status_wire import STATUS_PAYLOAD_TYPE, decode

Message: TypeAlias = Any
"""A pymavlink message: its fields are attributes named by the MAVLink definition."""

GCS_SYSTEM_ID = 255
GCS_COMPONENT_ID = mavlink.MAV_COMP_ID_MISSIONPLANNER  # 190
HEARTBEAT_PERIOD_S = 1.0
LINK_TIMEOUT_S = 3.0
"""No autopilot HEARTBEAT for this long: the link is shown DOWN (the companion's default)."""
STREAM_RATE_HZ = 2
STREAM_RETRY_S = 5.0
"""Ask for the streams again if nothing but heartbeats has come for this long."""
NUDGE_STEP = 10  # percent
NUDGE_PERIOD_S = 0.5
PWM_CENTRE, PWM_SPAN = 1500, 400
STEER_CHANNEL, THROTTLE_CHANNEL = 1, 3
RC_IGNORE, RC_RELEASE = 0xFFFF, 0
RELEASE_COPIES = 3
"""A release goes out this many times at once, so one lost datagram cannot leave a stick set."""
DISARM_WINDOW_S = 2.0
COMMAND_TIMEOUT_S = 3.0
MODE_TRIES, MODE_RETRY_S = 3, 1.0
COMPANION_TIMEOUT_S = 5.0
TEXT_LINES = 8
NOTE_LINES = 3
VALUE_STALE_S = 3.0

def _mode_name(number: int, vehicle_type: int | None = None) -> str:
    return modes_for(vehicle_type).get(number, f"mode#{number}")


STOP_MODES: dict[int, str] = {mavlink.MAV_TYPE_SUBMARINE: "ALT_HOLD"}
"""ALL STOP's mode where the vehicle has no HOLD: ArduSub holds its depth in ALT_HOLD and,
sticks centred, goes nowhere."""


def _result_name(result: int) -> str:
    entry = mavlink.enums["MAV_RESULT"].get(result)
    name = entry.name if entry is not None else str(result)
    return name.removeprefix("MAV_RESULT_").lower()


@dataclass
class Pending:
    """A command sent and not yet acknowledged."""

    label: str
    sent_at: float


@dataclass
class RemoteState:
    """What the console knows and what its keys do; no I/O. Every method takes the time
    ``now`` (monotonic seconds) and returns the MAVLink messages to send, in order."""

    target: tuple[int, int] = (1, 1)
    companion: tuple[int, int] = (1, COMPANION_COMPONENT)
    url: str = ""
    sysid: int = GCS_SYSTEM_ID
    compid: int = GCS_COMPONENT_ID
    now: float = 0.0
    # the connection and the autopilot
    connected: bool = False
    last_heartbeat: float | None = None
    link_up: bool = False
    mode: str | None = None
    vehicle_type: int | None = None
    """The autopilot's HEARTBEAT type: which mode table applies (Rover's until heard)."""
    armed: bool = False
    vfr: tuple[float, float, int] | None = None
    """(ground speed m/s, heading deg, throttle %) from VFR_HUD, with ``vfr_at``."""
    vfr_at: float | None = None
    last_stream_msg: float | None = None
    # the companion
    companion_heard: float | None = None
    helm_status: CompanionStatus = field(default_factory=CompanionStatus)
    """The companion's state, from its typed status channel alone."""
    values: dict[str, tuple[float, float]] = field(default_factory=dict)
    """NAMED_VALUE_FLOAT name → (value, time heard)."""
    texts: deque[tuple[float, str, str]] = field(
        default_factory=lambda: deque(maxlen=TEXT_LINES))
    """(time, source, text): the last STATUSTEXTs and link events."""
    # the operator
    thrust: int = 0
    rudder: int = 0
    """Stick nudges, in percent (multiples of NUDGE_STEP, -100…100)."""
    overriding: bool = False
    """An override has been sent and not yet released."""
    notes: deque[tuple[float, str]] = field(
        default_factory=lambda: deque([(0.0, "starting")], maxlen=NOTE_LINES))
    """What the console said to the operator last (key refusals, ACKs, releases): a few
    lines, since an ACK and the HEARTBEAT that follows it often come within one redraw."""
    disarm_armed_at: float | None = None
    pending: dict[int, Pending] = field(default_factory=dict)
    mode_request: ModeRequest | None = None
    quit: bool = False
    _next_heartbeat: float = 0.0
    _next_nudge: float = 0.0
    _streams_asked: float | None = None

    @property
    def helm(self) -> str | None:
        """The helm's line (``ONLINE: …``, ``offline: <why>``), once the companion said it."""
        return self.helm_status.status or None

    @property
    def tasks(self) -> list[str]:
        return list(self.helm_status.tasks)

    @property
    def mission_ended(self) -> str | None:
        task = self.helm_status.mission_ended
        return None if task is None else line(MissionEnded(task))

    @property
    def status(self) -> str:
        """The last thing said to the operator; setting it says something new."""
        return self.notes[-1][1]

    @status.setter
    def status(self, text: str) -> None:
        if self.notes and self.notes[-1][1] == text:
            self.notes[-1] = (self.now, text)
        else:
            self.notes.append((self.now, text))

    # -- messages to send -------------------------------------------------------------------

    def _command(self, command: int, *params: float, to: tuple[int, int] | None = None
                 ) -> Message:
        values = [float(p) for p in params] + [0.0] * (7 - len(params))
        ts, tc = to or self.target
        return mavlink.MAVLink_command_long_message(ts, tc, command, 0, *values)

    def _request_mode(self, mode: str) -> list[Message]:
        """Sent at once, even before a HEARTBEAT (ALL STOP is never held back); re-sent only
        while the link is up."""
        self.mode_request = ModeRequest(mode, tries=MODE_TRIES, retry_s=MODE_RETRY_S,
                                        numbers=mode_numbers_for(self.vehicle_type))
        return self._send_mode(self.now)

    def _rc(self, steer: int, throttle: int) -> Message:
        chans = [RC_IGNORE] * 8
        chans[STEER_CHANNEL - 1] = steer
        chans[THROTTLE_CHANNEL - 1] = throttle
        return mavlink.MAVLink_rc_channels_override_message(*self.target, *chans)

    @staticmethod
    def pwm(percent: int) -> int:
        return PWM_CENTRE + round(percent * PWM_SPAN / 100)

    def _override(self) -> list[Message]:
        self.overriding = True
        self._next_nudge = self.now + NUDGE_PERIOD_S
        return [self._rc(self.pwm(self.rudder), self.pwm(self.thrust))]

    def _release(self) -> list[Message]:
        """Centre the sticks; the release (0 = back to the radio) only if one was sent."""
        self.thrust = self.rudder = 0
        if not self.overriding:
            return []
        self.overriding = False
        return [self._rc(RC_RELEASE, RC_RELEASE) for _ in range(RELEASE_COPIES)]

    def heartbeat(self) -> Message:
        return mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE,
            3)

    def _streams(self) -> Message:
        self._streams_asked = self.now
        return mavlink.MAVLink_request_data_stream_message(
            *self.target, mavlink.MAV_DATA_STREAM_ALL, STREAM_RATE_HZ, 1)

    def _text(self, source: str, text: str) -> None:
        self.texts.append((self.now, source, text))

    # -- time and connection ----------------------------------------------------------------

    def connection(self, connected: bool, now: float) -> list[Message]:
        """The transport's state each loop; a new connection forgets the autopilot (its next
        HEARTBEAT tells the mode again)."""
        self.now = now
        out: list[Message] = []
        if connected != self.connected:
            self.connected = connected
            if not connected:
                out += self._lost("connection dropped")
                self.last_heartbeat = None
                self.mode = None
                self.armed = False
        return out

    def link_event(self, text: str, now: float) -> None:
        self.now = now
        self._text("link", text)

    def _lost(self, why: str) -> list[Message]:
        out: list[Message] = []
        if self.link_up:
            self.link_up = False
            dropped = "; stick nudges dropped" if self.thrust or self.rudder else ""
            self.status = f"autopilot link DOWN: {why}{dropped}"
            out = self._release()
            self.mode_request = None
        return out

    def tick(self, now: float) -> list[Message]:
        """Periodic duties: GCS heartbeat, streams, nudge refresh, time-outs."""
        self.now = now
        out: list[Message] = []
        if now >= self._next_heartbeat:
            self._next_heartbeat = now + HEARTBEAT_PERIOD_S
            out.append(self.heartbeat())
        out += self._watch_link(now)
        if (self.thrust or self.rudder) and self.mode == "MANUAL" and now >= self._next_nudge:
            out += self._override()
        self._expire_commands(now)
        out += self._retry_mode(now)
        if self.disarm_armed_at is not None and now - self.disarm_armed_at > DISARM_WINDOW_S:
            self.disarm_armed_at = None
            self.status = "disarm cancelled (D was not pressed again within 2 s)"
        return out

    def _watch_link(self, now: float) -> list[Message]:
        """The autopilot's HEARTBEAT overdue: link down; only heartbeats: ask for streams."""
        if self.link_up and (self.last_heartbeat is None
                             or now - self.last_heartbeat > LINK_TIMEOUT_S):
            return self._lost(f"no HEARTBEAT for {LINK_TIMEOUT_S:g} s")
        quiet = self.last_stream_msg is None or now - self.last_stream_msg >= STREAM_RETRY_S
        if self.link_up and self._streams_asked is not None \
                and now - self._streams_asked >= STREAM_RETRY_S and quiet:
            return [self._streams()]
        return []

    def _expire_commands(self, now: float) -> None:
        for command, p in list(self.pending.items()):
            if now - p.sent_at >= COMMAND_TIMEOUT_S:
                del self.pending[command]
                self.status = f"{p.label}: no answer in {COMMAND_TIMEOUT_S:g} s"

    def _retry_mode(self, now: float) -> list[Message]:
        """The mode asked for, asked again until the HEARTBEAT shows it (MODE_TRIES at most)."""
        if self.mode_request is None or not self.link_up:
            return []
        return self._send_mode(now)

    def _send_mode(self, now: float) -> list[Message]:
        req = self.mode_request
        assert req is not None
        step = req.step(now)
        if step is Step.FAILED:
            self.mode_request = None
            if req.refused is None:
                self.status = (f"mode {req.mode} not taken after {req.sent} requests "
                               f"(still {self.mode})")
            return []
        if step is not Step.SEND:
            return []
        self.pending[mavlink.MAV_CMD_DO_SET_MODE] = Pending(f"mode {req.mode}", now)
        return [req.message(*self.target)]

    # -- what arrives -----------------------------------------------------------------------

    def receive(self, msg: Message, now: float) -> list[Message]:
        self.now = now
        kind = msg.get_type()
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if kind == "HEARTBEAT":
            if src == self.companion:
                self.companion_heard = now
            elif src == self.target and msg.type != mavlink.MAV_TYPE_GCS:
                return self._autopilot_heartbeat(msg, now)
            return []
        if src == self.target:
            if kind not in ("STATUSTEXT", "COMMAND_ACK"):
                self.last_stream_msg = now
            if kind == "VFR_HUD":
                self.vfr = (float(msg.groundspeed), float(msg.heading), int(msg.throttle))
                self.vfr_at = now
        if src[0] != self.target[0]:
            return []
        if kind == "STATUSTEXT":
            self._statustext(src, str(msg.text).rstrip("\x00"))
        elif kind == "COMMAND_ACK":
            self._ack(msg)
        elif src == self.companion:
            self._from_companion(kind, msg, now)
        return []

    def _from_companion(self, kind: str, msg: Message, now: float) -> None:
        if kind == "NAMED_VALUE_FLOAT":
            name = str(msg.name).rstrip("\x00")
            if math.isfinite(msg.value):
                self.values[name] = (float(msg.value), now)
        elif kind == "TUNNEL" and msg.payload_type == STATUS_PAYLOAD_TYPE \
                and msg.target_system in (0, self.sysid):
            event = decode(bytes(msg.payload)[:msg.payload_length])
            if event is not None:
                self.companion_heard = now
                self.helm_status = self.helm_status.apply(event)

    def _autopilot_heartbeat(self, msg: Message, now: float) -> list[Message]:
        out: list[Message] = []
        self.last_heartbeat = now
        if not self.link_up:
            self.link_up = True
            self.status = "autopilot link up"
            out.append(self._streams())
        self.vehicle_type = msg.type
        mode = _mode_name(msg.custom_mode, msg.type)
        armed = bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        if self.mode == "MANUAL" and mode != "MANUAL" and (self.overriding or self.thrust
                                                           or self.rudder):
            out += self._release()
            self.status = f"stick nudges released: autopilot now in {mode}"
        if self.armed and not armed and self.overriding:
            out += self._release()
        self.mode, self.armed = mode, armed
        if self.mode_request is not None and self.mode_request.heartbeat(mode):
            self.mode_request = None
        return out

    def _statustext(self, src: tuple[int, int], text: str) -> None:
        """Listed for the operator to read; the helm's state comes from the typed channel."""
        if src == self.companion:
            self.companion_heard = self.now
            self._text("helm", text)
        elif src == self.target:
            self._text("AP", text)
        else:
            self._text(f"{src[0]}:{src[1]}", text)

    def _ack(self, msg: Message) -> None:
        ts = getattr(msg, "target_system", 0)
        tc = getattr(msg, "target_component", 0)
        if ts not in (0, self.sysid) or tc not in (0, self.compid):
            return  # another ground station's answer
        pending = self.pending.pop(msg.command, None)
        if pending is None:
            return
        result = _result_name(msg.result)
        self.status = f"{pending.label}: {result}"
        if msg.command == mavlink.MAV_CMD_DO_SET_MODE and self.mode_request is not None:
            self.mode_request.acknowledged(msg.result)
            if self.mode_request.refused is not None:
                self.mode_request = None  # refused: asking again will not help

    # -- keys -------------------------------------------------------------------------------

    def handle_key(self, key: str, now: float) -> list[Message]:
        """One key press (a character, or ``up``/``down``/``left``/``right``)."""
        self.now = now
        key = {"up": "w", "down": "s", "left": "a", "right": "d"}.get(key, key)
        if key != "D" and self.disarm_armed_at is not None:
            self.disarm_armed_at = None
        if key in ("\n", "\r"):
            return []
        if key == " ":
            return self._all_stop()
        if key == "q":
            self.quit = True  # run() says why it quit
            return self._release()
        if key == "x":
            if not (self.overriding or self.thrust or self.rudder):
                self.status = "sticks already centred"
                return []
            self.status = "sticks centred: override released"
            return self._release()
        action = {"o": self._toggle, "A": self._arm, "D": self._disarm, "R": self._restart,
                  "w": lambda: self._nudge(thrust=NUDGE_STEP),
                  "s": lambda: self._nudge(thrust=-NUDGE_STEP),
                  "a": lambda: self._nudge(rudder=-NUDGE_STEP),
                  "d": lambda: self._nudge(rudder=NUDGE_STEP)}.get(key)
        if action is None:
            shown = key if key.isprintable() and len(key) == 1 else repr(key)
            self.status = f"key {shown} does nothing (the keys are listed below)"
            return []
        return action()

    def _refuse(self, why: str) -> list[Message]:
        self.status = why
        return []

    def _all_stop(self) -> list[Message]:
        """Never refused: whatever the console believes, ask for HOLD and release the sticks."""
        if not self.connected:
            self.status = "ALL STOP: NOT SENT, no connection to the autopilot!"
            self.thrust = self.rudder = 0
            return []
        out = self._release()
        stop = STOP_MODES.get(self.vehicle_type or 0, "HOLD")
        out += self._request_mode(stop)
        self.status = f"ALL STOP: {stop} requested, sticks released"
        return out

    def _ready(self) -> str | None:
        if not self.connected:
            return "no connection to the autopilot"
        if not self.link_up:
            return "no HEARTBEAT from the autopilot"
        return None

    def _toggle(self) -> list[Message]:
        if (why := self._ready()) is not None:
            return self._refuse(f"o refused: {why}")
        if self.mode == "GUIDED":
            self.status = "MANUAL requested: helm offline"
            return self._request_mode("MANUAL")
        self.status = "GUIDED requested: helm online" + (
            "" if self.armed else " once armed (A)")
        return self._request_mode("GUIDED")

    def _arm(self) -> list[Message]:
        if (why := self._ready()) is not None:
            return self._refuse(f"A refused: {why}")
        if self.armed:
            return self._refuse("A refused: already armed")
        self.pending[mavlink.MAV_CMD_COMPONENT_ARM_DISARM] = Pending("arm", self.now)
        self.status = "arm requested"
        return [self._command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)]

    def _disarm(self) -> list[Message]:
        if (why := self._ready()) is not None:
            self.disarm_armed_at = None
            return self._refuse(f"D refused: {why}")
        if not self.armed:
            self.disarm_armed_at = None
            return self._refuse("D refused: already disarmed")
        if self.disarm_armed_at is None or self.now - self.disarm_armed_at > DISARM_WINDOW_S:
            self.disarm_armed_at = self.now
            self.status = "DISARM? press D again within 2 s"
            return []
        self.disarm_armed_at = None
        self.pending[mavlink.MAV_CMD_COMPONENT_ARM_DISARM] = Pending("disarm", self.now)
        self.status = "disarm requested"
        return self._release() + [self._command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0)]

    def _restart(self) -> list[Message]:
        if not self.connected:
            return self._refuse("R refused: no connection")
        heard = self.companion_heard
        if heard is None or self.now - heard > COMPANION_TIMEOUT_S:
            who = f"{self.companion[0]}:{self.companion[1]}"
            return self._refuse(f"R refused: no companion heard at {who}")
        self.pending[CMD_RESTART_HELM] = Pending("RESTART_HELM", self.now)
        self.status = "RESTART_HELM sent to the companion"
        return [self._command(CMD_RESTART_HELM, 1, to=self.companion)]

    def helm_online(self) -> bool:
        heard = self.companion_heard
        return (self.helm_status.online is True
                and heard is not None and self.now - heard <= COMPANION_TIMEOUT_S)

    def _nudge(self, thrust: int = 0, rudder: int = 0) -> list[Message]:
        what = "thrust" if thrust else "rudder"
        if (why := self._ready()) is not None:
            return self._refuse(f"{what} refused: {why}")
        if self.mode != "MANUAL":
            hint = "; o switches to MANUAL" if self.mode == "GUIDED" else ""
            return self._refuse(f"{what} refused: sticks only in MANUAL (autopilot in "
                                f"{self.mode}{hint})")
        if not self.armed:
            return self._refuse(f"{what} refused: disarmed (A arms)")
        if self.helm_online():
            return self._refuse(f"{what} refused: the helm is driving in MANUAL; "
                                "space takes over")
        new_thrust = max(-100, min(100, self.thrust + thrust))
        new_rudder = max(-100, min(100, self.rudder + rudder))
        if (new_thrust, new_rudder) == (self.thrust, self.rudder):
            return self._refuse(f"{what} already at the limit")
        self.thrust, self.rudder = new_thrust, new_rudder
        if not (self.thrust or self.rudder):
            self.status = "sticks centred: override released"
            return self._release()
        self.status = f"sticks: thrust {self.thrust:+d} %, rudder {self.rudder:+d} %"
        return self._override()
