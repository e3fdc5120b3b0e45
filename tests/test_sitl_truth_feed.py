"""The serial instruments driven by another simulator's ground truth (``mavhelm instruments``).

Unit tests feed ``TruthFeed`` real MAVLink bytes (encoded and parsed by pymavlink); the runner
is tested against a MAVLink server on a real socket with real ptys read by pyserial; the last
test runs the command beside the real ArduPilot SITL and checks what the ptys say against the
SITL's own SIMSTATE.
"""

from __future__ import annotations

import math
import os
import re
import select
import signal
import socket
import subprocess
import sys
import time

import pytest
import serial
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.core.clock import AutopilotClock
from mavhelm.sitl.faults import Scenario
from mavhelm.sitl.flat_earth import Origin
from mavhelm.sitl.instruments_runner import (
    PREFIX,
    InstrumentsRunner,
    TruthLink,
    parse_origin,
    parse_truth,
)
from mavhelm.sitl.runner import make_sensor_ports
from mavhelm.sitl.serial_sensors import Beacon, HeadingSensor, NmeaGps, RadioRanges, SensorPort
from mavhelm.sitl.truth_feed import BootTimeScenario, TruthFeed, heading_of_yaw, stream_requests
from tests.support.nmea_read import read_sentence

ORIGIN = Origin(56.4120, -5.4760)
AUTOPILOT = (1, 1)


def wire(*msgs: mavlink.MAVLink_message, src: tuple[int, int] = AUTOPILOT) -> list:
    """The messages as they arrive: encoded by one pymavlink, parsed by another."""
    tx = mavlink.MAVLink(None, srcSystem=src[0], srcComponent=src[1])
    data = b"".join(m.pack(tx) for m in msgs)
    return mavlink.MAVLink(None).parse_buffer(data) or []


def heartbeat() -> mavlink.MAVLink_message:
    return mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_SURFACE_BOAT,
                                             mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 0x41, 0, 4, 3)


def system_time(boot_ms: int, unix_us: int = 0) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_system_time_message(unix_us, boot_ms)


def simstate(x: float, y: float, yaw: float, zgyro: float = 0.0,
             origin: Origin = ORIGIN) -> mavlink.MAVLink_message:
    lat, lon = origin.to_global(x, y)
    return mavlink.MAVLink_simstate_message(0.01, -0.02, yaw, 0.0, 0.0, -9.8, 0.0, 0.0, zgyro,
                                            round(lat * 1e7), round(lon * 1e7))


def sim_state(vn: float, ve: float) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_sim_state_message(1, 0, 0, 0, 0, 0, 0, 0, 0, -9.8, 0, 0, 0,
                                             5.64e8, -5.5e7, 0, 0, 0, vn, ve, 0)


def feed_all(feed: TruthFeed, msgs: list) -> list:
    return [t for m in msgs if (t := feed.feed(m)) is not None]


def burst(boot_ms: int, x: float, y: float, yaw: float, *, vel: tuple[float, float] | None = None,
          unix_us: int = 0) -> list:
    """One burst as ArduPilot sends it at a shared interval: SYSTEM_TIME, SIMSTATE, SIM_STATE."""
    msgs = [system_time(boot_ms, unix_us), simstate(x, y, yaw)]
    if vel is not None:
        msgs.append(sim_state(*vel))
    return wire(*msgs)


# -- conversion ------------------------------------------------------------------------------

def test_simstate_becomes_truth_in_the_local_frame_at_the_autopilots_time() -> None:
    feed = TruthFeed(ORIGIN, offset=1000.0, water_depth=12.0)
    msgs = wire(heartbeat(), system_time(12_340),
                simstate(30.0, -40.0, -math.pi / 2, zgyro=math.radians(5.0)))
    [truth] = feed_all(feed, msgs)
    assert truth.t == pytest.approx(1012.34)
    assert (truth.x, truth.y) == (pytest.approx(30.0, abs=0.02), pytest.approx(-40.0, abs=0.02))
    assert truth.heading == pytest.approx(270.0)
    assert truth.yaw_rate == pytest.approx(5.0, abs=1e-4)
    assert truth.roll == pytest.approx(math.degrees(0.01), abs=1e-4)
    assert truth.pitch == pytest.approx(math.degrees(-0.02), abs=1e-4)
    assert truth.water_depth == 12.0 and truth.z == 0.0
    assert heading_of_yaw(math.pi) == pytest.approx(180.0)
    assert heading_of_yaw(-1e-9) < 360.0


