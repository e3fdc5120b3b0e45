"""``mavhelm remote``: the spec's iRemote console, as a MAVLink ground station in a terminal.

"Manual control can be regained at any time by pressing space on the iRemote console" (spec
section 1). Here the helm is online exactly while the autopilot is armed in GUIDED (the
companion's ``OnlineModes``), so the console's keys are mode changes, arming and RC override
sent to the autopilot, plus RESTART_HELM to the companion:

======  ==================================================================================
key     effect
======  ==================================================================================
space   ALL STOP: autopilot to HOLD (helm offline), stick nudges released; never refused
o       toggle: GUIDED → MANUAL (helm offline), any other mode → GUIDED (helm online)
A       arm
D D     disarm (D twice within 2 s: a disarm at sea is drastic)
w / s   thrust +10 % / −10 %   (MANUAL only: RC_CHANNELS_OVERRIDE channel 3, 1500 ± f×400 µs)
a / d   rudder −10 % / +10 %   (MANUAL only: channel 1)
arrows  up/down = w/s, left/right = a/d
x       centre the sticks: release the override (0 on channels 1 and 3)
R       RESTART_HELM: COMMAND_LONG MAV_CMD_USER_1 to the companion (1:191), ACK shown
q       quit (nudges released first); Ctrl-C, SIGTERM, SIGHUP and EOF on stdin do the same
======  ==================================================================================

A key that makes no sense now (a nudge outside MANUAL or while the helm drives, arming when
armed, ...) is refused with a status line, and nothing is sent. Nudges are refreshed every 0.5 s
(well inside ArduPilot's RC_OVERRIDE_TIME) and released on ``x``, on leaving MANUAL, on losing
the autopilot's heartbeat and on quitting.

It speaks as the ground station: system 255 (ArduPilot obeys RC override only from
MAV_GCS_SYSID, 255 by default), component 190, a GCS HEARTBEAT every second, and it asks the
autopilot for all its streams at 2 Hz. What it shows comes from MAVLink alone: the autopilot's
HEARTBEAT (mode, armed), VFR_HUD, COMMAND_ACKs and STATUSTEXTs, and the companion's STATUSTEXT
lines (``helm ONLINE: …``, ``task South started``, …) and NAMED_VALUE_FLOATs (NAV_X … DES_THRUST).

``RemoteState`` is the pure part (no I/O: messages in, messages out, a clock passed in);
``render`` draws it as plain lines; ``run`` is the terminal and the link at the edge.
"""

from __future__ import annotations

import argparse
import codecs
import math
import os
import select
import shutil
import signal
import socket
import sys
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.link import AutopilotLink, transport_for
from mavhelm.companion.mavlink_bridge import (
    CMD_RESTART_HELM,
    COMPANION_COMPONENT,
    ROVER_MODE_NUMBERS,
    ROVER_MODES,
)

Message = mavlink.MAVLink_message

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

KEY_HELP = ("keys: space ALL STOP (HOLD)   o GUIDED<->MANUAL   A arm   D D disarm   q quit",
            "      w/s thrust +/-   a/d rudder -/+ (MANUAL)   x centre   R restart helm")


def _mode_name(number: int) -> str:
    return ROVER_MODES.get(number, f"mode#{number}")


def _result_name(result: int) -> str:
    entry = mavlink.enums["MAV_RESULT"].get(result)
    name = entry.name if entry is not None else str(result)
    return name.removeprefix("MAV_RESULT_").lower()


def parse_ids(text: str) -> tuple[int, int]:
    """``SYS:COMP`` → (system, component), each 0…255 (argparse type)."""
    sys_text, sep, comp_text = text.partition(":")
    try:
        ids = (int(sys_text), int(comp_text))
    except ValueError:
        ids = (-1, -1)
    if not sep or not all(0 <= v <= 255 for v in ids):
        raise argparse.ArgumentTypeError(f"expected SYSTEM:COMPONENT (0-255 each), got {text!r}")
    return ids


@dataclass
class Pending:
    """A command sent and not yet acknowledged."""

    label: str
    sent_at: float


