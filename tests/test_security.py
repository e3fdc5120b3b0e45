"""Only the operator commands the boat (issue 19): the sender check, MAVLink 2 signing with
replays refused, the key file, and guests bound to who their link says they are."""

from __future__ import annotations

import os
from collections import deque
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.bridge import BridgeConfig, MavlinkBridge
from mavhelm.companion.bridge.senders import QUIET_S, SenderGate
from mavhelm.companion.console import StatusConsole
from mavhelm.companion.link import AutopilotLink
from mavhelm.companion.signing import (
    EPOCH_2015,
    KeyFileError,
    passphrase_key,
    read_key,
    signing_timestamp,
)
from mavhelm.companion.status import SenderRefused
from mavhelm.companion.status_wire import decode, encode
from mavhelm.core.bus import Bus
from mavhelm.core.clock import SimClock
from mavhelm.core.geodesy import Origin
from mavhelm.core.mission import Block, Entry, MissionError
from mavhelm.core.sender import LOCAL_BUS, SenderId, mavlink_source, parse_sender
from mavhelm.core.thirdparty import REQUEST_VARIABLE, TUNNEL_PAYLOAD_TYPE
from tests.support.helm_rig import Rig as HelmRig
from tests.support.helm_rig import Spec, one, safety

AUTOPILOT = (1, 1)
COMPANION = (1, 191)
OPERATOR = (255, 190)
STRANGER = (77, 191)
PASSPHRASE = "correct-horse-battery-staple"
KEY = passphrase_key(PASSPHRASE)


class Pipe:
    """The bytes under the bridge's link: ``incoming`` in, ``written`` out."""

    def __init__(self) -> None:
        self.incoming: deque[bytes] = deque()
        self.written = bytearray()

    def open(self) -> None: ...
    def ready(self) -> bool: return True
    def close(self) -> None: ...
    def fileno(self) -> int | None: return None

    def write(self, data: bytes) -> int:
        self.written += data
        return len(data)

    def read_into(self, buffer: memoryview) -> int:
        if not self.incoming:
            return 0
        chunk = self.incoming.popleft()
        buffer[:len(chunk)] = chunk
        return len(chunk)


class Sender:
    """A MAVLink speaker on the network (the autopilot, a ground station, a stranger)."""

    def __init__(self, ids: tuple[int, int], key: bytes | None = None) -> None:
        self.mav = mavlink.MAVLink(None, srcSystem=ids[0], srcComponent=ids[1])
        if key is not None:
            self.mav.signing.secret_key = key
            self.mav.signing.sign_outgoing = True
            self.mav.signing.link_id = 3
            self.mav.signing.timestamp = signing_timestamp()

    def frame(self, msg: mavlink.MAVLink_message) -> bytes:
        return bytes(msg.pack(self.mav))

    def command(self, command: int, param1: float = 1.0) -> bytes:
        return self.frame(mavlink.MAVLink_command_long_message(
            *COMPANION, command, 0, param1, 0, 0, 0, 0, 0, 0))

    def tunnel(self, text: str) -> bytes:
        data = text.encode()
        return self.frame(mavlink.MAVLink_tunnel_message(
            *COMPANION, TUNNEL_PAYLOAD_TYPE, len(data), list(data.ljust(128, b"\0"))))

    def gcs_sysid(self, value: int) -> bytes:
        return self.frame(mavlink.MAVLink_param_value_message(
            b"MAV_GCS_SYSID", value, mavlink.MAV_PARAM_TYPE_INT32, 1, 0))

    def heartbeat(self) -> bytes:
        return self.frame(mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_GROUND_ROVER, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 4, 3))