def test_nothing_before_the_autopilots_heartbeat_and_first_time_stamp() -> None:
    feed = TruthFeed(ORIGIN, offset=0.0)
    assert feed_all(feed, wire(system_time(1000), simstate(0, 0, 0))) == []  # who is it?
    assert feed_all(feed, wire(heartbeat(), simstate(0, 0, 0))) == []        # when is it?
    assert len(feed_all(feed, wire(system_time(1100), simstate(0, 0, 0)))) == 1


def test_other_systems_neither_move_the_clock_nor_the_truth() -> None:
    feed = TruthFeed(ORIGIN, offset=0.0)
    gcs = mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID,
                                            0, 0, 4, 3)
    feed_all(feed, wire(gcs, src=(255, 190)))
    assert feed.autopilot is None                      # a ground station is not the autopilot
    feed_all(feed, wire(heartbeat(), system_time(5000)))
    assert feed.autopilot == AUTOPILOT
    target = mavlink.MAVLink_set_attitude_target_message(999_999, 1, 1, 0x03, [1, 0, 0, 0],
                                                         0, 0, 0.1, 0.5)
    stray = simstate(500.0, 500.0, 0.0)
    assert feed_all(feed, wire(target, stray, src=(1, 191))) == []   # the companion's
    [truth] = feed_all(feed, wire(simstate(1.0, 2.0, 0.0)))
    assert truth.t == pytest.approx(5.0) and truth.x == pytest.approx(1.0, abs=0.02)


def test_same_time_base_as_the_companions_autopilot_clock() -> None:
    """Both put the wall clock's Unix time on the first autopilot stamp and then count
    autopilot seconds: a companion that starts at the same moment reads the same times."""
    unix = [1_800_000_000.0]
    mono = [100.0]
    clock = AutopilotClock(wall=lambda: mono[0], epoch=unix[0])
    feed = TruthFeed(ORIGIN, wall=lambda: unix[0])
    feed_all(feed, wire(heartbeat()))
    for boot_ms, dt in ((4_000, 0.0), (9_000, 0.5), (60_000, 5.1)):   # a 10x faster autopilot
        mono[0] += dt
        unix[0] += dt
        clock.observe(boot_ms / 1000.0)
        [truth] = feed_all(feed, burst(boot_ms, 0.0, 0.0, 0.0))
        assert truth.t == pytest.approx(clock.now(), abs=1e-6)
    assert truth.t == pytest.approx(1_800_000_000.0 + 56.0)   # autopilot seconds, not wall


def test_a_rebooted_autopilot_keeps_the_time_running_forwards() -> None:
    feed = TruthFeed(ORIGIN, offset=100.0)
    feed_all(feed, wire(heartbeat()))
    [a] = feed_all(feed, burst(50_000, 0, 0, 0))
    [b] = feed_all(feed, burst(49_900, 0, 0, 0))     # a late stamp: time does not go back
    [c] = feed_all(feed, burst(2_000, 0, 0, 0))      # a restart
    [d] = feed_all(feed, burst(3_000, 0, 0, 0))
    assert (a.t, b.t, c.t, d.t) == (pytest.approx(150.0), pytest.approx(150.0),
                                    pytest.approx(150.0), pytest.approx(151.0))
    assert feed.reboots == 1