@dataclass
class ModeRequest:
    """A mode asked for, re-asked every MODE_RETRY_S until the HEARTBEAT shows it."""

    mode: str
    tries: int
    next_try: float


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
    armed: bool = False
    vfr: tuple[float, float, int] | None = None
    """(ground speed m/s, heading deg, throttle %) from VFR_HUD, with ``vfr_at``."""
    vfr_at: float | None = None
    last_stream_msg: float | None = None
    # the companion
    companion_heard: float | None = None
    helm: str | None = None
    tasks: list[str] = field(default_factory=list)
    mission_ended: str | None = None
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

    def _set_mode(self, mode: str) -> Message:
        self.pending[mavlink.MAV_CMD_DO_SET_MODE] = Pending(f"mode {mode}", self.now)
        return self._command(mavlink.MAV_CMD_DO_SET_MODE,
                             mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, ROVER_MODE_NUMBERS[mode])

    def _request_mode(self, mode: str) -> list[Message]:
        self.mode_request = ModeRequest(mode, 1, self.now + MODE_RETRY_S)
        return [self._set_mode(mode)]

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
        if self.link_up and (self.last_heartbeat is None
                             or now - self.last_heartbeat > LINK_TIMEOUT_S):
            out += self._lost(f"no HEARTBEAT for {LINK_TIMEOUT_S:g} s")
        if self.link_up and self._streams_asked is not None \
                and now - self._streams_asked >= STREAM_RETRY_S \
                and (self.last_stream_msg is None
                     or now - self.last_stream_msg >= STREAM_RETRY_S):
            out.append(self._streams())
        if (self.thrust or self.rudder) and self.mode == "MANUAL" and now >= self._next_nudge:
            out += self._override()
        for command, p in list(self.pending.items()):
            if now - p.sent_at >= COMMAND_TIMEOUT_S:
                del self.pending[command]
                self.status = f"{p.label}: no answer in {COMMAND_TIMEOUT_S:g} s"
        req = self.mode_request
        if req is not None and self.link_up and now >= req.next_try:
            if req.tries >= MODE_TRIES:
                self.mode_request = None
                self.status = (f"mode {req.mode} not taken after {MODE_TRIES} requests "
                               f"(still {self.mode})")
            else:
                req.tries += 1
                req.next_try = now + MODE_RETRY_S
                out.append(self._set_mode(req.mode))
        if self.disarm_armed_at is not None and now - self.disarm_armed_at > DISARM_WINDOW_S:
            self.disarm_armed_at = None
            self.status = "disarm cancelled (D was not pressed again within 2 s)"
        return out

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
        elif kind == "NAMED_VALUE_FLOAT" and src == self.companion:
            name = str(msg.name).rstrip("\x00")
            if math.isfinite(msg.value):
                self.values[name] = (float(msg.value), now)
        return []

    def _autopilot_heartbeat(self, msg: Message, now: float) -> list[Message]:
        out: list[Message] = []
        self.last_heartbeat = now
        if not self.link_up:
            self.link_up = True
            self.status = "autopilot link up"
            out.append(self._streams())
        mode = _mode_name(msg.custom_mode)
        armed = bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        if self.mode == "MANUAL" and mode != "MANUAL" and (self.overriding or self.thrust
                                                           or self.rudder):
            out += self._release()
            self.status = f"stick nudges released: autopilot now in {mode}"
        if self.armed and not armed and self.overriding:
            out += self._release()
        self.mode, self.armed = mode, armed
        req = self.mode_request
        if req is not None and req.mode == mode:
            self.mode_request = None
        return out

    def _statustext(self, src: tuple[int, int], text: str) -> None:
        if src == self.companion:
            self.companion_heard = self.now
            if text.startswith("helm ONLINE") or text.startswith("helm offline"):
                self.helm = text.removeprefix("helm ")
            elif text.startswith("helm reloaded"):
                self.tasks = []
                self.mission_ended = None
            elif text.startswith("task "):
                body = text[5:]
                if body.endswith(" started"):
                    name = body.removesuffix(" started")
                    if name not in self.tasks:
                        self.tasks.append(name)
                elif " ended" in body:
                    name = body.partition(" ended")[0]
                    if name in self.tasks:
                        self.tasks.remove(name)
            elif text.startswith("MISSION ENDED"):
                self.mission_ended = text
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
        if msg.command == mavlink.MAV_CMD_DO_SET_MODE and \
                msg.result != mavlink.MAV_RESULT_ACCEPTED:
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
        out += self._request_mode("HOLD")
        self.status = "ALL STOP: HOLD requested, sticks released"
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
        return (self.helm is not None and self.helm.startswith("ONLINE")
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


# -- the screen ------------------------------------------------------------------------------

def _age(now: float, then: float | None) -> str:
    if then is None:
        return "never"
    return f"{max(0.0, now - then):.0f} s ago"


def render(state: RemoteState, width: int = 100, height: int | None = None) -> list[str]:
    """The console as plain lines, each at most ``width`` characters."""
    s, now = state, state.now
    rule = "-" * max(0, width)
    if s.link_up:
        link = "LINK UP"
    elif s.connected:
        link = "LINK DOWN (connected, no HEARTBEAT)" if s.last_heartbeat is None \
            else f"LINK DOWN (no HEARTBEAT for {now - s.last_heartbeat:.0f} s)"
    else:
        link = "NOT CONNECTED"
    ap = f"autopilot  {link}"
    if s.mode is not None:
        ap += f"   mode {s.mode}   {'ARMED' if s.armed else 'disarmed'}"
    if s.mode_request is not None:
        ap += f"   (asking for {s.mode_request.mode})"
    lines = [f"mavhelm remote  {s.url}  as GCS {s.sysid}:{s.compid}", rule, ap]
    if s.vfr is not None and s.vfr_at is not None and now - s.vfr_at <= VALUE_STALE_S:
        speed, heading, throttle = s.vfr
        lines.append(f"           speed {speed:.2f} m/s   heading {heading:.0f} deg   "
                     f"throttle {throttle} %")
    who = f"{s.companion[0]}:{s.companion[1]}"
    heard = s.companion_heard
    if heard is None:
        lines.append(f"helm       (no companion heard at {who})")
    else:
        stale = "" if now - heard <= COMPANION_TIMEOUT_S else \
            f"   [companion silent for {now - heard:.0f} s]"
        lines.append(f"helm       {s.helm or '(no status yet)'}{stale}")
        lines.append(f"tasks      {', '.join(s.tasks) if s.tasks else '-'}")
        if s.mission_ended:
            lines.append(f"           {s.mission_ended}")
    v = s.values

    def num(name: str, fmt: str) -> str:
        """The value as ``fmt`` (``.1f``, ``+.0f``), never as ``-0.0``."""
        if name not in v:
            return "-"
        return format(round(v[name][0], int(fmt[-2])) + 0.0, fmt)

    if v:
        newest = max(t for _, t in v.values())
        lines.append(f"nav        x {num('NAV_X', '.1f')} m   y {num('NAV_Y', '.1f')} m   "
                     f"heading {num('NAV_HDG', '.0f')} deg   speed {num('NAV_SPEED', '.2f')} "
                     f"m/s   ({_age(now, newest)})")
        driving = "" if state.helm_online() else "   (the helm's last, not driving)"
        lines.append(f"desired    rudder {num('DES_RUDDER', '+.1f')}   "
                     f"thrust {num('DES_THRUST', '+.1f')}{driving}")
    if s.thrust or s.rudder:
        sticks = (f"thrust {s.thrust:+d} %  rudder {s.rudder:+d} %   (RC override ch"
                  f"{THROTTLE_CHANNEL} {s.pwm(s.thrust)}, ch{STEER_CHANNEL} {s.pwm(s.rudder)})")
    else:
        sticks = "centred (no override)"
    lines += [f"sticks     {sticks}", rule]
    lines += [f"> {text}" for _, text in s.notes]
    lines.append(rule)
    texts = list(s.texts)
    if height is not None:
        room = max(1, height - len(lines) - 1 - len(KEY_HELP))
        texts = texts[-room:]
    for at, source, text in texts:
        lines.append(f"{max(0.0, now - at):5.0f}s  {source:<5} {text}")
    if not texts:
        lines.append("(no messages yet)")
    lines += [rule, *KEY_HELP]
    return [line[:width] for line in lines]


# -- keys from a terminal or a pipe ---------------------------------------------------------

ARROWS = {"A": "up", "B": "down", "C": "right", "D": "left"}
ESC_FLUSH_S = 0.1


class KeyReader:
    """Splits what arrives on stdin into keys. Escape sequences are whole keys (arrows become
    ``up``/``down``/``left``/``right``, anything else ``esc``), so the ``A`` of an up-arrow
    can never arm the autopilot."""

    def __init__(self) -> None:
        self._decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")
        self._held = ""
        self._held_at = 0.0

    def feed(self, data: bytes, now: float) -> list[str]:
        text = self._held + self._decoder.decode(data)
        self._held = ""
        keys: list[str] = []
        i = 0
        while i < len(text):
            ch = text[i]
            if ch != "\x1b":
                keys.append(ch)
                i += 1
                continue
            if i + 1 >= len(text):
                self._held, self._held_at = text[i:], now  # maybe the start of a sequence
                break
            if text[i + 1] not in "[O":
                keys.append("esc")  # Alt+key: swallowed whole, so Alt+A cannot arm
                i += 2
                continue
            j = i + 2
            while j < len(text) and not ("\x40" <= text[j] <= "\x7e"):
                j += 1  # CSI parameter bytes
            if j >= len(text):
                self._held, self._held_at = text[i:], now
                break
            keys.append(ARROWS.get(text[j], "esc") if j == i + 2 else "esc")
            i = j + 1
        return keys

    def flush(self, now: float) -> list[str]:
        """A lone ESC (or a cut-off sequence) held too long is an ESC key."""
        if self._held and now - self._held_at >= ESC_FLUSH_S:
            self._held = ""
            return ["esc"]
        return []


# -- the terminal and the link ---------------------------------------------------------------

class _Stop(Exception):
    """SIGTERM or SIGHUP: leave as ``q`` does."""


def _raise_stop(signum, frame) -> None:
    raise _Stop(signal.Signals(signum).name)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--connect", required=True,
                        help="the vehicle: tcp:HOST:PORT, udp:HOST:PORT (listen), "
                             "udpout:HOST:PORT or a serial device (a telemetry radio)")
    parser.add_argument("--baud", type=int, default=57600, help="serial baud rate (57600)")
    parser.add_argument("--sysid", type=int, default=GCS_SYSTEM_ID,
                        help="this ground station's system id (default 255: ArduPilot takes "
                             "RC override only from MAV_GCS_SYSID)")
    parser.add_argument("--compid", type=int, default=GCS_COMPONENT_ID,
                        help="this ground station's component id (default 190)")
    parser.add_argument("--target", type=parse_ids, default=(1, 1), metavar="SYS:COMP",
                        help="the autopilot (default 1:1)")
    parser.add_argument("--companion", type=parse_ids, default=(1, COMPANION_COMPONENT),
                        metavar="SYS:COMP",
                        help="the companion that takes RESTART_HELM (default 1:191)")


