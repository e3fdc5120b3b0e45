"""The autopilot link over real loopback sockets: it connects late, reconnects, never blocks,
speaks MAVLink 2, and bounds what a flood costs without losing the newest HEARTBEAT."""

from __future__ import annotations

import contextlib
import socket
import threading
import tracemalloc

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.link import READ_BUDGET, AutopilotLink, TcpTransport, transport_for
from tests.support.ports import free_port


class Autopilot:
    """A loopback TCP server standing in for ArduPilot's port; encodes as system 1/1."""

    def __init__(self, port: int) -> None:
        self.server = socket.socket()
        self.server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.server.bind(("127.0.0.1", port))
        self.server.listen(1)
        self.conn: socket.socket | None = None
        self.mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)

    def accept(self) -> None:
        self.server.settimeout(10)
        self.conn, _ = self.server.accept()

    def frame(self, kind: str, **fields) -> bytes:
        return getattr(self.mav, f"{kind}_encode")(**fields).pack(self.mav)

    def heartbeat(self, custom_mode: int = 15, armed: bool = True) -> bytes:
        return self.frame("heartbeat", type=11, autopilot=3,
                          base_mode=0x89 if armed else 0x09, custom_mode=custom_mode,
                          system_status=4)

    def close(self) -> None:
        if self.conn is not None:
            self.conn.close()
        self.server.close()


def poll_until(link: AutopilotLink, now: float, done, polls: int = 2000):
    got = []
    for _ in range(polls):
        got += link.poll(now)
        if done(got):
            return got
        threading.Event().wait(0.001)
    raise AssertionError(f"not done after {polls} polls; events {link.events}")


def in_thread(fn, seconds: float = 20.0):
    """Run ``fn``; a call that blocks forever fails here instead of hanging the suite."""
    result: list = []
    t = threading.Thread(target=lambda: result.append(fn()), daemon=True)
    t.start()
    t.join(seconds)
    assert not t.is_alive(), "the call blocked"
    return result[0] if result else None


@contextlib.contextmanager
def connected(budget: int = READ_BUDGET):
    """A fake autopilot on a free port and a link already connected to it."""
    port = free_port()
    ap = Autopilot(port)
    link = AutopilotLink(f"tcp:127.0.0.1:{port}", budget=budget)
    try:
        link.poll(0.0)
        ap.accept()
        poll_until(link, 0.0, lambda _got: link.connected)
        yield ap, link, port
    finally:
        ap.close()
        link.close()


def test_urls_pick_their_transport():
    assert isinstance(transport_for("tcp:127.0.0.1:5760", 57600), TcpTransport)
    assert transport_for("udpout:127.0.0.1:14550", 57600).listen is False
    assert transport_for("udp:0.0.0.0:14550", 57600).listen is True
    serial_line = transport_for("/dev/ttyAMA0,921600", 57600)
    assert (serial_line.device, serial_line.baud) == ("/dev/ttyAMA0", 921600)
    with pytest.raises(ValueError, match="expected tcp:HOST:PORT"):
        transport_for("tcp:nohost", 57600)


def test_a_link_started_before_the_autopilot_waits_and_retries_with_backoff():
    port = free_port()
    link = AutopilotLink(f"tcp:127.0.0.1:{port}")
    assert in_thread(lambda: link.poll(0.0)) == []
    assert not link.connected and link.generation == 0
    events = link.take_events()
    assert len(events) == 1 and events[0].startswith(f"waiting for the autopilot at tcp:127.0.0.1:"
                                                     f"{port}: Connection refused")
    attempts = []
    for tenth in range(1, 300):
        now = tenth / 10
        before = link.backoff.next_at
        link.poll(now)
        if link.backoff.next_at != before:
            attempts.append(round(now, 1))
    assert attempts[:5] == [1.0, 3.0, 7.0, 15.0, 23.0], "1 s doubling to 8 s between attempts"
    assert link.take_events() == [], "the same failure is said once, not at every retry"
    ap = Autopilot(port)
    try:
        link.poll(100.0)
        ap.accept()
        poll_until(link, 100.0, lambda _got: link.connected)
        assert link.generation == 1
        assert link.take_events() == [f"link to tcp:127.0.0.1:{port} open (MAVLink 2)"]
    finally:
        ap.close()
        link.close()


def test_frames_sent_are_mavlink_2():
    with connected() as (ap, link, _port):
        link.mav.heartbeat_send(18, 8, 0, 0, 4)
        assert ap.conn is not None
        ap.conn.settimeout(5)
        data = ap.conn.recv(100)
        assert data[0] == 0xFD, "MAVLink 2 magic"
        parsed = mavlink.MAVLink(None).parse_buffer(data)
        assert [m.get_type() for m in parsed] == ["HEARTBEAT"]
        assert (parsed[0].get_srcSystem(), parsed[0].get_srcComponent()) == (1, 191)
        assert link.stats.bytes_written == len(data)


