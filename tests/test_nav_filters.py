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


class MemoryLog:
    def __init__(self) -> None:
        self.olog_lines: list[str] = []
        self.xlog_lines: list[str] = []

    def olog(self, lines: list[str]) -> None:
        self.olog_lines.extend(lines)

    def xlog(self, lines: list[str]) -> None:
        self.xlog_lines.extend(lines)


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


GPS_COMPASS = """
  X = EKF @ 2
  Y = EKF @ 2
  Yaw = EKF @ 2
  Speed = EKF @ 2
  SENSOR_XY = GPS -> gps @ 0,0,0 ~ 2.0
  SENSOR_ORIENTATION = INS -> compass @ 0,0,0 ~ 1.0
"""


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


def test_an_unobservable_position_is_a_navigation_failure_that_ends_the_mission() -> None:
    rig = Rig(GPS_COMPASS + "  EKF_X = 0\n  EKF_Y = 0\n  EKF_SIGMA_XY = 5\n"
                            "  EKF_MAX_SIGMA_XY = 20\n")
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