def _send(link: AutopilotLink, messages: list[Message]) -> None:
    for msg in messages:
        link.mav.send(msg)


def _close_gently(link: AutopilotLink, wait_s: float = 0.3) -> None:
    """Close so that the last frames (the release of the sticks) get there: a TCP socket
    closed with unread input sends a reset, which can discard what is still queued. So
    finish writing, half-close, and drain until the peer closes or ``wait_s`` passes."""
    sock = link.socket() if link.connected else None
    if sock is None:
        link.close()
        return
    transport = link.transport
    deadline = time.monotonic() + wait_s
    try:
        while getattr(transport, "_unsent", b"") and time.monotonic() < deadline:
            select.select([], [sock], [], 0.05)
            link.write(b"")
        sock.shutdown(socket.SHUT_WR)
        while (left := deadline - time.monotonic()) > 0:
            if select.select([sock], [], [], left)[0] and not sock.recv(65536):
                break
    except OSError:
        pass
    link.close()


class Screen:
    """Redraws in place (home, each line cleared to its end, the rest cleared), only when the
    picture changed."""

    def __init__(self, write: Callable[[str], None], tty: bool) -> None:
        self.write = write
        self.tty = tty
        self._last: list[str] | None = None

    def start(self) -> None:
        self.write("\x1b[?25l\x1b[2J" if self.tty else "\x1b[2J")

    def draw(self, state: RemoteState) -> None:
        size = shutil.get_terminal_size((100, 30))
        lines = render(state, max(20, size.columns - 1), size.lines if self.tty else None)
        if lines == self._last:
            return
        self._last = lines
        self.write("\x1b[H" + "".join(f"{line}\x1b[K\n" for line in lines) + "\x1b[J")

    def stop(self) -> None:
        if self.tty:
            self.write("\x1b[?25h")


