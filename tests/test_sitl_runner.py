"""``mavhelm sim`` options, determinism, speed and the serial-sensor hook."""

from __future__ import annotations

import argparse
import hashlib
import math
import socket
import time
from pathlib import Path

import pytest

from mavhelm.core.clock import SimClock
from mavhelm.sitl import runner
from mavhelm.sitl.faults import Scenario
from mavhelm.sitl.simulator import Simulator
from tests.support.nmea_read import ParseError, read_sentence


def _parse(*argv: str) -> argparse.Namespace:
    p = argparse.ArgumentParser()
    runner.add_arguments(p)
    return p.parse_args(list(argv))


def test_runner_options():
    a = _parse()
    assert (a.model, a.port, a.out, a.speedup) == ("mavhelm-boat", [5760, 5762, 5763], [], 1.0)
    a = _parse("--model", "mavhelm-rover-skid", "--port", "0,0", "--out",
               "udp:127.0.0.1:14550", "--out", "udp:10.0.0.2:14551", "--home", "50.1,-4.2,90",
               "--speedup", "5", "--fast-start", "--seed", "3")
    assert a.port == [0, 0] and a.out == [("127.0.0.1", 14550), ("10.0.0.2", 14551)]
    assert a.home == (50.1, -4.2, 90.0) and a.fast_start and a.seed == 3
    with pytest.raises(SystemExit):
        _parse("--out", "tcp:1.2.3.4:5")


def test_runner_refuses_bad_options_with_a_usage_error(capsys):
    for argv in (("--model", "mavhelm-rover-rudder"), ("--speedup", "0"), ("--speedup", "nan"),
                 ("--param", "WP_SPEED"), ("--param", "WP_SPEED=inf")):
        with pytest.raises(SystemExit):
            _parse(*argv)
        assert "usage:" in capsys.readouterr().err
    assert _parse("--param", "wp_speed=2").param == [("WP_SPEED", 2.0)]


def _recording(seed: int, scenario=None) -> bytes:
    """Everything one client receives over 30 s with the sim stepped at 20 Hz."""
    clock = SimClock(0.0)
    sim = Simulator(clock, ports=(0,), fast_start=True, seed=seed, scenario=scenario)
    c = socket.create_connection(("127.0.0.1", sim.ports[0]))
    c.setblocking(False)
    while not sim.links:
        sim.service(0.0)
    got = bytearray()
    try:
        for _ in range(600):
            sim.step(clock.advance(0.05))
            deadline = time.monotonic() + 5
            while len(got) < sim.links[0].bytes_sent and time.monotonic() < deadline:
                try:
                    got += c.recv(65536)
                except BlockingIOError:
                    time.sleep(0.0002)
    finally:
        c.close()
        sim.close()
    return bytes(got)


FAULTS = """
# every MAVLink-side fault kind that draws random numbers, inside the 30 s recording
seed = {seed}
gps_outlier     from 0 to 30 prob=0.2 sigma=5
gps_jump        at 12 dx=8 dy=-3
compass_bias    from 20 deg=3
link_garbage    from 5 to 15 prob=0.1
link_duplicate  from 10 to 20 prob=0.1
link_reorder    from 15 to 25 prob=0.1
"""


def test_a_scenario_file_replays_bit_identical_streams(tmp_path):
    def replay(seed: int) -> bytes:
        path = tmp_path / f"faults{seed}.scn"
        path.write_text(FAULTS.format(seed=seed))
        scenario = Scenario.from_file(path)
        return _recording(scenario.seed, scenario)

    first, again = replay(7), replay(7)
    assert hashlib.sha256(first).digest() == hashlib.sha256(again).digest()
    assert replay(8) != first, "another seed draws other faults and noise"
    assert _recording(7) != first, "the faults must show in the stream"


def test_same_seed_same_bytes_without_faults():
    a, b = _recording(7), _recording(7)
    assert hashlib.sha256(a).digest() == hashlib.sha256(b).digest()
    assert _recording(8) != a  # GPS noise differs