def test_velocity_is_sim_states_true_velocity() -> None:
    feed = TruthFeed(ORIGIN, offset=0.0)
    feed_all(feed, wire(heartbeat()))
    feed_all(feed, burst(1000, 0.0, 0.0, math.pi / 2, vel=(1.0, 2.0)))   # vn 1, ve 2
    [truth] = feed_all(feed, burst(1100, 0.2, 0.1, math.pi / 2, vel=(1.0, 2.0)))
    assert feed.velocity_source == "SIM_STATE"
    assert (truth.vx, truth.vy) == (pytest.approx(2.0), pytest.approx(1.0))
    assert (truth.surge, truth.sway) == (pytest.approx(2.0), pytest.approx(-1.0))  # heading 90


def test_without_sim_state_velocity_is_differentiated_from_positions() -> None:
    feed = TruthFeed(ORIGIN, offset=0.0)
    feed_all(feed, wire(heartbeat()))
    truths = []
    for k in range(30):   # 3 m/s north, 1 m/s west, 10 Hz
        truths += feed_all(feed, burst(1000 + 100 * k, -0.1 * k, 0.3 * k, 0.0))
    assert feed.velocity_source == "differentiated"
    assert truths[0].vx == 0.0 and truths[0].vy == 0.0      # one sample: no velocity yet
    assert truths[-1].vx == pytest.approx(-1.0, abs=0.02)
    assert truths[-1].vy == pytest.approx(3.0, abs=0.02)
    # a SIM_STATE velocity is used while fresh, then positions take over again
    feed_all(feed, burst(4000, -3.0, 9.0, 0.0, vel=(7.0, 0.0)))
    [fresh] = feed_all(feed, burst(4100, -3.1, 9.3, 0.0))
    assert (fresh.vy, feed.velocity_source) == (pytest.approx(7.0), "SIM_STATE")
    for k in range(2, 13):
        [stale] = feed_all(feed, burst(4000 + 100 * k, -3.0 - 0.1 * k, 9.0 + 0.3 * k, 0.0))
    assert feed.velocity_source == "differentiated" and stale.vy == pytest.approx(3.0, abs=0.02)


def test_origin_defaults_to_the_first_simstate_position() -> None:
    feed = TruthFeed(None, offset=0.0)
    here = Origin(50.1, -4.2)
    first = simstate(0.0, 0.0, 0.0, origin=here)
    [a] = feed_all(feed, wire(heartbeat(), system_time(1000), first))
    [b] = feed_all(feed, wire(system_time(1100), simstate(10.0, 20.0, 0.0, origin=here)))
    assert feed.origin == Origin(first.lat * 1e-7, first.lng * 1e-7)
    assert (a.x, a.y) == (0.0, 0.0)
    assert (b.x, b.y) == (pytest.approx(10.0, abs=0.02), pytest.approx(20.0, abs=0.02))


def test_stream_requests_ask_simstate_sim_state_and_system_time_at_one_interval() -> None:
    msgs = wire(*stream_requests(10.0, 1, 1), src=(255, 158))
    assert [m.command for m in msgs] == [mavlink.MAV_CMD_SET_MESSAGE_INTERVAL] * 3
    assert sorted(int(m.param1) for m in msgs) == [2, 108, 164]
    assert {m.param2 for m in msgs} == {100_000.0}
    with pytest.raises(ValueError):
        stream_requests(0.0)


