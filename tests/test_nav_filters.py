"""pNav with its filters, on the bus: sensor lines in, EKF_*/LSQ_* and NAV_* out (spec 2.2).

A synthetic vehicle drives a known track; its sensors post what the serial readers and the
MAVLink bridge post. These pin the navigator's logic; the simulator and the real ArduPilot
SITL tests (test_nav_sim.py, benchmarks/bench_nav_ardupilot.py) prove it on the real path.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock
from mavhelm.core.mission import parse_mission
from mavhelm.nav.navigator import Navigator
from tests.support.mission import EKF_GPS_COMPASS


class MemoryLog:
    def __init__(self) -> None:
        self.olog_lines: list[str] = []
        self.xlog_lines: list[str] = []

    def olog(self, lines: list[str]) -> None:
        self.olog_lines.extend(lines)

    def xlog(self, lines: list[str]) -> None:
        self.xlog_lines.extend(lines)

    def flush(self) -> None:
        pass


class Rig:
    def __init__(self, body: str) -> None:
        self.clock = SimClock(1000.0)
        self.bus = Bus(self.clock)
        self.log = MemoryLog()
        text = "ProcessConfig = pNav\n{\n" + body + "\n}\n"
        self.nav = Navigator.from_mission(self.bus, parse_mission(text, "f.moos"), self.log)
        self.bus.subscribe(self.nav.name, self.nav.subscriptions())
        self.bus.subscribe("listener", ["*"])
        self.out: list[Message] = []

    def post(self, name: str, value: float, t: float | None = None) -> None:
        self.bus.notify(name, value, "sensor", t)

    def tick(self, dt: float = 0.1) -> None:
        self.clock.advance(dt)
        now = self.clock.now()
        self.nav.on_mail(self.bus.fetch(self.nav.name), now)
        self.nav.iterate(now)
        self.nav.idle()  # as the companion's loop does: the .olog/.xlog lines are written
        self.out.extend(m for m in self.bus.fetch("listener") if m.source == "pNav")

    def last(self, name: str) -> Message | None:
        found = [m for m in self.out if m.name == name]
        return found[-1] if found else None

    def values(self, name: str) -> list[float | str]:
        return [m.value for m in self.out if m.name == name]


def circle(t: float, r: float = 50.0, speed: float = 2.0) -> tuple[float, float, float]:
    """A vehicle on a circle, counter-clockwise: x, y, yaw (rad, MOOS)."""
    w = speed / r
    a = w * t
    x, y = r * math.cos(a), r * math.sin(a)
    # moving counter-clockwise: the velocity points along (−sin a, cos a), which is yaw a
    return x, y, a


GPS_COMPASS = EKF_GPS_COMPASS


def test_gps_and_compass_give_a_smoother_position_and_speed_from_positions_only() -> None:
    rig = Rig(GPS_COMPASS)
    rng = np.random.default_rng(1)
    raw, fused = [], []
    for k in range(1200):  # 120 s at 10 Hz, GPS at 1 Hz
        t = rig.clock.now()
        x, y, yaw = circle(t - 1000.0)
        rig.post("INS_YAW", yaw + rng.normal(0, math.radians(1.0)))
        if k % 10 == 0:
            gx, gy = x + rng.normal(0, 2.0), y + rng.normal(0, 2.0)
            rig.post("GPS_X", gx)
            rig.post("GPS_Y", gy)
            if k > 300:
                raw.append(math.hypot(gx - x, gy - y))
        rig.tick()
        if k > 300:
            ex, ey = rig.last("NAV_X"), rig.last("NAV_Y")
            tx, ty, _ = circle(ex.time - 1000.0)
            fused.append(math.hypot(ex.double - tx, ey.double - ty))
    raw_rms = math.sqrt(np.mean(np.square(raw)))
    fused_rms = math.sqrt(np.mean(np.square(fused)))
    print(f"\nGPS σ 2 m: raw RMS {raw_rms:.2f} m, EKF RMS {fused_rms:.2f} m")
    # on a circle (0.08 m/s² of unmodelled acceleration) at 1 Hz the constant-velocity model
    # can only do so much: measured 2.2 m against 2.9 m raw. The ArduPilot benchmark measures
    # the straight-leg boat case the issue asks about.
    assert fused_rms < 0.8 * raw_rms
    speeds = [float(v) for v in rig.values("EKF_SPEED")[-600:]]
    assert np.mean(speeds) == pytest.approx(2.0, abs=0.3)
    yaw_rates = [float(v) for v in rig.values("EKF_YAW_VEL")[-600:]]
    assert np.mean(yaw_rates) == pytest.approx(2.0 / 50.0, abs=0.01)
    assert rig.last("NAV_X_SOURCE").value == "EKF"
    assert any("started at the first gps fix" in str(v) for v in rig.values("NAV_WARNING"))
    accepted = [line for line in rig.log.olog_lines if " accepted " in line]
    assert len(accepted) > 1000 and rig.log.xlog_lines[0].startswith("# t X Y H")


def test_the_logs_are_written_in_the_idle_time_and_the_last_tick_at_close() -> None:
    """The tick keeps the .olog/.xlog values; the idle time after it formats and writes
    them; a navigator closed straight after a tick (the companion stopping) still writes
    that tick's."""
    rig = Rig(GPS_COMPASS)
    rig.post("INS_YAW", 0.3)
    rig.post("GPS_X", 1.0)
    rig.post("GPS_Y", 2.0)
    rig.tick()
    written = len(rig.log.olog_lines), len(rig.log.xlog_lines)
    assert written[0] >= 2 and written[1] >= 2  # the idle time wrote the first tick's
    rig.clock.advance(0.1)
    rig.post("INS_YAW", 0.31)
    now = rig.clock.now()
    rig.nav.on_mail(rig.bus.fetch(rig.nav.name), now)
    rig.nav.iterate(now)  # no idle time after this one
    assert (len(rig.log.olog_lines), len(rig.log.xlog_lines)) == written
    rig.nav.close()
    assert len(rig.log.olog_lines) > written[0] and len(rig.log.xlog_lines) > written[1]
    assert rig.log.olog_lines[-1].startswith("1000.200 compass ORIENTATION yaw=0.3100 ")


