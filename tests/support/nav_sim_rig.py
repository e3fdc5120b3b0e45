"""A boat patrolling a box in ``mavhelm sim`` (lockstep, over TCP) with its serial instruments
on real pseudo-terminals, read by the companion's iSerial readers, fused by pNav, steered by
the helm on NAV_*: the navigator's whole real path, for the simulator tests of issue 9."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mavhelm.core.bus import Message
from mavhelm.core.mission import parse_mission
from mavhelm.demo.harness import SimulatedRun
from mavhelm.sitl.faults import Scenario
from mavhelm.sitl.serial_sensors import (
    AcousticLbl,
    Beacon,
    DvlSensor,
    HeadingSensor,
    PtySerialPort,
    RadioRanges,
)
from tests.support.mission import mission_text as standard_mission

LAT, LON = 56.4120, -5.4760
BEACONS = (Beacon("1", -60.0, -60.0, -1.0), Beacon("2", 160.0, -50.0, -1.0),
           Beacon("3", 50.0, 160.0, -1.0))
"""Three radio beacons on posts around the box (1 m below the antenna plane: the receiver's
antenna is 1 m up), within the receivers' 300 m of every corner."""
LBL_BEACONS = (Beacon("1", -150.0, -150.0, -20.0, 0.05), Beacon("2", 300.0, -150.0, -20.0, 0.1),
               Beacon("3", 60.0, 300.0, -20.0, 0.15))
"""Seabed transponders, 20 m down, with their turn-around times (s)."""

DEAD_RECKONING = """
    X = GPS @ 2, EKF @ 2
    Y = GPS @ 2, EKF @ 2
    Heading = HDG @ 1, INS @ 1
    SENSOR_XY          = GPS -> gps ~ 2
    SENSOR_ORIENTATION = HDG -> compass ~ 0.5
    SENSOR_BODY_VEL    = DVL -> dvl @ 0,0,-0.3 ~ 0.02, 0.02
    SENSOR_BODY_VEL    = INS -> gyro ~ 0.5
"""
"""The box patrol's pNav on GPS, compass, DVL and gyro (the EKF dead-reckons through a GPS
outage): the simulator test's and the nav benchmark's."""

RANGES = """
    X = GPS @ 2, EKF @ 2
    Y = GPS @ 2, EKF @ 2
    Heading = HDG @ 1, INS @ 1
    SENSOR_XY          = GPS -> gps ~ 2
    SENSOR_ORIENTATION = HDG -> compass ~ 0.5
    SENSOR_BODY_VEL    = INS -> gyro ~ 0.5
    SENSOR_RANGE       = RNG -> radio @ 0,0,1 ~ 0.3
    FIXEDSIDESLIP      = 0 @ 0.3
    BEACON = 1 @ -60,-60,-1
    BEACON = 2 @ 160,-50,-1
    BEACON = 3 @ 50,160,-1
"""
"""GPS, compass, gyro and three radio beacons (no DVL): the simulator tests' ranging pNav."""

BOX = """
    Task = XYPattern
    {
        Name     = Box
        Priority = 3
        Location = 0,0
        Location = 100,0
        Location = 100,100
        Location = 0,100
        Repeat   = FOREVER
        Radius   = 8
        Thrust   = %s
        TimeOut  = 3000
    }
"""


def mission_text(serial: str, nav: str, *, thrust: float = 60.0,
                 imavlink: Iterable[tuple[str, object]] = ()) -> str:
    """The box patrol mission (also the ArduPilot benchmark's) with these iSerial blocks,
    pNav lines, thrust and extra iMAVLink settings."""
    return standard_mission(
        BOX % f"{thrust:g}", origin=(LAT, LON), blocks=serial, nav=nav,
        imavlink=[("Connect", "tcp:127.0.0.1:5760"), ("OnlineModes", "GUIDED"),
                  ("MaxTurnRate", 45), *imavlink],
        helm={"AppTick": 10, "MAXRUDDER": 30}, overall_timeout=3000)


SERIAL = """
ProcessConfig = iSerial_{label}
{{
    Name      = {name}
    Port      = {port}
    Sentences = {sentences}
}}
"""