def test_a_dropped_connection_is_reported_and_a_new_one_has_a_new_generation():
    with connected() as (ap, link, port):
        assert ap.conn is not None
        ap.conn.sendall(ap.heartbeat())
        got = poll_until(link, 0.0, lambda got: any(m.get_type() == "HEARTBEAT" for m in got))
        assert link.generation == 1 and got[0].custom_mode == 15
        link.take_events()
        ap.conn.close()
        poll_until(link, 1.0, lambda _got: not link.connected)
        assert link.take_events() == [f"link to tcp:127.0.0.1:{port} lost: the autopilot closed "
                                      "the connection; reconnecting"]
        link.poll(2.5)
        ap.accept()
        poll_until(link, 2.5, lambda _got: link.connected)
        assert link.generation == 2


def test_a_flood_is_bounded_and_the_newest_heartbeat_survives():
    with connected(budget=8192) as (ap, link, _port):
        attitude = ap.frame("attitude", time_boot_ms=1, roll=0.0, pitch=0.0, yaw=1.0,
                            rollspeed=0.0, pitchspeed=0.0, yawspeed=0.0)
        flood = (ap.heartbeat(custom_mode=0) + attitude * 2000 + ap.heartbeat(custom_mode=4)
                 + attitude * 150000)
        assert ap.conn is not None
        sender = threading.Thread(target=ap.conn.sendall, args=(flood,))
        sender.start()
        got = []
        tracemalloc.start()
        while link.stats.bytes_read < len(flood):
            got += in_thread(lambda: link.poll(1.0))
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        sender.join()
        assert peak < 4 * 1024 * 1024, f"reading a 6 MB flood allocated {peak / 1e6:.1f} MB at peak"
        heartbeats = [m.custom_mode for m in got if m.get_type() == "HEARTBEAT"]
        assert heartbeats and heartbeats[-1] == 4, "the newest HEARTBEAT (HOLD) is kept"
        assert link.stats.bytes_dropped > len(flood) // 2
        parsed_attitudes = sum(m.get_type() == "ATTITUDE" for m in got)
        assert parsed_attitudes < 152000 * 0.1, "most of the flood is dropped, not parsed"


def test_only_what_the_reader_reads_is_decoded_and_every_frame_is_recorded():
    """A bridge's link decodes only its messages: RAW_IMU and MEMINFO (ArduPilot's default
    streams) pass as counted, recorded frames; a MAVLink 1 frame and a corrupt one too."""
    from mavhelm.companion.bridge.config import BridgeConfig
    from mavhelm.companion.bridge.handlers import read_messages

    recorded: list[bytes] = []
    with connected() as (ap, link, _port):
        link.recorder = recorded.append
        link.decode_only(read_messages(BridgeConfig()))
        raw_imu = ap.frame("raw_imu", time_usec=1, xacc=1, yacc=2, zacc=3, xgyro=4, ygyro=5,
                           zgyro=6, xmag=7, ymag=8, zmag=9)
        corrupt = bytearray(ap.frame("meminfo", brkval=1, freemem=2))
        corrupt[-1] ^= 0xFF
        v1 = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        v1.WIRE_PROTOCOL_VERSION = "1.0"
        v1_ahrs = v1.ahrs_encode(0, 0, 0, 0, 0, 0, 0).pack(v1, force_mavlink1=True)
        sys_status = ap.frame("sys_status", onboard_control_sensors_present=0,
                              onboard_control_sensors_enabled=0,
                              onboard_control_sensors_health=0, load=0, voltage_battery=0,
                              current_battery=0, battery_remaining=0, drop_rate_comm=0,
                              errors_comm=0, errors_count1=0, errors_count2=0,
                              errors_count3=0, errors_count4=0)
        assert ap.conn is not None
        ap.conn.sendall(raw_imu + ap.heartbeat() + bytes(corrupt) + v1_ahrs + sys_status)
        got = poll_until(link, 0.0, lambda got: len(got) >= 2)
    assert [m.get_type() for m in got] == ["HEARTBEAT", "SYS_STATUS"], "SYS_STATUS: a stream"
    assert link.stats.skimmed == 3
    assert len(recorded) == 5 and recorded[0] == raw_imu and recorded[2] == bytes(corrupt)


def test_a_link_told_nothing_decodes_everything():
    with connected() as (ap, link, _port):
        raw_imu = ap.frame("raw_imu", time_usec=1, xacc=1, yacc=2, zacc=3, xgyro=4, ygyro=5,
                           zgyro=6, xmag=7, ymag=8, zmag=9)
        assert ap.conn is not None
        ap.conn.sendall(raw_imu)
        got = poll_until(link, 0.0, lambda got: len(got) >= 1)
    assert got[0].get_type() == "RAW_IMU" and got[0].zgyro == 6 and link.stats.skimmed == 0