class Companion:
    """A bridge on a pipe, its bus watched, and the ACKs it writes decoded."""

    def __init__(self, **settings) -> None:
        self.clock = SimClock(100.0)
        self.bus = Bus(self.clock)
        self.bus.subscribe("t", {"RESTART_HELM", "REMOTE_FLAG", "GoHome", REQUEST_VARIABLE,
                                 "MAVLINK_SENDER_REFUSED"})
        self.pipe = Pipe()
        link = AutopilotLink("tcp:127.0.0.1:5760", transport=self.pipe)
        self.bridge = MavlinkBridge(self.bus, BridgeConfig(remote_flags=["GoHome"], **settings),
                                    Origin(56.412, -5.476), link=link)
        self.parser = mavlink.MAVLink(None)
        self.parser.robust_parsing = True
        if settings.get("signing_key_file"):
            self.parser.signing.secret_key = KEY
            self.parser.signing.allow_unsigned_callback = lambda mav, msg_id: True

    def hear(self, *frames: bytes, dt: float = 0.1) -> list:
        self.clock.advance(dt)
        mark = len(self.pipe.written)
        self.pipe.incoming.extend(frames)
        self.bridge.receive(self.clock.now())
        return self.parser.parse_buffer(bytes(self.pipe.written[mark:])) or []

    def acks(self, written: list) -> list[tuple[int, int, int]]:
        return [(m.command, m.result, m.target_system) for m in written
                if m.get_type() == "COMMAND_ACK"]

    def posted(self) -> list[tuple[str, str, str]]:
        return [(m.name, m.string, m.source) for m in self.bus.fetch("t")]


def key_file(tmp_path: Path, mode: int = 0o600, text: str = PASSPHRASE + "\n") -> Path:
    path = tmp_path / "signing.key"
    path.write_text(text)
    path.chmod(mode)
    return path


# -- who a sender is ------------------------------------------------------------------------

def test_sender_spelling():
    assert parse_sender("255") == SenderId(255) and parse_sender(" 42:191 ") == SenderId(42, 191)
    assert parse_sender("LOCAL") == LOCAL_BUS
    assert SenderId(255).matches(SenderId(255, 190)) and not SenderId(42, 191).matches(
        SenderId(42, 190))
    assert not SenderId(255).matches(LOCAL_BUS) and LOCAL_BUS.matches(LOCAL_BUS)
    for bad in ("0", "256", "1:0", "x", "1:2:3", ""):
        with pytest.raises(ValueError):
            parse_sender(bad)


def test_the_gate_waits_for_the_autopilots_gcs_sysid_then_obeys_only_it():
    gate = SenderGate()
    assert gate.check(SenderId(*OPERATOR), signed=False) == \
        "the autopilot's MAV_GCS_SYSID is not known yet"
    assert gate.check(LOCAL_BUS, signed=False) is None, "the bus needs no parameter"
    gate.gcs_sysid = 255
    assert gate.check(SenderId(*OPERATOR), signed=False) is None
    assert gate.check(LOCAL_BUS, signed=False) is None, "the local bus (a web view) too"
    assert gate.check(SenderId(*STRANGER), signed=False) == \
        "not an allowed sender (allowed: 255, local)"
    gate.guests = (SenderId(42, 191),)
    assert gate.check(SenderId(42, 191), signed=False, guest=True) is None
    assert gate.check(SenderId(42, 191), signed=False) is not None, "a guest only requests"


def test_with_signing_required_only_a_signed_packet_is_obeyed():
    gate = SenderGate([SenderId(255), LOCAL_BUS], require_signing=True)
    assert gate.check(SenderId(*OPERATOR), signed=True) is None
    assert gate.check(SenderId(*OPERATOR), signed=False) == \
        "not signed, and RequireSigning is on"
    assert gate.check(LOCAL_BUS, signed=False) is None


def test_refusals_are_all_counted_and_said_once_per_sender_per_quiet_time():
    gate = SenderGate([SenderId(255)])
    said = [gate.refuse(SenderId(77, 191), "COMMAND_LONG USER_1", "no", t)
            for t in (0.0, 1.0, 2.0, QUIET_S + 0.5)]
    other = gate.refuse(SenderId(78, 191), "COMMAND_LONG USER_1", "no", 2.5)
    assert [e is not None for e in said] == [True, False, False, True]
    assert said[-1] == SenderRefused("77:191", "COMMAND_LONG USER_1", "no", 4)
    assert other is not None and other.count == 5 and gate.refused == 5


def test_a_refusal_is_a_typed_event_on_the_bus_the_console_and_the_wire(tmp_path):
    event = SenderRefused("77:191", "COMMAND_LONG USER_1", "not an allowed sender", 3)
    assert SenderRefused.from_bus(event.to_bus()) == event
    assert decode(encode(event)) == event
    assert decode(encode(SenderRefused("1:2", "x", "y", 2**40))).count == 2**32 - 1
    lines: list[str] = []
    bus = Bus(SimClock(0.0))
    console = StatusConsole(bus, lines.append)
    msg = bus.notify("MAVLINK_SENDER_REFUSED", event.to_bus(), "iMAVLink")
    console.take([msg], 0.0)
    assert lines[-1].endswith("REFUSED COMMAND_LONG USER_1 from 77:191: not an allowed sender "
                              "(3 refused so far)")
    assert console.status.refused == 3