def test_an_unobservable_position_is_a_navigation_failure_that_ends_the_mission() -> None:
    rig = Rig(GPS_COMPASS + "  EKF_X = 0\n  EKF_Y = 0\n  EKF_SIGMA_XY = 5\n"
                            "  MaxEKFPositionUncertainty = 20\n")
    for _ in range(1200):
        rig.post("INS_YAW", 0.3)  # a compass alone: the position only grows uncertain
        rig.tick()
        if rig.values("NAVIGATION_FAILURE"):
            break
    failure = rig.values("NAVIGATION_FAILURE")
    assert len(failure) == 1 and "exceeds the limit 20 m" in str(failure[0])
    assert rig.values("EndMission")
    # off-line for good: nothing more from the filter
    n = len(rig.values("EKF_X"))
    for _ in range(20):
        rig.post("GPS_X", 0.0)
        rig.post("GPS_Y", 0.0)
        rig.tick()
    assert len(rig.values("EKF_X")) == n
    assert any(" offline" in line for line in rig.log.olog_lines)


def test_gps_jumps_of_50_m_are_rejected_and_logged() -> None:
    """With the jumps the estimate is what it is when those fixes never came: they moved it
    by nothing (less than 1 m is the brief)."""

    def run(jumps: bool) -> tuple[Rig, list[tuple[float, float]]]:
        rig = Rig(GPS_COMPASS)
        rng = np.random.default_rng(2)
        track = []
        for k in range(1500):
            x, y, yaw = circle(rig.clock.now() - 1000.0)
            rig.post("INS_YAW", yaw)
            noise = rng.normal(0, 2.0, size=2)
            if k % 10 == 0:
                in_jump = 900 <= k < 960
                if jumps or not in_jump:
                    rig.post("GPS_X", x + (50.0 if in_jump else 0.0) + noise[0])
                    rig.post("GPS_Y", y + noise[1])
            rig.tick()
            track.append((rig.last("EKF_X").double, rig.last("EKF_Y").double)
                         if rig.last("EKF_X") else (0.0, 0.0))
        return rig, track

    jumped, with_jumps = run(True)
    _, without = run(False)
    moved = max(math.hypot(a[0] - b[0], a[1] - b[1]) for a, b in zip(with_jumps, without,
                                                                       strict=True))
    assert moved < 1.0
    rejected = [line for line in jumped.log.olog_lines
                if " gps XY " in line and " rejected " in line]
    assert len(rejected) == 6
    # χ² distances beyond the 2-dof gate at 0.999 (13.8); they shrink as the coasting filter
    # grows less sure (273 for the first, 31 for the sixth): a jump that lasts long enough
    # is eventually believed, as it should be when the vehicle really was elsewhere
    assert all(float(line.split()[-1]) > 13.8 for line in rejected)