def run(args: argparse.Namespace) -> int:
    try:
        transport_for(args.connect, args.baud)
    except ValueError as exc:
        print(f"mavhelm remote: {exc}", file=sys.stderr)
        return 2
    for name in ("sysid", "compid"):
        if not 1 <= getattr(args, name) <= 255:
            print(f"mavhelm remote: --{name} must be 1-255", file=sys.stderr)
            return 2
    target, companion = tuple(args.target), tuple(args.companion)
    state = RemoteState(target=target, companion=companion, url=args.connect,
                        sysid=args.sysid, compid=args.compid, now=time.monotonic())
    link = AutopilotLink(args.connect, args.baud, args.sysid, args.compid, *target)
    stdin_fd = sys.stdin.fileno()
    out_fd = sys.stdout.fileno()
    is_tty = os.isatty(stdin_fd)

    def write(text: str) -> None:
        data = text.encode("utf-8", "replace")
        while data:
            try:
                n = os.write(out_fd, data)
            except BlockingIOError:
                select.select([], [out_fd], [], 1.0)
                continue
            data = data[n:]

    screen = Screen(write, os.isatty(out_fd))
    saved = None
    old_handlers = {sig: signal.signal(sig, _raise_stop) for sig in (signal.SIGTERM,
                                                                      signal.SIGHUP)}
    old_int = signal.getsignal(signal.SIGINT)
    reader = KeyReader()
    stdin_open = True
    why = "q"
    try:
        if is_tty:
            import termios
            import tty

            saved = termios.tcgetattr(stdin_fd)
            tty.setcbreak(stdin_fd, termios.TCSANOW)
        screen.start()
        next_draw = 0.0
        while not state.quit:
            now = time.monotonic()
            messages = link.poll(now)
            _send(link, state.connection(link.connected, now))
            for event in link.take_events():
                state.link_event(event, now)
            for msg in messages:
                if msg.get_type() != "BAD_DATA":
                    _send(link, state.receive(msg, now))
            keys: list[str] = reader.flush(now)
            if stdin_open and select.select([stdin_fd], [], [], 0)[0]:
                data = os.read(stdin_fd, 1024)
                if not data:
                    stdin_open = False  # EOF: a script's last key was sent
                    keys.append("q")
                    why = "end of input"
                keys += reader.feed(data, now)
            for key in keys:
                _send(link, state.handle_key(key, now))
                if state.quit:
                    break
            if state.quit:
                break
            _send(link, state.tick(now))
            if now >= next_draw:
                screen.draw(state)
                next_draw = now + 0.25
            waits = [stdin_fd] if stdin_open else []
            sock = link.fileno() if link.connected else None
            if sock is not None:
                waits.append(sock)
            timeout = max(0.0, min(0.05, next_draw - time.monotonic()))
            select.select(waits, [], [], timeout)
    except KeyboardInterrupt:
        why = "Ctrl-C"
    except _Stop as exc:
        why = str(exc)
    finally:
        # the clean-up is not to be cut short: a second Ctrl-C or SIGTERM waits for it
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            signal.signal(sig, signal.SIG_IGN)
        try:
            state.now = time.monotonic()
            _send(link, state.handle_key("q", state.now))  # sticks released first
            state.status = f"quit ({why})"
            screen.draw(state)
            screen.stop()
        except OSError:
            pass  # the terminal has gone (SIGHUP): nothing to draw on
        finally:
            if saved is not None:
                import termios

                try:
                    termios.tcsetattr(stdin_fd, termios.TCSADRAIN, saved)
                except termios.error:
                    pass
            _close_gently(link)
            signal.signal(signal.SIGINT, old_int)
            for sig, handler in old_handlers.items():
                signal.signal(sig, handler)
    try:
        write(f"mavhelm remote: stopped ({why})\n")
    except OSError:
        pass
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="mavhelm remote", description=__doc__.split("\n")[0])
    add_arguments(parser)
    return run(parser.parse_args(argv))


if __name__ == "__main__":
    sys.exit(main())