def test_paced_clock_runs_n_times_faster_than_the_wall(monkeypatch):
    wall = [1000.0]
    monkeypatch.setattr(runner.time, "monotonic", lambda: wall[0])
    clock = runner.PacedClock(10.0)
    wall[0] += 0.5
    assert clock.now() == pytest.approx(5.0)
    wall[0] += 2.0
    assert clock.now() == pytest.approx(25.0)
    with pytest.raises(ValueError):
        runner.PacedClock(0.0)


class _Recorder:
    def __init__(self) -> None:
        self.calls: list[float] = []

    def update(self, truth, now: float) -> None:
        self.calls.append((now, truth.t))


def test_serial_sensors_updated_after_physics():
    clock = SimClock(0.0)
    rec = _Recorder()
    sim = Simulator(clock, ports=(), fast_start=True, serial_sensors=[rec])
    try:
        for _ in range(5):
            sim.step(clock.advance(0.1))
        assert [round(n, 6) for n, _ in rec.calls] == [0.1, 0.2, 0.3, 0.4, 0.5]
        assert all(abs(n - t) < 0.02 for n, t in rec.calls)
    finally:
        sim.close()


# ---------------------------------------------------------------------------- --sensors


def test_sensor_options():
    a = _parse()
    assert (a.sensors, a.beacons, a.ranging) == (False, None, "acoustic")
    a = _parse("--sensors", "--beacons", "1:100,0;B2:0,150,-20,0.25", "--ranging", "radio")
    assert a.sensors and a.ranging == "radio"
    assert [(b.id, b.x, b.y, b.z, b.turnaround_s) for b in a.beacons] == [
        ("1", 100.0, 0.0, 0.0, 0.0), ("B2", 0.0, 150.0, -20.0, 0.25)]
    for bad in ("1:100", "1:a,b", ":1,2", "1:1,2,3,4,5", ";"):
        with pytest.raises(SystemExit):
            _parse("--beacons", bad)
    with pytest.raises(SystemExit):
        _parse("--ranging", "sonar")


def test_beacons_without_sensors_is_refused(capsys):
    assert runner.run(_parse("--port", "0", "--beacons", "1:10,0")) == 2
    assert "--beacons needs --sensors" in capsys.readouterr().err


def test_sensor_kit_per_vehicle():
    from mavhelm.sitl.faults import Scenario
    from mavhelm.sitl.flat_earth import Origin

    beacons = _parse("--beacons", "1:100,0;2:0,100").beacons
    boat = runner.make_sensor_ports("boat", Origin(50.0, -4.0), Scenario(), beacons, "radio",
                                    epoch=1.7e9)
    rover = runner.make_sensor_ports("rover", Origin(50.0, -4.0), Scenario(), None, "acoustic")
    try:
        assert [p.name for p in boat] == ["nmea_gps", "heading", "depth", "dvl", "ranges"]
        assert [p.name for p in rover] == ["nmea_gps", "heading", "dvl"]
        assert boat[0].sensor.epoch == 1.7e9  # NMEA UTC follows the simulator's GPS clock
        assert not rover[2].sensor.report_altitude  # wheel odometry
        lines = [runner.describe_port(p) for p in boat]
        assert lines[0] == f"nmea_gps on {boat[0].slave_path} (NMEA GGA+RMC, 1 Hz)"
        assert lines[4].endswith("($PMVHRNG ranges, 2 beacons, 2 Hz)")
        assert all(p.slave_path.startswith("/dev/") for p in boat + rover)
    finally:
        for p in boat + rover:
            p.close()