@dataclass
class NavRun:
    """What the run recorded: NAV_*/EKF_* posts, truth at every tick, and the run itself."""

    run: SimulatedRun
    ports: list[PtySerialPort]
    messages: list[Message] = field(default_factory=list)

    def series(self, name: str) -> list[Message]:
        return [m for m in self.run.messages if m.name == name]

    def truth_at(self, t: float) -> tuple[float, float]:
        times = np.array([tr.t for tr in self.run.track])
        i = int(np.clip(np.searchsorted(times, t), 0, len(times) - 1))
        tr = self.run.track[i]
        return tr.x, tr.y

    def errors(self, source: str, t0: float = -math.inf, t1: float = math.inf
               ) -> list[tuple[float, float]]:
        """(time, horizontal error against truth) of a source's X/Y posts."""
        xs = {m.time: m.double for m in self.series(f"{source}_X")}
        ys = {m.time: m.double for m in self.series(f"{source}_Y")}
        out = []
        for t in sorted(set(xs) & set(ys)):
            if t0 <= t <= t1:
                tx, ty = self.truth_at(t)
                out.append((t, math.hypot(xs[t] - tx, ys[t] - ty)))
        return out

    def distance_travelled(self, t0: float, t1: float) -> float:
        pts = [(tr.x, tr.y) for tr in self.run.track if t0 <= tr.t <= t1]
        return float(sum(math.hypot(b[0] - a[0], b[1] - a[1]) for a, b in zip(pts, pts[1:],
                                                                               strict=False)))

    def olog(self) -> list[str]:
        logs = self.run.companion.nav_logs
        assert logs is not None, "start(..., logs=True) writes the nav logs"
        return logs.olog_path.read_text().splitlines()

    def close(self) -> None:
        self.run.close()
        for port in self.ports:
            port.close()


def start(nav_lines: str, *, ranging: str | None = None, scenario: str = "",
          tmp_path: Path, seed: int = 3, dvl: bool = True, record: tuple[str, ...] = (),
          beacons: tuple[Beacon, ...] | None = None, logs: bool = False,
          dvl_scale_error: float = 0.0) -> NavRun:
    """The boat with a heading sensor, a DVL (if ``dvl``) and a ranging receiver (``radio``,
    ``acoustic`` or None; ``beacons`` the ones it hears, default all), the given pNav lines,
    and the fault ``scenario`` text. ``logs``: write the alog and the .olog/.xlog in
    ``tmp_path``. ``dvl_scale_error``: the DVL's speeds that much long (0.05: 5 %)."""
    sc = Scenario.from_text(f"seed = {seed}\n{scenario}", name="nav")
    sensors: list = [HeadingSensor()]
    if dvl:
        sensors.append(DvlSensor(scale_error=dvl_scale_error))
    if ranging == "radio":
        sensors.append(RadioRanges(beacons=beacons or BEACONS, round_robin=False))
    elif ranging == "acoustic":
        sensors.append(AcousticLbl(beacons=beacons or LBL_BEACONS))
    ports = [PtySerialPort(s, sc) for s in sensors]
    kinds = {"heading": ("HDG", "HDT"), "dvl": ("DVL", "PMVHDVL"),
             "ranges": ("RNG", "PMVHRNG"), "lbl": ("LBL", "PMVHLBL")}
    serial = "".join(SERIAL.format(label=p.name, name=kinds[p.name][0], port=p.slave_path,
                                   sentences=kinds[p.name][1]) for p in ports)
    text = mission_text(serial, nav_lines)
    mission = parse_mission(text, str(tmp_path / "nav.moos"))
    names = {f"{s}_{k}" for s in ("NAV", "EKF", "LSQ", "GPS") for k in ("X", "Y")}
    names |= {"NAV_X_SOURCE", "NAV_WARNING", "NAVIGATION_FAILURE", "EndMission",
              "EKF_SPEED", "TASK_STARTED", *record}
    # the companion navigates through the outage itself: the autopilot's EKF failsafe (HOLD
    # when its own position is lost) would take the vehicle from it, as on a real boat
    run = SimulatedRun.start(mission, scenario=sc, seed=seed, serial_sensors=ports,
                             record=names, params={"FS_EKF_ACTION": 0},
                             alog_path=tmp_path / "nav.alog" if logs else None)
    return NavRun(run, ports)