def test_late_data_are_logged_late_without_lag_and_used_with_it() -> None:
    body = GPS_COMPASS + "  SENSOR_DEPTH = DEPTH -> pressure ~ 0.05\n"
    for lag, expect_late in ((0.0, True), (2.0, False)):
        rig = Rig(body + f"  EKF_LAG = {lag}\n")
        for k in range(100):
            rig.post("INS_YAW", 0.0)
            if k % 10 == 0:
                rig.post("GPS_X", 0.0)
                rig.post("GPS_Y", 0.0)
                rig.post("DEPTH_DEPTH", 4.0, rig.clock.now() - 1.5)  # 1.5 s old
            rig.tick()
        late = [line for line in rig.log.olog_lines
                if " pressure DEPTH " in line and " late" in line]
        assert bool(late) is expect_late
        if not expect_late:
            assert rig.last("EKF_DEPTH").double == pytest.approx(4.0, abs=0.2)


def test_each_time_stamp_of_a_tick_is_a_slice_of_its_own() -> None:
    """Readings stamped apart within one tick are predicted to and updated at each stamp
    (spec 2.2's fine discretization of time); stamped alike, they are one slice. The count
    is what ``bench_tick_deployed`` prints: a companion on the wall clock takes several."""
    rig = Rig(GPS_COMPASS)
    for _ in range(20):
        rig.post("INS_YAW", 0.0)
        rig.post("GPS_X", 0.0)
        rig.post("GPS_Y", 0.0)
        rig.tick()
    fusion = rig.nav.fusion
    assert fusion is not None and fusion.ekf is not None
    before = fusion.slices
    for _ in range(10):
        last_tick = rig.clock.now()
        rig.post("INS_YAW", 0.0, last_tick + 0.02)
        rig.post("GPS_X", 0.0, last_tick + 0.05)
        rig.post("GPS_Y", 0.0, last_tick + 0.05)
        rig.tick()
    assert fusion.slices - before == 20
    before = fusion.slices
    for _ in range(10):
        rig.post("INS_YAW", 0.0)
        rig.post("GPS_X", 0.0)
        rig.post("GPS_Y", 0.0)
        rig.tick()
    assert fusion.slices - before == 10