def test_nmea_gps_tells_the_autopilots_utc_and_the_simstate_position() -> None:
    feed = TruthFeed(ORIGIN, offset=1_800_000_000.0)
    utc_boot0 = 1_796_000_000.25            # the SITL's UTC at boot 0 (its own clock)
    gps = SensorPort(NmeaGps(origin=ORIGIN, noise_m=0.0, wander_m=0.0))
    feed_all(feed, wire(heartbeat()))
    lines = b""
    for k in range(25):
        boot_ms = 20_000 + 100 * k
        for truth in feed_all(feed, burst(boot_ms, 3.0 * k, 40.0, 0.0, vel=(0.0, 30.0),
                                          unix_us=round((utc_boot0 + boot_ms / 1000) * 1e6))):
            gps.sensor.epoch = feed.gps_epoch
            lines += gps.poll(truth, truth.t)
    ggas = [read_sentence(line)[1] for line in lines.split(b"\r\n")
            if line.startswith(b"$GPGGA")]
    assert len(ggas) == 3                    # 1 Hz over 20.0 ... 22.4 s
    for fields in ggas:
        hh, mm, ss = int(fields[0][:2]), int(fields[0][2:4]), float(fields[0][4:])
        boot_s = (hh * 3600 + mm * 60 + ss - utc_boot0 % 86400) % 86400
        assert boot_s == pytest.approx(round(boot_s), abs=0.006)   # on the second
        lat = int(fields[1][:2]) + float(fields[1][2:]) / 60
        lon = -(int(fields[3][:3]) + float(fields[3][3:]) / 60)
        x, y = ORIGIN.to_local(lat, lon)
        k = (boot_s - 20.0) * 10
        assert (x, y) == (pytest.approx(3.0 * k, abs=0.05), pytest.approx(40.0, abs=0.05))


def test_scenario_windows_are_autopilot_seconds() -> None:
    base = Scenario.from_text("seed = 4\nnmea_gps_outage from 10 to 20")
    sc = BootTimeScenario.of(base)
    sc.shift = 1_800_000_000.0
    assert sc.seed == 4 and sc.rng("x").random() == base.rng("x").random()
    assert sc.active("nmea_gps_outage", 1_800_000_015.0)
    assert not sc.active("nmea_gps_outage", 15.0)
    assert not sc.active_matching("nmea_gps_outage", 1_800_000_025.0, port="nmea_gps")


def test_command_line_values() -> None:
    import argparse

    assert parse_truth("tcp:127.0.0.1:5762") == ("127.0.0.1", 5762)
    assert parse_origin("56.1,-5.2,3") == Origin(56.1, -5.2)
    for bad in ("udp:127.0.0.1:5762", "tcp:127.0.0.1", "tcp::5762", "tcp:h:x", "tcp:h:70000"):
        with pytest.raises(argparse.ArgumentTypeError):
            parse_truth(bad)
    for bad in ("56.1", "95,3", "1,2,3,4", "a,b"):
        with pytest.raises(argparse.ArgumentTypeError):
            parse_origin(bad)


# -- the runner on a real socket and real ptys -----------------------------------------------

class FakeAutopilot:
    """A MAVLink server on a real TCP socket sending what a SITL sends for the feed."""

    def __init__(self) -> None:
        self.server = socket.create_server(("127.0.0.1", 0))
        self.port = self.server.getsockname()[1]
        self.conn: socket.socket | None = None
        self.mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        self.rx = mavlink.MAVLink(None)
        self.received: list = []

    def accept(self, timeout_s: float = 5.0) -> None:
        self.server.settimeout(timeout_s)
        self.conn, _ = self.server.accept()
        self.conn.setblocking(False)

    def send(self, *msgs: mavlink.MAVLink_message) -> None:
        assert self.conn is not None
        self.conn.sendall(b"".join(m.pack(self.mav) for m in msgs))

    def drain(self) -> None:
        assert self.conn is not None
        try:
            while data := self.conn.recv(65536):
                self.received += self.rx.parse_buffer(data) or []
        except BlockingIOError:
            pass

    def drop(self) -> None:
        assert self.conn is not None
        self.conn.close()
        self.conn = None

    def close(self) -> None:
        if self.conn is not None:
            self.conn.close()
        self.server.close()


