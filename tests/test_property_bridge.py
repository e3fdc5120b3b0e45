"""Property tests of the MAVLink bridge against a hostile link.

The bridge talks to ``FakeMavfile``, an in-memory stand-in for a pymavlink mavfile: ``recv(n)``
hands out queued bytes (whatever hypothesis made of them), and ``mav`` is a real ardupilotmega
``MAVLink`` object, robust-parsing like mavutil's, whose writes are captured, so what the bridge
sends is real encoded MAVLink and is read back here with a fresh parser.

(a) random bytes, damaged frames and valid frames with any field values never make ``receive``
    or ``send`` raise;
(b) everything written parses back, and every SET_ATTITUDE_TARGET carries a finite yaw rate
    within ±MaxTurnRate and a finite thrust within [-1, 1];
(c) SET_ATTITUDE_TARGET goes out only in a tick where the bridge was online, and on a clean link
    ``online`` is exactly "HEARTBEAT from 1/1 within LinkTimeOut, armed, in an OnlineMode";
(d) a DESIRED_RUDDER / DESIRED_THRUST that is not finite or not within ±MAXRUDDER / ±100 goes
    out as exactly 0 and is reported on MAVLINK_OUTPUT_REFUSED; a good one goes out as given.
"""

from __future__ import annotations

import math
import struct
from collections import deque
from dataclasses import dataclass, field

from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.actuation import ATTITUDE_RATE_AND_THRUST, rudder_to_turn_rate
from mavhelm.companion.bridge import (
    ROVER_MODE_NUMBERS,
    ROVER_MODES,
    BridgeConfig,
    MavlinkBridge,
)
from mavhelm.companion.link import AutopilotLink
from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock
from mavhelm.core.geodesy import Origin

ORIGIN = Origin(56.412, -5.476)
AUTOPILOT = (1, 1)
COMPANION = (1, mavlink.MAV_COMP_ID_ONBOARD_COMPUTER)
GUIDED = ROVER_MODE_NUMBERS["GUIDED"]
CUSTOM = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
ARMED = mavlink.MAV_MODE_FLAG_SAFETY_ARMED | CUSTOM
ROVER = mavlink.MAV_TYPE_GROUND_ROVER
ARDUPILOT = mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA
DESIRED = ("DESIRED_RUDDER", "DESIRED_THRUST")