def test_a_tlog_replays_through_the_missions_pnav_with_its_truth(tmp_path) -> None:
    """``mavhelm nav replay`` on a MAVLink .tlog: the frames go through the mission's bridge
    (GPS_RAW_INT → GPS_X/Y, ATTITUDE → INS_YAW, SIMSTATE → TRUTH_X/Y) and the pNav block's
    EKF is scored against the truth."""
    import struct
    import subprocess
    import sys

    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    from mavhelm.core.geodesy import Origin

    origin = Origin(56.4120, -5.4760)
    mission = tmp_path / "m.moos"
    mission.write_text("LatOrigin = 56.4120\nLongOrigin = -5.4760\nProcessConfig = pNav\n{\n"
                       + GPS_COMPASS + "}\n")
    ap = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    rng = np.random.default_rng(5)
    data = bytearray()
    t0 = 1_767_225_600.0
    for k in range(1200):  # 120 s: ATTITUDE and SIMSTATE at 10 Hz, GPS at 1 Hz
        t = k * 0.1
        x, y, yaw = circle(t)
        frames = [mavlink.MAVLink_attitude_message(int(t * 1000), 0.0, 0.0, -yaw, 0.0, 0.0, 0.0)]
        lat, lon = origin.to_global(x, y)
        frames.append(mavlink.MAVLink_simstate_message(0, 0, -yaw, 0, 0, 0, 0, 0, 0,
                                                       int(lat * 1e7), int(lon * 1e7)))
        if k % 10 == 0:
            glat, glon = origin.to_global(x + rng.normal(0, 2.0), y + rng.normal(0, 2.0))
            frames.append(mavlink.MAVLink_gps_raw_int_message(
                int(t * 1e6), 3, int(glat * 1e7), int(glon * 1e7), 0, 100, 100, 200, 0, 10))
        for frame in frames:
            data += struct.pack(">Q", round((t0 + t) * 1e6)) + frame.pack(ap)
    log = tmp_path / "run.tlog"
    log.write_bytes(bytes(data))
    done = subprocess.run([sys.executable, "-m", "mavhelm.cli", "nav", "replay", str(mission),
                           str(log)], capture_output=True, text=True, check=False)
    print("\n" + done.stdout)
    assert done.returncode == 0, done.stdout + done.stderr
    lines = {ln.split()[0]: ln for ln in done.stdout.splitlines() if "position:" in ln}
    gps_rms = float(lines["GPS"].split("RMS ")[1].split(" m")[0])
    nav_rms = float(lines["NAV"].split("RMS ")[1].split(" m")[0])
    assert 2.0 < gps_rms < 4.0 and nav_rms < 0.8 * gps_rms
    assert (tmp_path / "run_replay.olog").read_text().count(" gps XY ") >= 100


def test_lsq_rejection_drops_a_channels_outlier_before_the_filters_see_it() -> None:
    from mavhelm.nav.sensor_channel import SensorChannel

    channel = SensorChannel(points=8, tolerance=2.0)
    ranges = [100.0 + 1.5 * k for k in range(8)]  # a beacon being approached steadily
    assert all(channel.test(float(k), r) for k, r in enumerate(ranges))
    assert not channel.test(8.0, 112.0 + 30.0)  # multipath: 30 m long
    assert channel.test(9.0, 113.5)  # back on the line
    assert channel.rejected == 1
    rig = Rig(GPS_COMPASS + "  SENSOR_RANGE = RNG -> uwb ~ 0.5\n  BEACON = 1 @ 0,0,0\n"
                            "  LSQ_REJECTION = uwb @ 6, 2.0\n  LSQ = false\n")
    for k in range(60):
        rig.post("RNG_RANGE_1", 50.0 + (40.0 if k == 40 else 0.0))
        rig.tick()
    outliers = [line for line in rig.log.olog_lines if " outlier" in line]
    assert len(outliers) == 1 and "range=90.000" in outliers[0]


def test_a_static_vehicle_has_no_rates_and_fixed_depth_and_tide_pin_z() -> None:
    rig = Rig("  X = EKF\n  Y = EKF\n  Depth = EKF\n  SENSOR_XY = GPS -> gps ~ 2\n"
              "  EKF_MOBILE = false\n  FIXEDDEPTH = 0 @ 0.05\n  FIXEDTIDE = 1.5 @ 0.05\n"
              "  EKF_TIDE = true\n  SENSOR_DEPTH = P -> pressure ~ 0.1\n")
    rng = np.random.default_rng(3)
    for k in range(300):
        if k % 10 == 0:
            rig.post("GPS_X", 10.0 + rng.normal(0, 2.0))
            rig.post("GPS_Y", -5.0 + rng.normal(0, 2.0))
        rig.tick()
    assert rig.last("EKF_X").double == pytest.approx(10.0, abs=1.5)
    assert rig.last("EKF_SPEED").double == 0.0  # a static vehicle: no rate states
    assert rig.last("NAV_DEPTH").double == pytest.approx(0.0, abs=0.05)
    assert rig.last("EKF_TIDE").double == pytest.approx(1.5, abs=0.05)
    assert rig.last("EKF_Z").double == pytest.approx(1.5, abs=0.1)  # depth = tide − Z


