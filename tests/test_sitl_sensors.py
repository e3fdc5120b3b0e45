"""Serial sensor models and ports: values against truth, rates, faults, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavhelm.sitl.faults import Scenario
from mavhelm.sitl.flat_earth import Origin
from mavhelm.sitl.serial_sensors import (
    AcousticLbl,
    Beacon,
    DvlSensor,
    EchoSounder,
    HeadingSensor,
    NmeaGps,
    RadioRanges,
    SensorPort,
    body_velocity,
    update_all,
)
from mavhelm.sitl.truth import Truth
from tests.support.nmea_read import ParseError, latlon, read_sentence

ORIGIN = Origin(50.36, -4.14)
BEACONS = [
    Beacon("1", 150.0, 0.0, -20.0, turnaround_s=0.10),
    Beacon("2", 0.0, 200.0, -25.0, turnaround_s=0.25),
    Beacon("3", -120.0, -80.0, -15.0, turnaround_s=0.40),
]


def moving(t: float, speed: float = 1.5, heading: float = 60.0) -> Truth:
    """A boat on a straight line: a deterministic Truth for any t."""
    h = math.radians(heading)
    vx, vy = speed * math.sin(h), speed * math.cos(h)
    return Truth(
        t=t, x=vx * t, y=vy * t, heading=heading, surge=speed, vx=vx, vy=vy, water_depth=18.0
    )


def circling(t: float) -> Truth:
    """A boat turning at 3 deg/s on a 30 m circle, water depth varying: richer truth."""
    w = math.radians(3.0)
    r = 30.0
    heading = (90.0 + 3.0 * t) % 360.0  # tangent to a clockwise circle starting north of 0
    return Truth(
        t=t,
        x=r * math.sin(w * t),
        y=r * math.cos(w * t),
        heading=heading,
        yaw_rate=3.0,
        surge=r * w,
        vx=r * w * math.cos(w * t),
        vy=-r * w * math.sin(w * t),
        water_depth=15.0 + 5.0 * math.sin(0.01 * t),
    )


def run(port: SensorPort, truth_of, duration: float, dt: float = 0.05) -> list[str]:
    """Step a port like the simulator does; return the output lines (decoded, no EOL)."""
    for i in range(int(round(duration / dt)) + 1):
        t = i * dt
        port.update(truth_of(t), t)
    return port.output.decode("latin-1").split("\r\n")[:-1]


def parsed(lines: list[str]) -> list[tuple[str, list[str]]]:
    return [read_sentence(line) for line in lines]


# ------------------------------------------------------------------------ models vs truth


def test_gps_positions_match_truth_without_noise() -> None:
    gps = NmeaGps(origin=ORIGIN, noise_m=0.0, wander_m=0.0, speed_noise_mps=0.0)
    out = parsed(run(SensorPort(gps), moving, 30.0))
    ggas = [f for a, f in out if a == "GPGGA"]
    rmcs = [f for a, f in out if a == "GPRMC"]
    assert len(ggas) == len(rmcs) == 31  # 1 Hz, t = 0..30 inclusive
    for k, f in enumerate(ggas):
        truth = moving(float(k))
        x, y = ORIGIN.to_local(latlon(f[1], f[2]), latlon(f[3], f[4]))
        assert math.hypot(x - truth.x, y - truth.y) < 0.01
        assert f[0] == f"0000{k:02d}.00"
    for f in rmcs:
        assert float(f[6]) == pytest.approx(1.5 * 3600 / 1852, abs=0.006)
        assert float(f[7]) == pytest.approx(60.0, abs=0.06)


def test_gps_noise_has_the_configured_size() -> None:
    gps = NmeaGps(origin=ORIGIN, rate_hz=10.0, noise_m=0.5, wander_m=1.0, wander_tau_s=5.0)
    out = parsed(run(SensorPort(gps, Scenario(seed=3)), moving, 600.0, dt=0.1))
    errs = []
    for a, f in out:
        if a == "GPGGA":
            t = (float(f[0][:2]) * 3600 + float(f[0][2:4]) * 60) + float(f[0][4:])
            x, y = ORIGIN.to_local(latlon(f[1], f[2]), latlon(f[3], f[4]))
            errs.append((x - moving(t).x, y - moving(t).y))
    e = np.array(errs)
    assert len(e) == 6001
    # per axis: sqrt(0.5² + 1²) ≈ 1.12 m; wander is correlated, so allow a loose band
    assert 0.8 < e.std(axis=0).min() and e.std(axis=0).max() < 1.5
    assert np.abs(e.mean(axis=0)).max() < 0.5


def test_gps_epoch_follows_unix_simulation_clock() -> None:
    gps = NmeaGps(origin=ORIGIN)
    t = 1_767_225_600.0 + 3600.0
    line = gps.sample(moving(t), t, np.random.default_rng(0))[0]
    assert read_sentence(line)[1][0] == "010000.00"


def test_heading_rate_noise_and_wrap() -> None:
    lines = run(SensorPort(HeadingSensor(noise_deg=0.0)), circling, 20.0)
    values = [float(f[0]) for _, f in parsed(lines)]
    assert len(values) == 201  # 10 Hz
    for k, v in enumerate(values):
        want = circling(k / 10).heading
        assert abs((v - want + 180) % 360 - 180) <= 0.051
    noisy = run(SensorPort(HeadingSensor(noise_deg=0.5), Scenario(seed=1)), moving, 60.0)
    err = np.array([float(f[0]) for _, f in parsed(noisy)]) - 60.0
    assert 0.4 < err.std() < 0.6


def test_echo_sounder_depth_below_transducer_and_loss() -> None:
    sounder = EchoSounder(noise_m=0.0, noise_frac=0.0, draft_m=0.4)
    out = parsed(run(SensorPort(sounder), circling, 10.0))
    assert len(out) == 2 * 21  # DPT + DBT at 2 Hz
    for k in range(21):
        (a1, dpt), (a2, dbt) = out[2 * k], out[2 * k + 1]
        assert (a1, a2) == ("SDDPT", "SDDBT")
        want = circling(k / 2).water_depth - 0.4
        assert float(dpt[0]) == pytest.approx(want, abs=0.006) and dpt[1] == "0.40"
        assert float(dbt[2]) == pytest.approx(want, abs=0.006)
        assert float(dbt[0]) == pytest.approx(want / 0.3048, abs=0.06)
    deep = EchoSounder(max_range_m=10.0)
    assert all(f[0] == "" for a, f in parsed(run(SensorPort(deep), moving, 2.0)) if a == "SDDPT")


def test_dvl_body_velocity_matches_rotation() -> None:
    assert body_velocity(Truth(0, 0, 0, heading=90.0, vx=2.0)) == pytest.approx((2.0, 0.0))
    assert body_velocity(Truth(0, 0, 0, heading=0.0, vx=1.0)) == pytest.approx((0.0, 1.0))
    assert body_velocity(Truth(0, 0, 0, heading=180.0, vy=1.0)) == pytest.approx((-1.0, 0.0))
    out = parsed(run(SensorPort(DvlSensor(noise_mps=0.0)), circling, 10.0))
    assert len(out) == 51  # 5 Hz
    for address, f in out:
        truth = circling(float(f[0]))
        assert address == "PMVHDVL" and f[4] == "A"
        assert float(f[1]) == pytest.approx(truth.surge, abs=0.002)  # circling: no sway
        assert float(f[2]) == pytest.approx(0.0, abs=0.002)
        assert float(f[5]) == pytest.approx(truth.water_depth - 0.3, abs=0.1)
    lost = DvlSensor(max_altitude_m=5.0)
    assert {f[4] for _, f in parsed(run(SensorPort(lost), moving, 1.0))} == {"V"}
    odo = DvlSensor(report_altitude=False, max_altitude_m=math.inf)
    assert {f[5] for _, f in parsed(run(SensorPort(odo), moving, 1.0))} == {""}


def _twtt_truth(truth_of, t0: float, b: Beacon, depth: float = 0.5) -> float:
    """Exact two-way travel time by bisection on the true trajectory."""

    def pos(t: float) -> tuple[float, float, float]:
        tr = truth_of(t)
        return tr.x, tr.y, tr.z - depth

    bx = (b.x, b.y, b.z)
    leave = t0 + math.dist(pos(t0), bx) / 1500.0 + b.turnaround_s
    lo, hi = leave, leave + 2.0
    for _ in range(60):
        mid = (lo + hi) / 2
        if leave + math.dist(pos(mid), bx) / 1500.0 > mid:
            lo = mid
        else:
            hi = mid
    return lo - t0


def test_lbl_travel_times_include_turnaround_and_motion() -> None:
    port = SensorPort(AcousticLbl(beacons=BEACONS, noise_s=0.0, listen_window_s=2.0))
    out = parsed(run(port, moving, 20.0))
    assert len(out) == 10  # pings at 0, 2, ... 18 reported; the one at 20 s is still listening
    for address, f in out:
        assert address == "PMVHLBL"
        t0 = float(f[0])
        assert [f[1], f[3], f[5]] == ["1", "2", "3"]
        for b, value in zip(BEACONS, (f[2], f[4], f[6]), strict=True):
            assert float(value) == pytest.approx(_twtt_truth(moving, t0, b), abs=2e-6)
    # a stationary check by hand: 2 r / c + turn-around
    still = AcousticLbl(beacons=[Beacon("9", 300.0, 0.0, -0.5, 0.2)], noise_s=0.0)
    lines = run(SensorPort(still), lambda t: Truth(t, 0.0, 0.0, 0.0), 3.0)
    assert float(read_sentence(lines[0])[1][2]) == pytest.approx(0.2 + 600 / 1500, abs=1e-6)


def test_lbl_reported_when_window_closes_and_out_of_range_empty() -> None:
    lbl = AcousticLbl(beacons=BEACONS, listen_window_s=3.0, max_range_m=152.0)
    rng = np.random.default_rng(0)
    assert lbl.sample(moving(0.0), 0.0, rng) == []
    assert lbl.sample(moving(2.9), 2.9, rng) == []
    lines = lbl.sample(moving(3.0), 3.0, rng)
    assert len(lines) == 1
    f = read_sentence(lines[0])[1]
    assert f[2] != "" and f[4] == "" and f[6] != ""  # beacon 2 is 201 m away
    short = AcousticLbl(beacons=[Beacon("far", 1000.0, 0.0)], listen_window_s=1.0)  # 1.33 s
    assert short.sample(moving(0.0), 0.0, rng) == []
    assert read_sentence(short.sample(moving(1.0), 1.0, rng)[0])[1][2] == ""


def test_lbl_offset_and_multipath_fault_shift_one_beacon() -> None:
    base = dict(beacons=BEACONS, noise_s=0.0)
    clean = parsed(run(SensorPort(AcousticLbl(**base)), moving, 10.0))
    offset = parsed(run(SensorPort(AcousticLbl(**base, offset_m=3.0)), moving, 10.0))
    sc = Scenario.from_text("range_multipath from 4 to 100 bias=7.5 beacon=2")
    multi = parsed(run(SensorPort(AcousticLbl(**base), sc), moving, 10.0))
    for (_, c), (_, o), (_, m) in zip(clean, offset, multi, strict=True):
        for i in (2, 4, 6):
            assert float(o[i]) - float(c[i]) == pytest.approx(6.0 / 1500, abs=2e-6)
        hit = float(c[0]) >= 4.0
        assert float(m[4]) - float(c[4]) == pytest.approx(15.0 / 1500 if hit else 0.0, abs=2e-6)
        assert m[2] == c[2] and m[6] == c[6]


def test_radio_ranges_can_look_like_plaza1() -> None:
    """Plaza1: ranges minus truth have median +2.8 m, MAD 0.8 m, and outliers."""
    sc = Scenario.from_text("seed = 11\nrange_outlier always prob=0.05 sigma=30\n")
    sensor = RadioRanges(beacons=BEACONS, offset_m=2.8, noise_m=1.2, antenna_height_m=0.0)
    errs, ids = [], []
    for address, f in parsed(run(SensorPort(sensor, sc), circling, 1000.0, dt=0.1)):
        assert address == "PMVHRNG"
        tr = circling(float(f[0]))
        b = next(b for b in BEACONS if b.id == f[1])
        errs.append(float(f[2]) - math.dist((tr.x, tr.y, 0.0), (b.x, b.y, b.z)))
        ids.append(f[1])
    e = np.array(errs)
    assert len(e) == 2001 and ids[:4] == ["1", "2", "3", "1"]  # 2 Hz round robin
    median = np.median(e)
    mad = np.median(np.abs(e - median))
    assert median == pytest.approx(2.8, abs=0.15)
    assert mad == pytest.approx(0.8, abs=0.1)
    outliers = np.mean(e - 2.8 > 8.0)
    assert 0.025 < outliers < 0.07
    assert e.min() > -5.0  # outliers are long paths, never short


def test_radio_outlier_fault_selects_beacon_and_window() -> None:
    sc = Scenario.from_text("range_outlier from 10 to 20 prob=1 sigma=50 beacon=3")
    sensor = RadioRanges(beacons=BEACONS, noise_m=0.0, antenna_height_m=0.0, round_robin=False)
    for _, f in parsed(run(SensorPort(sensor, sc), moving, 30.0, dt=0.5)):
        t = float(f[0])
        tr = moving(t)
        b = next(b for b in BEACONS if b.id == f[1])
        err = float(f[2]) - math.dist((tr.x, tr.y, 0.0), (b.x, b.y, b.z))
        if f[1] == "3" and 10 <= t < 20:
            assert err > 0.01
        else:
            assert abs(err) < 0.002


# ------------------------------------------------------------------------------- faults


def test_nmea_gps_outage_sends_no_fix_then_recovers() -> None:
    sc = Scenario.from_text("nmea_gps_outage from 5 to 8 port=nmea_gps")
    out = parsed(run(SensorPort(NmeaGps(origin=ORIGIN), sc), moving, 12.0))
    qualities = [f[5] for a, f in out if a == "GPGGA"]
    assert qualities == ["1"] * 5 + ["0"] * 3 + ["1"] * 5
    status = [f[1] for a, f in out if a == "GPRMC"]
    assert status[5:8] == ["V"] * 3 and status[8] == "A"


def test_depth_dropout_full_and_partial() -> None:
    full = Scenario.from_text("depth_dropout from 2 to 4")
    out = parsed(run(SensorPort(EchoSounder(), full), moving, 6.0))
    empty = [float(f[0]) if f[0] else None for a, f in out if a == "SDDPT"]
    assert [i for i, d in enumerate(empty) if d is None] == [4, 5, 6, 7]  # t = 2, 2.5, 3, 3.5
    half = Scenario.from_text("seed = 2\ndepth_dropout always prob=0.5")
    out = parsed(run(SensorPort(EchoSounder(), half), moving, 100.0))
    lost = np.mean([f[0] == "" for a, f in out if a == "SDDPT"])
    assert 0.35 < lost < 0.65


def test_serial_garbage_breaks_lines_only_in_window() -> None:
    sc = Scenario.from_text("seed = 4\nserial_garbage from 2 to 4 port=heading prob=1")
    port = SensorPort(HeadingSensor(), sc)
    stamps, good, bad = [], 0, 0
    for i in range(61):
        t = i * 0.1
        before = len(port.output)
        port.update(moving(t), t)
        chunk = bytes(port.output[before:])
        if not chunk:
            continue
        try:
            read_sentence(chunk)
            good += 1
        except ParseError:
            bad += 1
            stamps.append(round(t, 1))
    assert bad == 20 and good == 41 and port.stats["garbled"] == 20
    assert stamps[0] == 2.0 and stamps[-1] == 3.9
    other = SensorPort(HeadingSensor(), sc, name="heading2")  # renames the sensor too
    assert other.sensor.name == "heading2"
    other.update(moving(3.0), 3.0)
    read_sentence(bytes(other.output))  # another port is not affected


def test_serial_truncate_cuts_before_checksum() -> None:
    sc = Scenario.from_text("seed = 8\nserial_truncate always port=depth prob=0.5")
    port = SensorPort(EchoSounder(), sc)
    lines = run(port, moving, 50.0)
    cut = [line for line in lines if "*" not in line]
    assert len(lines) == 202 and port.stats["truncated"] == len(cut)
    assert 0.35 < len(cut) / len(lines) < 0.65
    assert all(line.startswith("$") and len(line) >= 1 for line in cut)
    for line in lines:
        if "*" in line:
            read_sentence(line)


def test_latency_and_jitter_delay_lines_but_keep_order() -> None:
    sc = Scenario.from_text("seed = 5\nsensor_latency always sensor=dvl delay=0.5 jitter=0.3")
    port = SensorPort(DvlSensor(), sc)
    arrivals: list[tuple[float, float]] = []  # (time written, sample time stamp)
    for i in range(201):
        t = i * 0.05
        before = len(port.output)
        port.update(moving(t), t)
        for line in bytes(port.output[before:]).decode().split("\r\n")[:-1]:
            arrivals.append((t, float(read_sentence(line)[1][0])))
    delays = [w - s for w, s in arrivals]
    assert min(delays) >= 0.5 - 1e-9 and max(delays) <= 0.8 + 0.05 + 1e-9
    assert max(delays) - min(delays) > 0.1  # jitter really varies
    stamps = [s for _, s in arrivals]
    assert stamps == sorted(stamps)
    # no scenario, no delay
    plain = SensorPort(DvlSensor())
    plain.update(moving(0.0), 0.0)
    assert plain.output.startswith(b"$PMVHDVL,0.000,")


# ------------------------------------------------------------------------ determinism


def all_ports(scenario: Scenario) -> list[SensorPort]:
    sensors = [
        NmeaGps(origin=ORIGIN),
        HeadingSensor(),
        EchoSounder(),
        DvlSensor(),
        AcousticLbl(beacons=BEACONS),
        RadioRanges(beacons=BEACONS, offset_m=2.8, noise_m=1.2),
    ]
    return [SensorPort(s, scenario) for s in sensors]


FAULTY = """\
range_outlier always prob=0.1 sigma=30
range_multipath from 20 to 40 bias=5 beacon=2
serial_garbage from 10 to 30 port=nmea_gps prob=0.3
serial_truncate from 5 to 50 port=ranges prob=0.2
sensor_latency always sensor=dvl delay=0.2 jitter=0.2
depth_dropout from 30 to 40 prob=0.5
nmea_gps_outage from 45 to 50
"""


def streams(seed: int, text: str = FAULTY) -> list[bytes]:
    ports = all_ports(Scenario.from_text(f"seed = {seed}\n{text}"))
    for i in range(1201):
        t = i * 0.05
        update_all(ports, circling(t), t)
    return [bytes(p.output) for p in ports]


def test_same_seed_gives_bit_identical_streams() -> None:
    a, b = streams(42), streams(42)
    assert all(len(s) > 500 for s in a)
    assert a == b


def test_different_seed_gives_different_streams() -> None:
    a, c = streams(42), streams(43)
    assert all(x != y for x, y in zip(a, c, strict=True))


def test_line_faults_do_not_disturb_sensor_noise() -> None:
    """Garbage on one port must not change what any sensor measures (independent streams)."""
    clean = streams(42, "")
    dirty = streams(42, "serial_garbage always port=nmea_gps prob=0.5\n")
    assert clean[1:] == dirty[1:]
    assert clean[0] != dirty[0]
    good = [ln for ln in dirty[0].split(b"\r\n") if ln in set(clean[0].split(b"\r\n"))]
    assert len(good) > 30  # the ungarbled lines are the clean stream's lines