# -- the bridge: every command to the companion is checked -----------------------------------

@pytest.fixture
def unsigned() -> tuple[Companion, Sender, Sender, Sender]:
    c = Companion()
    autopilot, operator, stranger = Sender(AUTOPILOT), Sender(OPERATOR), Sender(STRANGER)
    c.hear(autopilot.heartbeat(), autopilot.gcs_sysid(255))
    c.posted()
    return c, autopilot, operator, stranger


def test_a_strangers_restart_flag_and_request_are_refused_and_the_operator_obeyed(unsigned):
    c, _, operator, stranger = unsigned
    written = c.hear(stranger.command(mavlink.MAV_CMD_USER_1),
                     stranger.command(mavlink.MAV_CMD_USER_2),
                     stranger.tunnel("Sample@iScience:TASK=GoToWayPoint|Location=0,0"))
    denied = mavlink.MAV_RESULT_DENIED
    assert c.acks(written) == [(mavlink.MAV_CMD_USER_1, denied, 77),
                               (mavlink.MAV_CMD_USER_2, denied, 77)], "no answer to a TUNNEL"
    posted = c.posted()
    assert [(n, v) for n, v, _ in posted] == [(
        "MAVLINK_SENDER_REFUSED",
        "77:191|COMMAND_LONG USER_1|1|not an allowed sender (allowed: 255, local)")], \
        "nothing done; one line for the sender, whatever it tries next"
    assert c.bridge.gate.refused == 3
    written = c.hear(operator.command(mavlink.MAV_CMD_USER_1),
                     operator.command(mavlink.MAV_CMD_USER_2))
    assert c.acks(written) == [(mavlink.MAV_CMD_USER_1, mavlink.MAV_RESULT_ACCEPTED, 255),
                               (mavlink.MAV_CMD_USER_2, mavlink.MAV_RESULT_ACCEPTED, 255)]
    names = [n for n, _, _ in c.posted()]
    assert names == ["RESTART_HELM", "GoHome", "REMOTE_FLAG"]


def test_the_bridge_asks_the_autopilot_for_its_gcs_sysid_and_refuses_until_known():
    c = Companion()
    written = c.hear(Sender(AUTOPILOT).heartbeat(), Sender(OPERATOR).command(
        mavlink.MAV_CMD_USER_1))
    asked = {m.param_id for m in written if m.get_type() == "PARAM_REQUEST_READ"}
    assert asked == {"MAV_GCS_SYSID", "SYSID_MYGCS"}
    assert c.acks(written) == [(mavlink.MAV_CMD_USER_1, mavlink.MAV_RESULT_DENIED, 255)]
    assert "MAV_GCS_SYSID is not known yet" in c.posted()[0][1]


def test_a_stranger_cannot_pose_as_the_autopilot_to_set_the_gcs_sysid(unsigned):
    c, _, _, stranger = unsigned
    c.hear(stranger.gcs_sysid(77))
    assert c.bridge.gate.gcs_sysid == 255


def test_allowed_senders_from_the_mission_replace_the_default():
    c = Companion(allowed_senders=(SenderId(250, 190),))
    written = c.hear(Sender((250, 190)).command(mavlink.MAV_CMD_USER_1),
                     Sender(OPERATOR).command(mavlink.MAV_CMD_USER_1))
    assert [r for _, r, _ in c.acks(written)] == [mavlink.MAV_RESULT_ACCEPTED,
                                                  mavlink.MAV_RESULT_DENIED]


def test_a_request_is_posted_with_its_sender_as_the_source(unsigned):
    c, _, operator, _ = unsigned
    c.hear(operator.tunnel("Sample@iScience:CLOSE"))
    assert c.posted() == [(REQUEST_VARIABLE, "Sample@iScience:CLOSE", mavlink_source(255, 190))]


# -- signing ----------------------------------------------------------------------------------

def test_the_key_is_mavproxys_and_the_timestamp_counts_10us_from_2015():
    import hashlib
    assert KEY == hashlib.sha256(PASSPHRASE.encode()).digest()
    assert signing_timestamp(EPOCH_2015 + 1.5) == 150_000