def test_sim_closes_the_sensor_ptys_on_ctrl_c(monkeypatch, capsys):
    made = []
    real = runner.make_sensor_ports

    def recording(*args, **kw):
        ports = real(*args, **kw)
        made.extend(ports)
        return ports

    ticks = []

    def fake_select(r, w, x, timeout):
        ticks.append(timeout)
        if len(ticks) >= 20:
            raise KeyboardInterrupt
        return [], [], []

    monkeypatch.setattr(runner, "make_sensor_ports", recording)
    monkeypatch.setattr(runner.select, "select", fake_select)
    assert runner.run(_parse("--port", "0", "--fast-start", "--sensors")) == 0
    out = capsys.readouterr().out
    assert [p.name for p in made] == ["nmea_gps", "heading", "depth", "dvl"]
    for p in made:
        assert f"mavhelm sim: {p.name} on {p.slave_path} (" in out
        assert p._master == -1 and p._slave == -1  # both ends closed
    assert out.rstrip().endswith("mavhelm sim: stopped")


def _gga_position(line: bytes) -> tuple[float, float] | None:
    try:
        address, f = read_sentence(line)
    except ParseError:
        return None  # e.g. the tail of a line that was arriving as the port was opened
    if not address.endswith("GGA") or f[5] != "1":
        return None
    lat = int(f[1][:2]) + float(f[1][2:]) / 60.0
    lon = int(f[3][:3]) + float(f[3][3:]) / 60.0
    return (-lat if f[2] == "S" else lat), (-lon if f[4] == "W" else lon)


@pytest.mark.slow
def test_mavhelm_sim_sensors_serve_nmea_gps_on_a_pty():
    """The real command: read the printed pty path with pyserial, as a companion would, and
    get valid GGA at the --home position."""
    import signal

    import serial

    from mavhelm.sitl.flat_earth import Origin
    from tests.support.interop_helpers import SimProcess

    with SimProcess("--fast-start", "--sensors", "--home", "50.1,-4.2,90") as sim:
        paths = sim.sensor_paths("nmea_gps", "heading", "depth", "dvl")
        assert set(paths) == {"nmea_gps", "heading", "depth", "dvl"}
        fixes = []
        with serial.Serial(paths["nmea_gps"], 4800, timeout=0.5) as gps:
            deadline = time.monotonic() + 8
            while len(fixes) < 2 and time.monotonic() < deadline:
                line = gps.readline()
                if line.endswith(b"\r\n") and b"GGA" in line:
                    pos = _gga_position(line.strip())
                    if pos is not None:
                        fixes.append(pos)
        assert len(fixes) == 2, sim.output.text()
        home = Origin(50.1, -4.2)
        for lat, lon in fixes:
            x, y = home.to_local(lat, lon)
            assert math.hypot(x, y) < 10.0, (lat, lon)
        with serial.Serial(paths["heading"], timeout=0.5) as hdt:
            hdt.readline()  # the first read may start mid-line
            line = hdt.readline()
        assert line.startswith(b"$HEHDT,") and abs(float(line.split(b",")[1]) - 90.0) < 3.0
        sim.proc.send_signal(signal.SIGINT)
        assert sim.proc.wait(timeout=10) == 0
        deadline = time.monotonic() + 5
        while "mavhelm sim: stopped" not in sim.output.text() and time.monotonic() < deadline:
            time.sleep(0.05)
        assert "mavhelm sim: stopped" in sim.output.text()


def test_mavhelm_sim_starts_at_the_missions_origin():
    from tests.support.interop_helpers import SimProcess

    mission = Path(__file__).resolve().parents[1] / "examples" / "demo.moos"
    sim = SimProcess("--mission", str(mission))
    try:
        assert "at 56.412000,-5.476000 listening on" in sim.output.text()
    finally:
        sim.close()


def test_a_busy_port_names_the_port_and_the_option(capsys):
    holder = socket.socket()
    holder.bind(("127.0.0.1", 0))
    holder.listen(1)
    port = holder.getsockname()[1]
    try:
        assert runner.run(_parse("--port", f"{port}")) == 1
    finally:
        holder.close()
    err = capsys.readouterr().err
    assert err.startswith(f"mavhelm sim: TCP port {port} on 127.0.0.1 is already in use")
    assert f"--port {port + 10}" in err