def test_runner_serves_truth_on_ptys_and_survives_a_lost_link() -> None:
    ap = FakeAutopilot()
    said: list[str] = []
    ports = make_sensor_ports("boat", ORIGIN, Scenario(seed=2),
                              [Beacon("1", 0.0, 100.0)], "radio")
    feed = TruthFeed(ORIGIN)
    runner = InstrumentsRunner(TruthLink("127.0.0.1", ap.port), ports, feed, say=said.append)
    heading_port = next(p for p in ports if isinstance(p.sensor, HeadingSensor))
    ranges_port = next(p for p in ports if isinstance(p.sensor, RadioRanges))
    try:
        with serial.Serial(heading_port.slave_path, timeout=0) as hdt, \
                serial.Serial(ranges_port.slave_path, timeout=0) as rng:
            runner.step(0.0)
            ap.accept()
            assert runner.connected and said[-1].endswith(f"connected to tcp:127.0.0.1:{ap.port}")
            ap.send(heartbeat())
            for _ in range(5):
                runner.step(0.02)
            ap.drain()
            asked = sorted(int(m.param1) for m in ap.received
                           if m.get_type() == "COMMAND_LONG"
                           and m.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL)
            assert asked == [2, 108, 164]
            boot = 10_000
            for k in range(20):    # 2 autopilot seconds heading 045, 1 m/s north
                boot += 100
                ap.send(system_time(boot), simstate(0.0, 0.1 * k, math.radians(45.0)),
                        sim_state(1.0, 0.0))
                runner.step(0.01)
            for _ in range(5):
                runner.step(0.01)
            assert feed.samples == 20
            assert any("time stamps = autopilot boot s + " in s for s in said)
            hdts = [read_sentence(line) for line in hdt.read(10_000).splitlines()]
            assert 15 <= len(hdts) <= 21
            assert all(a == "HEHDT" and abs(float(f[0]) - 45.0) < 1.5 for a, f in hdts)
            rngs = [read_sentence(line)[1] for line in rng.read(10_000).splitlines()]
            assert len(rngs) >= 3
            for t, beacon, r in rngs:   # the boat is 100 - y m from the beacon (antenna 1 m up)
                y = (float(t) - feed.offset - 10.1) * 1.0
                assert beacon == "1"
                assert float(r) == pytest.approx(math.hypot(100.0 - y, 1.0), abs=1.5)

            ap.drop()                                       # the autopilot goes away ...
            deadline = time.monotonic() + 5.0
            while runner.connected and time.monotonic() < deadline:
                runner.step(0.02)
            assert not runner.connected and "lost" in said[-1] and "retrying" in said[-1]
            while runner.connections < 2 and time.monotonic() < deadline:   # ... and is back
                runner.step(0.02)
                select.select([ap.server], [], [], 0.02)
                if ap.conn is None and select.select([ap.server], [], [], 0)[0]:
                    ap.accept()
            assert runner.connections == 2
            ap.send(heartbeat())
            for _ in range(10):
                boot += 100
                ap.send(system_time(boot), simstate(0.0, 2.0, math.radians(90.0)))
                runner.step(0.01)
            assert feed.samples == 30
            later = [read_sentence(line)[1] for line in hdt.read(10_000).splitlines()]
            assert later and all(abs(float(f[0]) - 90.0) < 1.5 for f in later[1:])
    finally:
        runner.close()
        ap.close()
        for p in ports:
            p.close()