def test_a_key_file_others_can_read_is_refused_like_an_ssh_key(tmp_path):
    assert read_key(key_file(tmp_path)) == KEY
    for mode in (0o640, 0o604, 0o620):
        with pytest.raises(KeyFileError, match="group or others .* chmod 600"):
            read_key(key_file(tmp_path, mode))
    for text in ("", "two words", "é"):
        with pytest.raises(KeyFileError, match="one passphrase"):
            read_key(key_file(tmp_path, text=text))
    with pytest.raises(KeyFileError, match="not a regular file"):
        read_key(tmp_path)


def test_key_file_settings_are_refused_at_load_with_the_line(tmp_path):
    mission = str(tmp_path / "m.moos")

    def load(*entries: tuple[str, str]) -> BridgeConfig:
        block = Block("ProcessConfig", "iMAVLink", mission, 3,
                      [Entry(k, v, mission, 4 + i) for i, (k, v) in enumerate(entries)])
        return BridgeConfig.from_block(block)

    key_file(tmp_path)
    cfg = load(("SigningKeyFile", "signing.key"), ("RequireSigning", "true"))
    assert cfg.signing_key_file == str(tmp_path / "signing.key") and cfg.require_signing
    assert PASSPHRASE not in repr(cfg), "the key is never in the config, so never logged"
    os.chmod(tmp_path / "signing.key", 0o644)
    with pytest.raises(MissionError, match=r"m\.moos:4: SigningKeyFile: signing key file .* "
                                           "accessible by group or others"):
        load(("SigningKeyFile", "signing.key"))
    with pytest.raises(MissionError, match=r"m\.moos:4: RequireSigning needs SigningKeyFile"):
        load(("RequireSigning", "true"))
    with pytest.raises(MissionError, match=r"m\.moos:4: AllowedSenders: expected local"):
        load(("AllowedSenders", "255, 999"))


@pytest.fixture
def signed(tmp_path) -> tuple[Companion, Sender, Sender]:
    c = Companion(signing_key_file=str(key_file(tmp_path)), require_signing=True,
                  allowed_senders=(SenderId(255),))
    autopilot, operator = Sender(AUTOPILOT, KEY), Sender(OPERATOR, KEY)
    c.hear(autopilot.heartbeat())
    c.posted()
    return c, autopilot, operator


def test_the_companion_signs_what_it_sends(signed):
    c, autopilot, operator = signed
    written = c.hear(autopilot.heartbeat(), operator.command(mavlink.MAV_CMD_USER_1))
    assert [m.get_type() for m in written] == ["COMMAND_ACK"]
    assert all(m.get_signed() for m in written), "verified with the key by the reader"
    assert c.bridge.state.signed is True


def test_an_unsigned_command_is_refused_when_signing_is_required(signed):
    c, _, _ = signed
    written = c.hear(Sender(OPERATOR).command(mavlink.MAV_CMD_USER_1))
    assert c.acks(written) == [(mavlink.MAV_CMD_USER_1, mavlink.MAV_RESULT_DENIED, 255)]
    assert "not signed" in c.posted()[0][1]


def test_a_replayed_signed_command_is_refused(signed):
    c, _, operator = signed
    packet = operator.command(mavlink.MAV_CMD_USER_1)
    first = c.hear(packet)
    assert c.acks(first) == [(mavlink.MAV_CMD_USER_1, mavlink.MAV_RESULT_ACCEPTED, 255)]
    again = c.hear(packet)
    assert c.acks(again) == [(mavlink.MAV_CMD_USER_1, mavlink.MAV_RESULT_DENIED, 255)]
    assert [n for n, _, _ in c.posted()] == ["RESTART_HELM", "MAVLINK_SENDER_REFUSED"]


def test_a_packet_signed_with_another_key_is_refused(signed):
    c, _, _ = signed
    forger = Sender(OPERATOR, passphrase_key("guess"))
    written = c.hear(forger.command(mavlink.MAV_CMD_USER_1))
    assert c.acks(written) == [(mavlink.MAV_CMD_USER_1, mavlink.MAV_RESULT_DENIED, 255)]