def test_a_gps_antenna_on_a_lever_arm_is_explained_where_it_is() -> None:
    """An antenna 2 m to starboard: as the boat turns, its fixes circle the hull; with the
    lever arm declared the filter puts the vehicle's origin where it is, without it 2 m off."""
    errors = {}
    for lever in ("2,0,0", "0,0,0"):
        rig = Rig(GPS_COMPASS.replace("SENSOR_XY = GPS -> gps @ 0,0,0 ~ 2.0",
                                      f"SENSOR_XY = GPS -> gps @ {lever} ~ 0.3"))
        for _k in range(1200):
            t = rig.clock.now() - 1000.0
            x, y, yaw = circle(t)
            rig.post("INS_YAW", yaw)
            if _k % 5 == 0:  # starboard is (cos H, sin H)
                rig.post("GPS_X", x + 2.0 * math.cos(yaw))
                rig.post("GPS_Y", y + 2.0 * math.sin(yaw))
            rig.tick()
        e = rig.last("EKF_X")
        tx, ty, _ = circle(e.time - 1000.0)
        errors[lever] = math.hypot(e.double - tx, rig.last("EKF_Y").double - ty)
    assert errors["2,0,0"] < 0.3 < 1.5 < errors["0,0,0"]


def test_a_replay_ignores_the_recorded_runs_own_nav_outputs() -> None:
    from mavhelm.nav.replay import replay

    block = parse_mission("ProcessConfig = pNav\n{\n" + GPS_COMPASS + "}\n", "r.moos").processes
    messages = []
    for k in range(300):
        t = 100.0 + 0.1 * k
        messages.append(Message("INS_YAW", 0.0, t, "iMAVLink"))
        if k % 10 == 0:
            messages += [Message("GPS_X", 5.0, t, "iMAVLink"), Message("GPS_Y", 7.0, t, "iMAVLink")]
        # what the live navigator recorded: must not be scored or routed again
        messages += [Message("NAV_X", 999.0, t, "pNav"), Message("NAV_Y", 999.0, t, "pNav"),
                     Message("EKF_X", 999.0, t, "pNav"), Message("EKF_Y", 999.0, t, "pNav")]
    result = replay(block["pNav"], messages)
    assert result.tracks["NAV"].x and max(result.tracks["NAV"].x) < 10.0
    assert len(result.tracks["NAV"].t) == len(set(result.tracks["NAV"].t))


def test_the_forecast_through_the_lag_reads_an_odometers_heading_as_the_filter_does() -> None:
    """EKF_LAG: the estimate brought forward to now dead-reckons the readings queued within
    the lag. An odometer's heading drifting 1°/s (its yaw rate reading the same drift): the
    filter's bias and drift take it out, and the forecast must too, the bias as it drifted
    since the filter's time and the rate less the drift (1.1° off through a 1 s lag when it
    took the heading less the filter's bias then and the rate as read; 0.000005° now)."""
    rig = Rig("""  X = EKF
  Y = EKF
  Heading = EKF
  EKF_LAG = 1
  EKF_YAW_BIAS = true
  SENSOR_XY          = GPS -> gps ~ 0.3
  SENSOR_ORIENTATION = ODOM -> odometer_heading ~ 0.5
  SENSOR_BODY_VEL    = ODOM -> odometer ~ 0.05, 0.05, 0.5
""")
    drift = math.radians(1.0)
    worst = 0.0
    for k in range(3000):  # north at 1 m/s, yaw 0, 10 Hz; a fix a second
        elapsed = rig.clock.now() - 1000.0
        rig.post("ODOM_YAW", math.remainder(drift * elapsed, 2 * math.pi))
        rig.post("ODOM_VX_BODY", 1.0)
        rig.post("ODOM_VY_BODY", 0.0)
        rig.post("ODOM_YAW_VEL", drift)
        if k % 10 == 0:
            rig.post("GPS_X", 0.0)
            rig.post("GPS_Y", elapsed)
        rig.tick()
        yaw = rig.last("NAV_YAW")
        if k > 2000 and yaw is not None:
            worst = max(worst, abs(math.remainder(yaw.double, 2 * math.pi)))
    assert worst < math.radians(0.1)