def test_runner_asks_again_until_the_rate_is_granted() -> None:
    """ArduPilot ignores a request made while it starts: SIMSTATE stays at 1 Hz until asked
    again; a simulator with no SIM_STATE is asked a bounded number of times."""
    ap = FakeAutopilot()
    said: list[str] = []
    wall = [0.0]
    feed = TruthFeed(ORIGIN, offset=0.0)
    runner = InstrumentsRunner(TruthLink("127.0.0.1", ap.port), [], feed, say=said.append,
                               wall=lambda: wall[0])

    def asks() -> int:
        ap.drain()
        return sum(m.get_type() == "COMMAND_LONG" for m in ap.received) // 3

    def run_for(seconds: float, period_ms: int, boot: int, sim_state_too: bool) -> int:
        """``seconds`` of wall time in 0.1 s steps, the autopilot sending truth every
        ``period_ms`` of its own (10x faster) time."""
        for _ in range(round(seconds * 10)):
            wall[0] += 0.1
            for _ in range(1000 // period_ms):
                boot += period_ms
                ap.send(system_time(boot), simstate(0.0, 0.0, 0.0),
                        *([sim_state(0.0, 0.0)] if sim_state_too else []))
            runner.step(0.01)
        return boot

    try:
        runner.step(0.0)
        ap.accept()
        ap.send(heartbeat())
        runner.step(0.05)
        assert asks() == 1
        boot = run_for(1.9, 1000, 1000, True)          # granted? no: 1 Hz (of 10 asked)
        assert asks() == 1
        boot = run_for(0.2, 1000, boot, True)
        assert asks() == 2 and "not at 10 Hz; asking again" in said[-1]
        boot = run_for(4.0, 100, boot, True)           # granted: no more asking
        assert asks() == 2
        run_for(10.0, 100, boot, False)                # no SIM_STATE: 3 tries, then positions
        assert asks() == 3 and said.count(f"{PREFIX} no SIM_STATE (true velocity); "
                                          "asking again") == 1
        assert feed.velocity_source == "differentiated"
    finally:
        runner.close()
        ap.close()


# -- beside the real ArduPilot SITL ---------------------------------------------------------

BEACONS = {"A": (0.0, 120.0), "B": (150.0, 0.0), "C": (-100.0, -80.0)}
RANGE_NOISE_M = 0.3          # RadioRanges default
ANTENNA_M = 1.0              # RadioRanges antenna height above the (z = 0) beacons


def _interp(track: list[tuple[float, float, float]], boot_s: float) -> tuple[float, float]:
    """(x, y) at autopilot time ``boot_s`` from a (boot s, x, y) track, linearly."""
    for (b0, x0, y0), (b1, x1, y1) in zip(track, track[1:], strict=False):
        if b0 <= boot_s <= b1:
            a = 0.0 if b1 == b0 else (boot_s - b0) / (b1 - b0)
            return x0 + a * (x1 - x0), y0 + a * (y1 - y0)
    raise AssertionError(f"{boot_s:.3f} s is outside the truth track "
                         f"{track[0][0]:.3f}..{track[-1][0]:.3f}")


def _angle_error(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def _heading_at(track: list[tuple[float, float, float, float]], boot_s: float) -> float:
    """Heading (deg) at ``boot_s`` from a (boot s, x, y, heading) track, interpolated."""
    for (b0, _, _, h0), (b1, _, _, h1) in zip(track, track[1:], strict=False):
        if b0 <= boot_s <= b1:
            a = 0.0 if b1 == b0 else (boot_s - b0) / (b1 - b0)
            return (h0 + a * ((h1 - h0 + 180.0) % 360.0 - 180.0)) % 360.0
    raise AssertionError(f"{boot_s:.3f} s is outside the truth track")


def test_instruments_beside_the_real_sitl_agree_with_its_simstate(real_sitl, tmp_path) -> None:
    from tests.support.ardupilot import RealOperator

    sitl = real_sitl(model="motorboat", speedup=10)
    op = RealOperator(sitl.ports.serial0, heartbeat_s=0.1)   # starts the SITL's clock
    beacons = ";".join(f"{k}:{x:g},{y:g}" for k, (x, y) in BEACONS.items())
    cmd = [sys.executable, "-m", "mavhelm.cli", "instruments",
           "--truth", f"tcp:127.0.0.1:{sitl.ports.serial1}", "--beacons", beacons,
           "--ranging", "radio", "--seed", "7"]
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            cwd=tmp_path, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    console: list[str] = []
    ptys: dict[str, serial.Serial] = {}
    try:
        assert proc.stdout is not None
        os.set_blocking(proc.stdout.fileno(), False)

        def read_console() -> None:
            while line := proc.stdout.readline():
                console.append(line.rstrip("\n"))
                m = re.fullmatch(r"mavhelm instruments: (\w+) on (/dev/\S+) \(.*\)", console[-1])
                if m:
                    ptys[m.group(1)] = serial.Serial(m.group(2), timeout=0)

        def ask_operator_truth() -> None:
            """The operator's own truth: SIMSTATE at 20 Hz, with SYSTEM_TIME at the same
            interval so every SIMSTATE (and every pty read) has a fresh autopilot time."""
            for mid in (mavlink.MAVLINK_MSG_ID_SIMSTATE, mavlink.MAVLINK_MSG_ID_SYSTEM_TIME):
                op.conn.mav.command_long_send(1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
                                              mid, 50_000, 0, 0, 0, 0, 0)

        def operator_truth_fast() -> bool:
            recent = [boot for _, boot, *_ in op.simstates[-10:] if boot is not None]
            return len(recent) == 10 and recent[-1] - recent[0] < 1000
        rx: dict[str, bytes] = {}
        read_at: dict[str, list[tuple[int | None, bytes]]] = {}

        utc_minus_boot: list[float] = []    # the autopilot's UTC, from its SYSTEM_TIME

        def pump(seconds: float) -> None:
            """Poll the operator, the console and the ptys, keeping each pty line with the
            autopilot time it was read at."""
            end = time.monotonic() + seconds
            while time.monotonic() < end:
                for msg in op.poll(0.01):
                    if msg.get_type() == "SYSTEM_TIME" and msg.time_unix_usec:
                        utc_minus_boot.append(msg.time_unix_usec / 1e6 - msg.time_boot_ms / 1e3)
                read_console()
                for name, ser in ptys.items():
                    data = rx.get(name, b"") + ser.read(65536)
                    *lines, rx[name] = data.split(b"\r\n")
                    read_at.setdefault(name, []).extend((op.boot_ms, ln) for ln in lines)

        # A request made before the autopilot runs is ignored: ask until it is granted.
        op.wait_until(lambda: op.heartbeats > 0, 10.0, "the autopilot's first HEARTBEAT")
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline and not (
                operator_truth_fast() and "velocity from SIM_STATE" in " ".join(console)):
            ask_operator_truth()
            pump(0.5)
        assert {"nmea_gps", "heading", "depth", "dvl", "ranges"} <= set(ptys), console
        offset = float(re.search(r"time stamps = autopilot boot s \+ ([\d.]+)",
                                 " ".join(console)).group(1))

        # Drive: arm in MANUAL, then full throttle with a little rudder (a wide circle at
        # ~8 m/s), for 25 autopilot seconds.
        op.hand_over("MANUAL", timeout_s=30.0)
        pump(0.05)              # what the ptys held meanwhile was not read at today's time
        read_at.clear()
        start_boot = op.boot_ms
        while op.boot_ms - start_boot < 25_000:
            op.conn.mav.rc_channels_override_send(1, 1, 1540, 65535, 2000, 65535, 65535,
                                                  65535, 65535, 65535)
            pump(0.05)
        pump(0.3)
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            out, _ = proc.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, _ = proc.communicate()
        console += (out or "").splitlines()
        for ser in ptys.values():
            ser.close()
        op.close()
    assert console[-1] == "mavhelm instruments: stopped", console
    assert proc.returncode == 0

    home = Origin(op.simstates[0][2] * 1e-7, op.simstates[0][3] * 1e-7)
    track = []
    for _, boot, lat, lng, yaw in op.simstates:
        if boot is not None:
            x, y = home.to_local(lat * 1e-7, lng * 1e-7)
            track.append((boot / 1000.0, x, y, math.degrees(yaw) % 360.0))
    moved = max(math.dist(track[0][1:3], row[1:3]) for row in track)
    xy = [(b, x, y) for b, x, y, _ in track]
    print(f"[instruments] boat moved {moved:.0f} m; time offset {offset:.3f}")
    driving = [row for row in track if row[0] >= start_boot / 1000]
    assert len(driving) > 15 * (driving[-1][0] - driving[0][0])   # the operator's truth, 20 Hz
    assert moved > 30.0, "the boat was not driven"

    # $PMVHRNG: each range, at its own time stamp (companion clock = boot + offset), is the
    # distance from the SIMSTATE truth of that moment, within its noise.
    errors = []
    for _, line in read_at["ranges"]:
        t, beacon, r = read_sentence(line)[1]
        boot_s = float(t) - offset
        if boot_s > xy[-1][0]:
            continue   # measured after the operator's last SIMSTATE
        x, y = _interp(xy, boot_s)
        bx, by = BEACONS[beacon]
        errors.append(float(r) - math.hypot(x - bx, y - by, ANTENNA_M))
    print(f"[instruments] {len(errors)} ranges, error mean {sum(errors) / len(errors):+.2f} m, "
          f"max |e| {max(map(abs, errors)):.2f} m")
    assert len(errors) >= 40                   # 2 Hz for 25 s
    assert max(map(abs, errors)) < 5 * RANGE_NOISE_M
    assert abs(sum(errors) / len(errors)) < 0.2

    # GGA: its UTC is the autopilot's (SYSTEM_TIME), and the fix is the truth of that moment
    # within the GPS's noise (0.5 m white + 1 m wander per axis) and a few metres.
    assert max(utc_minus_boot) - min(utc_minus_boot) < 0.01
    utc0 = utc_minus_boot[-1]
    gga_errors = []
    for _, line in read_at["nmea_gps"]:
        if not line.startswith(b"$GPGGA"):
            continue
        f = read_sentence(line)[1]
        of_day = int(f[0][:2]) * 3600 + int(f[0][2:4]) * 60 + float(f[0][4:])
        boot_s = (of_day - utc0) % 86400.0
        if boot_s > xy[-1][0]:
            continue
        lat = (int(f[1][:2]) + float(f[1][2:]) / 60) * (1 if f[2] == "N" else -1)
        lon = (int(f[3][:3]) + float(f[3][3:]) / 60) * (1 if f[4] == "E" else -1)
        x, y = home.to_local(lat, lon)
        gga_errors.append(math.dist((x, y), _interp(xy, boot_s)))
    print(f"[instruments] {len(gga_errors)} GGA, max error {max(gga_errors):.2f} m")
    assert len(gga_errors) >= 20               # 1 Hz for 25 s
    assert max(gga_errors) < 5.0

    # HDT carries no time, but its lines are consecutive 10 Hz slots of the truth time
    # (multiples of 0.1 s of boot + offset). Read latency (×10 under --speedup 10, and the
    # machine is shared) only bounds where the first slot is: of the grid points it may be,
    # the best must put every heading on the SIMSTATE truth within the sensor's 0.3° noise.
    # The bound is the operator's newest SYSTEM_TIME when a line was read, and the operator's
    # link may lag the instruments' own (a CI run found the first slot past it): the search
    # reaches 0.5 s beyond it too.
    headings = [float(read_sentence(line)[1][0]) for _, line in read_at["heading"]]
    assert len(headings) >= 200               # 10 Hz for 25 s
    latest = min(b / 1000 - 0.1 * i for i, (b, _) in enumerate(read_at["heading"]))
    top = latest - (latest + offset) % 0.1      # the last slot not after ``latest``
    candidates = [top - 0.1 * j for j in range(-5, 12)]

    def worst(s0: float) -> float:
        return max(_angle_error(h, _heading_at(track, s0 + 0.1 * i))
                   for i, h in enumerate(headings) if s0 + 0.1 * i <= track[-1][0])

    best = min(candidates, key=worst)
    turned = sum(abs((b[3] - a[3] + 180.0) % 360.0 - 180.0)
                 for a, b in zip(track, track[1:], strict=False))
    print(f"[instruments] {len(headings)} HDT, max error {worst(best):.2f} deg with the first "
          f"slot {latest - best:.1f} s before its earliest read; the boat turned {turned:.0f} deg")
    assert turned > 180.0
    assert worst(best) < 1.5