def test_a_forged_packet_from_the_future_does_not_lock_the_operator_out(signed):
    """pymavlink alone would record a forged packet's timestamp before finding its signature
    wrong, and refuse every genuine packet after it as a replay."""
    c, _, operator = signed
    forger = Sender(OPERATOR, passphrase_key("guess"))
    forger.mav.signing.link_id = operator.mav.signing.link_id
    forger.mav.signing.timestamp = operator.mav.signing.timestamp + 10**12
    c.hear(forger.command(mavlink.MAV_CMD_USER_1))
    written = c.hear(operator.command(mavlink.MAV_CMD_USER_1))
    assert c.acks(written) == [(mavlink.MAV_CMD_USER_1, mavlink.MAV_RESULT_ACCEPTED, 255)]


def test_unsigned_telemetry_is_ignored_when_signing_is_required(signed):
    c, _, _ = signed
    c.bus.subscribe("t", {"MAVLINK_WARNING"})
    before = c.bridge.state.last_heartbeat
    c.hear(Sender(AUTOPILOT).heartbeat())
    assert c.bridge.state.last_heartbeat == before and c.bridge.unsigned_ignored == 1
    for _ in range(5):
        c.hear(Sender(AUTOPILOT).heartbeat())
    warnings = [v for n, v, _ in c.posted() if n == "MAVLINK_WARNING"]
    assert len(warnings) == 1, "said once, after a few: SETUP_SIGNING may be on its way"
    assert warnings[0].startswith("the autopilot's packets are not signed: all are ignored")


def test_setup_signing_gives_an_unsigned_autopilot_the_key_once(tmp_path):
    c = Companion(signing_key_file=str(key_file(tmp_path)), setup_signing=True)
    autopilot = Sender(AUTOPILOT)
    written = c.hear(autopilot.heartbeat()) + c.hear(autopilot.heartbeat())
    [setup] = [m for m in written if m.get_type() == "SETUP_SIGNING"]
    assert bytes(setup.secret_key) == KEY and (setup.target_system, setup.target_component) \
        == AUTOPILOT
    assert abs(setup.initial_timestamp - signing_timestamp()) < 10 * 100_000


def test_setup_signing_leaves_an_autopilot_signed_with_another_key_alone(tmp_path):
    c = Companion(signing_key_file=str(key_file(tmp_path)), setup_signing=True)
    written = c.hear(Sender(AUTOPILOT, passphrase_key("the operator's")).heartbeat())
    assert "SETUP_SIGNING" not in [m.get_type() for m in written]
    assert c.bridge.state.signed is False


# -- guests are who their link says ----------------------------------------------------------

def guest_rig(allow: str) -> HelmRig:
    spec = Spec()
    rig = HelmRig(safety(spec), spec, ("Allow", allow))
    rig.tick(HELM_ONLINE=1.0, NAV_X=0.0, NAV_Y=0.0, NAV_HEADING=0.0)  # subscribed, online
    return rig


def ask(rig: HelmRig, text: str, source: str) -> str:
    rig.bus.notify(REQUEST_VARIABLE, text, source)
    out = rig.tick(HELM_ONLINE=1.0, NAV_X=0.0, NAV_Y=0.0, NAV_HEADING=0.0)
    return str(one(out, "THIRDPARTY_REPLY"))


REQUEST = "Sample@iScience:TASK=GoToWayPoint|Location=0,0"


def test_a_guest_bound_to_42_191_cannot_be_impersonated_from_77_191():
    rig = guest_rig("Sample@iScience:GoToWayPoint | From = 42:191 | SessionTimeOut = 5")
    assert ask(rig, REQUEST, mavlink_source(77, 191)) == (
        "Sample@iScience:DENIED:Sample@iScience is bound to 42:191; this request came from "
        "77:191")
    assert ask(rig, "Sample@iScience:CLOSE", mavlink_source(77, 191)).startswith(
        "Sample@iScience:DENIED:Sample@iScience is bound to 42:191")
    assert ask(rig, REQUEST, "uScience").startswith("Sample@iScience:DENIED:"), \
        "nor from the local bus"
    assert ask(rig, REQUEST, mavlink_source(42, 191)).startswith("Sample@iScience:ACCEPTED:")
    assert rig.helm.third_party.bound_senders() == (SenderId(42, 191),)


def test_a_guest_may_be_bound_to_the_local_bus():
    rig = guest_rig("Sample@iScience:GoToWayPoint | From = local")
    assert ":DENIED:" in ask(rig, REQUEST, mavlink_source(42, 191))
    assert ":ACCEPTED:" in ask(rig, REQUEST, "uScience")
    assert rig.helm.third_party.bound_senders() == ()