SETTINGS = settings(max_examples=60, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def f32(value: float) -> float:
    """What a float32 field on the wire makes of a double."""
    return struct.unpack("<f", struct.pack("<f", value))[0]


# -- the stand-in link --------------------------------------------------------------------------


class FakeTransport:
    """The byte pipe under the bridge's AutopilotLink: bytes in from ``incoming``, bytes out
    into ``written``; ``fail_next_read`` makes the next read fail as a reset connection."""

    def __init__(self) -> None:
        self.written = bytearray()
        self.incoming: deque[bytes] = deque()
        self.fail_next_read = False
        self.closed = False
        self.opens = 0

    def open(self) -> None:
        self.opens += 1
        self.closed = False

    def ready(self) -> bool:
        return not self.closed

    def write(self, data: bytes) -> int:
        self.written += data
        return len(data)

    def read_into(self, buffer: memoryview) -> int:
        if self.fail_next_read:
            self.fail_next_read = False
            self.incoming.clear()  # what was in flight on a reset connection is gone
            raise ConnectionResetError(104, "connection reset by peer")
        if not self.incoming:
            return 0
        chunk = self.incoming.popleft()
        if len(chunk) > len(buffer):
            self.incoming.appendleft(chunk[len(buffer):])
            chunk = chunk[:len(buffer)]
        buffer[:len(chunk)] = chunk
        return len(chunk)

    def close(self) -> None:
        self.closed = True

    def fileno(self) -> int | None:
        return None


def decode_all(data: bytes | bytearray) -> list[mavlink.MAVLink_message]:
    """Every message in ``data``, read with a fresh parser; fails on any byte that is not part
    of a well-formed frame."""
    parser = mavlink.MAVLink(None)
    parser.robust_parsing = True
    messages = parser.parse_buffer(bytes(data)) or []
    bad = [m for m in messages if m.get_type() == "BAD_DATA"]
    assert not bad, f"the bridge wrote bytes that do not parse: {bad}"
    leftover = bytes(parser.buf[parser.buf_index:])
    assert not leftover, f"the bridge wrote a partial frame: {leftover!r}"
    return messages


@dataclass
class TickResult:
    online: bool
    written_by_receive: list[mavlink.MAVLink_message]
    written_by_send: list[mavlink.MAVLink_message]
    refused: list[Message] = field(default_factory=list)

    def targets(self) -> list[mavlink.MAVLink_message]:
        return [m for m in self.written_by_send if m.get_type() == "SET_ATTITUDE_TARGET"]


class Rig:
    def __init__(self, start: float = 1000.0, config: BridgeConfig | None = None) -> None:
        self.clock = SimClock(start)
        self.bus = Bus(self.clock)
        self.bus.subscribe("t", {"MAVLINK_OUTPUT_REFUSED"})
        self.config = config or BridgeConfig()
        self.conn = FakeTransport()
        link = AutopilotLink("tcp:127.0.0.1:5760", transport=self.conn)
        self.bridge = MavlinkBridge(self.bus, self.config, ORIGIN, link=link)
        self.encoder = mavlink.MAVLink(None)

    def frame(self, msg: mavlink.MAVLink_message, source: tuple[int, int] = AUTOPILOT,
              v1: bool = False) -> bytes:
        self.encoder.srcSystem, self.encoder.srcComponent = source
        data = bytes(msg.pack(self.encoder, force_mavlink1=v1))
        self.encoder.seq = (self.encoder.seq + 1) % 256
        return data

    def tick(self, now: float, chunks=(), mail=(), recv_error: bool = False) -> TickResult:
        self.clock.set(now)
        self.conn.incoming.extend(bytes(c) for c in chunks if c)
        self.conn.fail_next_read = recv_error
        mark = len(self.conn.written)
        self.bridge.receive(now)
        by_receive = decode_all(self.conn.written[mark:])
        online = self.bridge.online
        mark = len(self.conn.written)
        self.bridge.send(list(mail), now)
        by_send = decode_all(self.conn.written[mark:])
        return TickResult(online, by_receive, by_send, self.bus.fetch("t"))


def check_written(result: TickResult, config: BridgeConfig) -> None:
    """(b) and (c) for one tick's output."""
    yaw_limit = f32(math.radians(config.max_turn_rate))
    assert all(m.get_type() != "SET_ATTITUDE_TARGET" for m in result.written_by_receive)
    for msg in result.written_by_receive + result.written_by_send:
        assert (msg.get_srcSystem(), msg.get_srcComponent()) == COMPANION
        assert msg.get_type() in {"HEARTBEAT", "COMMAND_LONG", "SET_ATTITUDE_TARGET",
                                  "NAMED_VALUE_FLOAT",
                                  "PARAM_REQUEST_READ"}  # MAV_GCS_SYSID: who may command
        if msg.get_type() == "NAMED_VALUE_FLOAT":
            assert math.isfinite(msg.value)
    for msg in result.targets():
        assert result.online, "SET_ATTITUDE_TARGET written while the helm was offline"
        assert (msg.target_system, msg.target_component) == AUTOPILOT
        assert msg.type_mask == ATTITUDE_RATE_AND_THRUST
        assert math.isfinite(msg.body_yaw_rate) and abs(msg.body_yaw_rate) <= yaw_limit
        assert math.isfinite(msg.thrust) and -1.0 <= msg.thrust <= 1.0
        assert msg.body_roll_rate == msg.body_pitch_rate == 0.0
        assert list(msg.q) == [1.0, 0.0, 0.0, 0.0]
    assert len(result.targets()) <= 1


# -- strategies ---------------------------------------------------------------------------------

u8 = st.integers(0, 0xFF)
u16 = st.integers(0, 0xFFFF)
u32 = st.integers(0, 0xFFFF_FFFF)
u64 = st.integers(0, 2**64 - 1)
i16 = st.integers(-(2**15), 2**15 - 1)
i32 = st.integers(-(2**31), 2**31 - 1)
f32s = st.floats(width=32)  # nan, ±inf, ±0, subnormals, ±3.4e38 all included
I32_EDGES = [0, 1, -1, 2**31 - 1, -(2**31), 900_000_000, -900_000_000, 900_000_001,
             1_800_000_000, -1_800_000_001]
lat_e7 = st.one_of(st.integers(-900_000_000, 900_000_000), st.sampled_from(I32_EDGES), i32)
lon_e7 = st.one_of(st.integers(-1_800_000_000, 1_800_000_000), st.sampled_from(I32_EDGES), i32)

heartbeats = st.builds(
    mavlink.MAVLink_heartbeat_message,
    type=st.one_of(st.sampled_from([ROVER, mavlink.MAV_TYPE_SURFACE_BOAT,
                                    mavlink.MAV_TYPE_GCS]), u8),
    autopilot=st.one_of(st.sampled_from([ARDUPILOT, mavlink.MAV_AUTOPILOT_INVALID]), u8),
    base_mode=st.one_of(st.sampled_from([0, CUSTOM, ARMED]), u8),
    custom_mode=st.one_of(st.sampled_from(sorted(ROVER_MODES)), u32),
    system_status=u8, mavlink_version=u8)

autopilot_heartbeats = st.builds(
    mavlink.MAVLink_heartbeat_message,
    type=st.just(ROVER), autopilot=st.just(ARDUPILOT),
    base_mode=st.sampled_from([ARMED, ARMED, CUSTOM]),
    custom_mode=st.sampled_from([GUIDED, GUIDED, ROVER_MODE_NUMBERS["HOLD"],
                                 ROVER_MODE_NUMBERS["MANUAL"], ROVER_MODE_NUMBERS["AUTO"]]),
    system_status=st.just(mavlink.MAV_STATE_ACTIVE), mavlink_version=st.just(3))
"""Heartbeats a real autopilot sends: switching between online and offline."""

gps_raw_ints = st.builds(
    mavlink.MAVLink_gps_raw_int_message,
    time_usec=u64, fix_type=st.one_of(st.sampled_from([0, 1, 2, 3, 4, 6]), u8),
    lat=lat_e7, lon=lon_e7, alt=i32, eph=u16, epv=u16,
    vel=st.one_of(st.just(0xFFFF), u16), cog=st.one_of(st.just(0xFFFF), u16),
    satellites_visible=u8, alt_ellipsoid=i32, h_acc=u32, v_acc=u32, vel_acc=u32, hdg_acc=u32,
    yaw=u16)

attitudes = st.builds(
    mavlink.MAVLink_attitude_message,
    time_boot_ms=u32, roll=f32s, pitch=f32s, yaw=f32s, rollspeed=f32s, pitchspeed=f32s,
    yawspeed=f32s)

global_position_ints = st.builds(
    mavlink.MAVLink_global_position_int_message,
    time_boot_ms=u32, lat=lat_e7, lon=lon_e7, alt=i32, relative_alt=i32, vx=i16, vy=i16,
    vz=i16, hdg=st.one_of(st.just(0xFFFF), u16))

command_acks = st.builds(
    mavlink.MAVLink_command_ack_message,
    command=st.one_of(st.just(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL), u16),
    result=st.one_of(st.just(mavlink.MAV_RESULT_ACCEPTED), u8), progress=u8,
    result_param2=i32, target_system=u8, target_component=u8)

statustexts = st.builds(
    mavlink.MAVLink_statustext_message,
    severity=u8, text=st.binary(max_size=50), id=u16, chunk_seq=u8)

ekf_status_reports = st.builds(
    mavlink.MAVLink_ekf_status_report_message,
    flags=st.one_of(st.sampled_from([0, mavlink.EKF_POS_HORIZ_ABS, 0x3FF]), u16),
    velocity_variance=f32s, pos_horiz_variance=f32s, pos_vert_variance=f32s,
    compass_variance=f32s, terrain_alt_variance=f32s, airspeed_variance=f32s)

messages = st.one_of(heartbeats, autopilot_heartbeats, gps_raw_ints, attitudes,
                     global_position_ints, command_acks, statustexts, ekf_status_reports)
sources = st.one_of(st.just(AUTOPILOT), st.tuples(u8, u8))


@st.composite
def frames(draw, message_strategy=messages, source_strategy=sources) -> bytes:
    """One message encoded as MAVLink 1 or 2 (any sequence number), from any system."""
    msg = draw(message_strategy)
    encoder = mavlink.MAVLink(None, *draw(source_strategy))
    encoder.seq = draw(u8)
    return bytes(msg.pack(encoder, force_mavlink1=draw(st.booleans())))


@st.composite
def damaged_frames(draw) -> bytes:
    frame = bytearray(draw(frames()))
    how = draw(st.sampled_from(["truncate", "flip", "both", "lengthen"]))
    if how in ("truncate", "both"):
        del frame[draw(st.integers(0, len(frame) - 1)):]
    if how in ("flip", "both") and frame:
        i = draw(st.integers(0, len(frame) - 1))
        frame[i] ^= 1 << draw(st.integers(0, 7))
    if how == "lengthen":  # a length byte that promises more than is there
        frame[1] = draw(u8)
    return bytes(frame)


noise = st.one_of(
    st.binary(max_size=300),
    st.lists(st.sampled_from([0xFD, 0xFE, 0x00, 0xFF, 0x01, 0x09]), max_size=40).map(bytes),
)
segments = st.one_of(frames(), frames(autopilot_heartbeats, st.just(AUTOPILOT)),
                     damaged_frames(), noise)

mail_values = st.one_of(st.floats(), st.sampled_from([20.0, -20.0, 100.0, -100.0, 1e308]),
                        st.text(max_size=5))
mail = st.lists(st.builds(Message, name=st.sampled_from([*DESIRED, "DESIRED_ELEVATOR"]),
                          value=mail_values, time=st.just(0.0), source=st.just("pHelm")),
                max_size=4)


@st.composite
def ticks(draw, segment_strategy=segments, max_dt: float = 4.0):
    """(dt, chunks as recv returns them, mail, whether recv raises) for one tick."""
    data = b"".join(draw(st.lists(segment_strategy, max_size=6)))
    piece = draw(st.integers(1, 600))
    chunks = [data[i:i + piece] for i in range(0, len(data), piece)]
    return (draw(st.floats(0.0, max_dt)), chunks, draw(mail),
            draw(st.booleans()) and draw(st.booleans()) and draw(st.booleans()))


# -- (a), (b), (c): a hostile link --------------------------------------------------------------


@SETTINGS
@given(start=st.sampled_from([0.0, 1000.0, 1.7e9]), script=st.lists(ticks(), max_size=8))
def test_any_bytes_never_raise_and_output_is_always_safe(start, script):
    rig = Rig(start)
    now = start
    for dt, chunks, tick_mail, recv_error in script:
        now += dt
        result = rig.tick(now, chunks, tick_mail, recv_error)
        check_written(result, rig.config)
    rig.bridge.close()
    assert rig.conn.closed


# (c) with a model: on a clean link, online is exactly what the spec says.

clean_segments = st.one_of(frames(), frames(autopilot_heartbeats, st.just(AUTOPILOT)))


class OnlineModel:
    """HEARTBEAT from the autopilot (1/1, not a GCS, not MAV_AUTOPILOT_INVALID) within
    LinkTimeOut, armed, and in one of OnlineModes."""

    def __init__(self, config: BridgeConfig) -> None:
        self.config = config
        self.heard: float | None = None
        self.armed = False
        self.mode: str | None = None

    def hear(self, msg: mavlink.MAVLink_message, now: float) -> None:
        if (msg.get_type() == "HEARTBEAT"
                and (msg.get_srcSystem(), msg.get_srcComponent()) == AUTOPILOT
                and msg.type != mavlink.MAV_TYPE_GCS
                and msg.autopilot != mavlink.MAV_AUTOPILOT_INVALID):
            self.heard = now
            self.armed = bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            self.mode = ROVER_MODES.get(msg.custom_mode)

    def online(self, now: float) -> bool:
        return (self.heard is not None and now - self.heard <= self.config.link_timeout
                and self.armed and self.mode in self.config.online_modes)


@SETTINGS
@given(script=st.lists(ticks(clean_segments), min_size=1, max_size=10))
def test_online_is_exactly_link_armed_and_mode_on_a_clean_link(script):
    rig = Rig(1000.0)
    model = OnlineModel(rig.config)
    now = 1000.0
    for dt, chunks, tick_mail, _ in script:
        now += dt
        for msg in decode_all(b"".join(chunks)):
            model.hear(msg, now)
        result = rig.tick(now, chunks, tick_mail)
        check_written(result, rig.config)
        assert result.online == model.online(now)
        wants = any(m.name in DESIRED and m.is_double for m in tick_mail)
        assert len(result.targets()) == (1 if result.online and wants else 0)


@SETTINGS
@given(garbage=st.lists(st.one_of(noise, damaged_frames()), min_size=1, max_size=8))
def test_the_link_comes_up_after_any_garbage(garbage):
    """Damaged bytes never wedge the parser: a steady stream of good HEARTBEATs after them
    brings the helm online."""
    rig = Rig(1000.0)
    rig.tick(1000.0, garbage)
    heartbeat = mavlink.MAVLink_heartbeat_message(ROVER, ARDUPILOT, ARMED, GUIDED, 4, 3)
    for i in range(1, 31):
        result = rig.tick(1000.0 + 0.1 * i, [rig.frame(heartbeat)])
    assert result.online


# (e) a position is read only from a latitude and longitude that exist. pymap3d does not check:
# GPS_RAW_INT with lat = 214.7° used to come out as GPS_X = -2565 km, and the navigator takes it.

POSITIONS = ("GPS_X", "GPS_Y", "AP_X", "AP_Y")


@SETTINGS
@given(msg=st.one_of(gps_raw_ints, global_position_ints), v1=st.booleans())
@example(msg=mavlink.MAVLink_gps_raw_int_message(0, 3, 2**31 - 1, -(2**31), 0, 0, 0, 0, 0, 0),
         v1=False)
@example(msg=mavlink.MAVLink_global_position_int_message(0, 900_000_001, 0, 0, 0, 0, 0, 0, 0),
         v1=False)
@example(msg=mavlink.MAVLink_gps_raw_int_message(0, 3, 900_000_000, 1_800_000_000, 0, 0, 0,
                                                 0, 0, 0), v1=False)
def test_positions_come_only_from_coordinates_on_the_earth(msg, v1):
    rig = Rig(1000.0)
    rig.bus.subscribe("p", set(POSITIONS) | {"MAVLINK_ERROR"})
    rig.tick(1000.0, [rig.frame(msg, v1=v1)])
    posted = rig.bus.fetch("p")
    positions = [m for m in posted if m.name in POSITIONS]
    fixed = msg.get_type() == "GLOBAL_POSITION_INT" or msg.fix_type >= 3
    null_island = msg.get_type() == "GLOBAL_POSITION_INT" and msg.lat == 0 and msg.lon == 0
    if abs(msg.lat) <= 900_000_000 and abs(msg.lon) <= 1_800_000_000:  # 1e-7 degrees
        assert len(positions) == (2 if fixed and not null_island else 0)
        assert all(math.isfinite(m.value) for m in positions)
    else:
        assert positions == []
        if fixed:
            assert rig.bridge.bad_packets == 1
            assert any(m.name == "MAVLINK_ERROR" for m in posted)


# -- (d): what the helm asks for, and what goes on the wire ---------------------------------------

GOOD_HEARTBEAT = mavlink.MAVLink_heartbeat_message(ROVER, ARDUPILOT, ARMED, GUIDED,
                                                    mavlink.MAV_STATE_ACTIVE, 3)
demands = st.one_of(
    st.floats(),  # nan, ±inf, ±1.8e308, subnormals
    st.floats(-150.0, 150.0),
    st.sampled_from([0.0, -0.0, 20.0, -20.0, 20.000000000000004, 100.0, -100.0,
                     100.00000000000001, 5e-324, math.nan, math.inf, -math.inf, 1e308]),
)


def expected(value: float, limit: float) -> tuple[float, bool]:
    """(what the bridge must use, whether it must refuse)."""
    if math.isfinite(value) and abs(value) <= limit:
        return value, False
    return 0.0, True


configs = st.builds(BridgeConfig, max_turn_rate=st.one_of(st.just(45.0), st.floats(0.0, 360.0,
                                                                                exclude_min=True)),
                   max_rudder=st.one_of(st.just(20.0), st.floats(1.0, 90.0)))


@SETTINGS
@given(config=configs,
       pairs=st.lists(st.tuples(st.one_of(st.none(), demands), st.one_of(st.none(), demands)),
                      min_size=1, max_size=10))
@example(config=BridgeConfig(),
         pairs=[(math.nan, math.inf), (1e308, -1e308), (20.0, 100.0), (-20.0, -100.0),
                (20.000000000000004, 100.00000000000001), (None, 50.0), (5.0, None)])
def test_demands_on_the_wire_are_finite_in_range_and_refused_when_bad(config, pairs):
    rig = Rig(1000.0, config)
    cfg = rig.config
    assert rig.tick(1000.0, [rig.frame(GOOD_HEARTBEAT)]).online
    for i, (rudder, thrust) in enumerate(pairs, start=1):
        now = 1000.0 + 0.1 * i
        tick_mail = [Message(name, value, now, "pHelm")
                     for name, value in zip(DESIRED, (rudder, thrust), strict=True)
                     if value is not None]
        result = rig.tick(now, [rig.frame(GOOD_HEARTBEAT)], tick_mail)
        assert result.online
        check_written(result, cfg)
        if not tick_mail:
            assert result.targets() == [] and result.refused == []
            continue
        [target] = result.targets()
        want_rudder, bad_rudder = expected(0.0 if rudder is None else rudder, cfg.max_rudder)
        want_thrust, bad_thrust = expected(0.0 if thrust is None else thrust, 100.0)
        want_yaw_rate = math.radians(rudder_to_turn_rate(want_rudder, cfg.max_rudder,
                                                         cfg.max_turn_rate))
        assert target.body_yaw_rate == f32(want_yaw_rate)
        assert target.thrust == f32(want_thrust / 100.0)
        if bad_rudder:
            assert target.body_yaw_rate == 0.0
        if bad_thrust:
            assert target.thrust == 0.0
        refused = [m.string for m in result.refused]
        assert len(refused) == bad_rudder + bad_thrust, refused
        assert any(s.startswith("DESIRED_RUDDER=") for s in refused) == bad_rudder
        assert any(s.startswith("DESIRED_THRUST=") for s in refused) == bad_thrust
        assert all(m.source == "iMAVLinkOut" for m in result.refused)
        posted_rate = rig.bus.latest("AP_CMD_YAW_RATE")
        posted_thrust = rig.bus.latest("AP_CMD_THRUST")
        assert posted_rate.value == want_yaw_rate and posted_rate.time == now
        assert posted_thrust.value == want_thrust / 100.0 and posted_thrust.time == now


@SETTINGS
@given(pairs=st.lists(st.tuples(demands, demands), min_size=1, max_size=5))
def test_nothing_is_sent_while_offline_whatever_is_asked(pairs):
    rig = Rig(1000.0)
    hold = mavlink.MAVLink_heartbeat_message(ROVER, ARDUPILOT, ARMED, ROVER_MODE_NUMBERS["HOLD"],
                                             mavlink.MAV_STATE_ACTIVE, 3)
    for i, (rudder, thrust) in enumerate(pairs):
        now = 1000.0 + 0.1 * i
        tick_mail = [Message("DESIRED_RUDDER", rudder, now, "pHelm"),
                     Message("DESIRED_THRUST", thrust, now, "pHelm")]
        result = rig.tick(now, [rig.frame(hold)], tick_mail)
        assert not result.online and result.targets() == [] and result.refused == []


# -- the rig itself -----------------------------------------------------------------------------


def test_the_rig_sees_real_mavlink_both_ways():
    """Not vacuous: through FakeTransport the bridge goes online, requests its streams, sends its
    heartbeat and a SET_ATTITUDE_TARGET that a fresh parser reads back."""
    rig = Rig(1000.0)
    mail_now = [Message("DESIRED_RUDDER", 10.0, 1000.0, "pHelm"),
                Message("DESIRED_THRUST", 50.0, 1000.0, "pHelm")]
    result = rig.tick(1000.0, [rig.frame(GOOD_HEARTBEAT)], mail_now)
    assert result.online and rig.bridge.link_up and rig.bridge.mode == "GUIDED"
    assert {m.get_type() for m in result.written_by_receive} == {
        "COMMAND_LONG", "PARAM_REQUEST_READ"}  # streams; MAV_GCS_SYSID (who may command)
    assert [m.get_type() for m in result.written_by_send] == [
        "SET_ATTITUDE_TARGET", "HEARTBEAT", "NAMED_VALUE_FLOAT", "NAMED_VALUE_FLOAT"]
    assert [(m.name, m.value) for m in result.written_by_send[2:4]] == [
        ("DES_RUDDER", 10.0), ("DES_THRUST", 50.0)]
    [target] = result.targets()
    assert target.body_yaw_rate == f32(math.radians(45.0))  # 10 of MAXRUDDER 20 × MaxTurnRate 90
    assert target.thrust == 0.5
    # a read error drops the connection: offline, said once, and back only with a new
    # connection and a fresh HEARTBEAT on it
    rig = Rig(1000.0)
    assert not rig.tick(1000.0, [rig.frame(GOOD_HEARTBEAT)], recv_error=True).online
    assert rig.bus.latest("MAVLINK_LINK").value == ("link to tcp:127.0.0.1:5760 lost: "
                                                    "connection reset by peer; reconnecting")
    assert not rig.tick(1000.1).online and rig.conn.opens == 1, "retried after 1 s, not at once"
    assert not rig.tick(1001.1).online and rig.conn.opens == 2
    assert rig.tick(1001.2, [rig.frame(GOOD_HEARTBEAT)]).online
    # and a frame that arrives a byte at a time lands
    rig = Rig(1000.0)
    assert rig.tick(1000.0, [bytes([b]) for b in rig.frame(GOOD_HEARTBEAT)]).online


def test_named_value_rate_sets_how_often_the_helms_view_goes_to_the_ground_station():
    """``NamedValueRate`` (Hz): 5 gives five NAMED_VALUE_FLOAT sets a second, 0 none, and the
    mission refuses a rate out of its declared range with the line."""
    from mavhelm.core.mission import MissionError, parse_mission

    def config(text: str) -> BridgeConfig:
        mission = parse_mission(f"ProcessConfig = iMAVLink\n{{\n{text}\n}}\n", "m.moos")
        return BridgeConfig.from_block(mission.process("iMAVLink"))

    def sets_per_second(rate_line: str) -> int:
        rig = Rig(1000.0, config(rate_line))
        sent = 0
        for i in range(20):  # two seconds at 10 Hz
            now = 1000.0 + 0.1 * i
            mail = [Message("DESIRED_RUDDER", 1.0, now, "pHelm")]
            result = rig.tick(now, [rig.frame(GOOD_HEARTBEAT)], mail)
            sent += sum(m.get_type() == "NAMED_VALUE_FLOAT" and m.name == "DES_RUDDER"
                        for m in result.written_by_send)
        return sent // 2

    assert sets_per_second("") == 1
    assert sets_per_second("NamedValueRate = 5") == 5
    assert sets_per_second("NamedValueRate = 0") == 0
    for bad in ("11", "-1", "nan"):
        try:
            config(f"NamedValueRate = {bad}")
        except MissionError as exc:
            assert str(exc).startswith("m.moos:3:") and "NamedValueRate" in str(exc)
        else:
            raise AssertionError(f"NamedValueRate = {bad} accepted")
