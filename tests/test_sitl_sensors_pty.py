"""Serial sensors on real pseudo-terminals, read with pyserial as the companion would."""

from __future__ import annotations

import time

import pytest
import serial

from mavhelm.sitl.faults import Scenario
from mavhelm.sitl.flat_earth import Origin
from mavhelm.sitl.serial_sensors import HeadingSensor, NmeaGps, PtySerialPort
from mavhelm.sitl.truth import Truth
from tests.support.nmea_read import ParseError, read_sentence


def truth(t: float) -> Truth:
    return Truth(t=t, x=t, y=0.0, heading=(10.0 * t) % 360.0, yaw_rate=10.0, vx=1.0)


def test_pyserial_reads_exact_sentences_from_the_pty() -> None:
    with PtySerialPort(HeadingSensor(noise_deg=0.0), keep_output=True) as port:
        assert port.slave_path.startswith("/dev/")
        with serial.Serial(port.slave_path, 4800, timeout=1.0) as ser:
            for i in range(21):
                port.update(truth(i * 0.1), i * 0.1)
            lines = [ser.readline() for _ in range(21)]
        assert b"".join(lines) == bytes(port.output)  # byte for byte, CRLF kept
        for k, line in enumerate(lines):
            assert line.endswith(b"\r\n")
            address, fields = read_sentence(line)
            assert address == "HEHDT"
            assert float(fields[0]) == pytest.approx((10.0 * k / 10) % 360.0, abs=0.051)
        assert port.stats["written"] == 21 and port.stats["dropped"] == 0


def test_full_buffer_drops_whole_lines_without_blocking() -> None:
    gps = NmeaGps(origin=Origin(50.0, -4.0), rate_hz=50.0)
    with PtySerialPort(gps, Scenario(seed=1)) as port:
        with serial.Serial(port.slave_path, timeout=0.2) as ser:  # a companion that stalls
            start = time.monotonic()
            for i in range(4000):  # ~600 kB offered to a pty that holds far less
                port.update(truth(i * 0.02), i * 0.02)
            assert time.monotonic() - start < 10.0
            assert port.stats["dropped"] > 0
            assert port.stats["written"] + port.stats["dropped"] == port.stats["lines"]
            buffered = b""
            while chunk := ser.read(65536):
                buffered += chunk
            t = 80.0
            for _ in range(5):  # once the reader catches up, lines flow again
                t += 0.02
                port.update(truth(t), t)
            fresh = ser.read(10_000)
    assert 1000 < len(buffered) and len(buffered) + len(fresh) == port.stats["bytes"]
    lines = (buffered + fresh).split(b"\r\n")
    assert lines[-1] == b""  # a line the pty only half took is finished first: none is cut
    for line in lines[:-1]:
        read_sentence(line)  # every line that got through is whole
    assert fresh.count(b"$GPGGA") == 6  # slots 80.00 … 80.10 s at 50 Hz


def test_bytes_from_the_companion_are_drained() -> None:
    with PtySerialPort(HeadingSensor()) as port:
        with serial.Serial(port.slave_path, timeout=0.5) as ser:
            ser.write(b"$PCFG,RATE,10*00\r\n")
            ser.flush()
            deadline = time.monotonic() + 2.0
            while port.stats["rx_bytes"] < 18 and time.monotonic() < deadline:
                port.update(truth(0.0), 0.0)
                time.sleep(0.01)
        assert port.stats["rx_bytes"] == 18


def test_garbage_reaches_the_reader() -> None:
    sc = Scenario.from_text("seed = 3\nserial_garbage always port=heading prob=1")
    with PtySerialPort(HeadingSensor(), sc, keep_output=True) as port:
        with serial.Serial(port.slave_path, timeout=0.5) as ser:
            for i in range(10):
                port.update(truth(i * 0.1), i * 0.1)
            data = ser.read(port.stats["bytes"])
    assert data == bytes(port.output) and port.stats["garbled"] == 10
    good = 0
    for line in data.split(b"\r\n"):
        try:
            read_sentence(line)
            good += 1
        except ParseError:
            pass
    assert good == 0


def test_default_ports_on_ptys() -> None:
    from mavhelm.sitl.serial_sensors import Beacon, default_ports

    ports = default_ports(Origin(50.0, -4.0), Scenario(seed=2), [Beacon("1", 50.0, 0.0, -10.0)])
    try:
        assert [p.name for p in ports] == ["nmea_gps", "heading", "depth", "dvl", "lbl"]
        assert len({p.slave_path for p in ports}) == 5  # type: ignore[attr-defined]
        with serial.Serial(ports[0].slave_path, timeout=0.5) as ser:  # type: ignore[attr-defined]
            for p in ports:
                p.update(truth(0.0), 0.0)
            assert read_sentence(ser.readline())[0] == "GPGGA"
    finally:
        for p in ports:
            p.close()
    with pytest.raises(ValueError):
        default_ports(Origin(0, 0), beacons=[Beacon("1", 1, 1)], ranging="sonar", pty=False)