def test_an_allow_line_without_from_takes_whom_the_bridge_lets_through():
    rig = guest_rig("Sample@iScience:GoToWayPoint")
    assert ":ACCEPTED:" in ask(rig, REQUEST, mavlink_source(255, 190))


@pytest.mark.parametrize(("allow", "reason"), [
    ("Sample@iScience:Timer | From = 42:999", "Allow: From: expected local, SYSTEM"),
    ("Sample@iScience:Timer | From = 42 | From = 43", "Allow: From given twice"),
    ("Sample@iScience:Timer | Owner = 42", "Allow: expected SessionTimeOut = s or From"),
])
def test_from_is_checked_at_load(allow, reason):
    with pytest.raises(MissionError, match=reason):
        guest_rig(allow)


# -- mavhelm check says whether the link is signed and the autopilot agrees -------------------

def test_check_says_whether_the_link_is_signed_and_the_autopilot_agrees(tmp_path):
    from mavhelm.companion.check import signing_line
    from mavhelm.companion.signing import signature

    keyed = BridgeConfig(signing_key_file=str(key_file(tmp_path)))
    required = BridgeConfig(signing_key_file=str(key_file(tmp_path)), require_signing=True)
    assert str(signing_line("valid", keyed)).startswith("  ok  link signed: the autopilot "
                                                        "signs with the companion's key")
    assert signing_line("none", keyed).status == "WARN"
    assert signing_line("none", required).status == "FAIL"
    assert "SetupSigning = true" in signing_line("none", required).text
    assert signing_line("other", keyed).status == "FAIL"
    assert signing_line("other", BridgeConfig()).status == "FAIL"
    assert str(signing_line("none", BridgeConfig())) == (
        "WARN  link not signed: anyone with a radio on its network can command the vehicle "
        "(docs/security.md)")
    reader = mavlink.MAVLink(None)
    reader.robust_parsing = True
    reader.signing.secret_key = KEY
    reader.signing.allow_unsigned_callback = lambda mav, msg_id: True
    heartbeats = [Sender(AUTOPILOT, KEY).heartbeat(), Sender(AUTOPILOT, b"x" * 32).heartbeat(),
                  Sender(AUTOPILOT).heartbeat()]
    assert [signature(reader.parse_char(hb)) for hb in heartbeats] == ["valid", "other", "none"]


def test_mavhelm_remote_shows_the_refusals_from_the_status_channel():
    from mavhelm.companion.remote.state import RemoteState
    from mavhelm.companion.remote.view import render

    s = RemoteState()
    payload = encode(SenderRefused("77:191", "COMMAND_LONG USER_1", "not an allowed sender", 4))
    tunnel = mavlink.MAVLink_tunnel_message(0, 0, 32802, len(payload),
                                            list(payload.ljust(128, b"\0")))
    tunnel._header = mavlink.MAVLink_header(tunnel.id, srcSystem=1, srcComponent=191)
    s.receive(tunnel, 1.0)
    assert s.helm_status.refused == 4
    assert "refused    4 commands from senders not allowed or not signed" in "\n".join(
        render(s, 120))


def test_a_telemetry_log_is_replayed_even_where_the_mission_requires_signing(tmp_path):
    import struct

    from mavhelm.companion.tlog import read_tlog
    from mavhelm.core.mission import parse_mission

    key_file(tmp_path)
    text = ("LatOrigin = 56.4120\nLongOrigin = -5.4760\nProcessConfig = iMAVLink\n{\n"
            "    SigningKeyFile = signing.key\n    RequireSigning = true\n}\n")
    mission = parse_mission(text, str(tmp_path / "m.moos"))
    log = tmp_path / "run.tlog"
    log.write_bytes(struct.pack(">Q", 1_767_225_600_000_000) + Sender(AUTOPILOT).heartbeat())
    replay = read_tlog(log, mission)
    assert "AP_MODE" in [m.name for m in replay.messages]


def test_a_local_control_asks_the_same_check(unsigned):
    c, _, _, _ = unsigned
    bridge = c.bridge
    assert bridge.authorize(LOCAL_BUS, False, "web: all stop", 1.0) is None
    bridge.gate.allowed = (SenderId(255),)
    assert bridge.authorize(LOCAL_BUS, False, "web: all stop", 1.0) == \
        "not an allowed sender (allowed: 255)"
    assert c.posted()[-1][1] == "local|web: all stop|1|not an allowed sender (allowed: 255)"
