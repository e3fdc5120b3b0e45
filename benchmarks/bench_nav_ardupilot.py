"""Benchmark: pNav against the real ArduPilot Rover SITL and its own EKF3 (issue 9, "Proven
against ArduPilot").

Both experiments run the real SITL (``MAVHELM_ARDUPILOT``, motorboat, ``--speedup 5``, calm
water: ``SIM_WIND_SPD 0``, ``SIM_WAVE_ENABLE 0``; ``--wind`` keeps the stock wind and waves),
the companion as ``mavhelm run MISSION --clock autopilot`` on SERIAL1 (tests/support/ardupilot.py's
``CompanionProcess``) and a ground station on SERIAL0 (``RealOperator``) that arms the boat in
GUIDED; the clocks start once the companion says ``helm ONLINE``. The mission patrols a 100 m
box (XYPattern, Repeat FOREVER, Thrust 60) steered on NAV_*, and asks for ``SIMSTATE@10`` so
the .alog holds the SITL's ground truth (TRUTH_X/Y/HEADING). Every figure is read from the
companion's .alog (``read_alog``; positions scored with ``mavhelm.nav.replay.accuracy``, the
truth interpolated at each estimate's time). Asserts nothing. (``--speedup 10`` starves the
companion on two cores once the instruments run too: it fell 90 autopilot s behind.)

1. **GPS noise.** pNav is fed GPS_RAW_INT and ATTITUDE only (``SENSOR_XY = GPS``,
   ``SENSOR_ORIENTATION = INS``, ``FIXEDSIDESLIP``; every queue ``= EKF``), never the
   autopilot's GLOBAL_POSITION_INT. The SITL is started with ``SIM_GPS1_NOISE 2`` as the issue
   says, but in ArduPilot that parameter is the GPS's *vertical* error only (its description:
   "Amplitude of the GPS vertical position error", a slow sine on the altitude; this build has
   no horizontal-noise parameter, SIM_GPS1_HNSE came later): measured here, it leaves the
   horizontal fix exactly on the truth. So the ground station adds the horizontal noise itself
   through the SITL's own glitch offsets: it sets ``SIM_GPS1_GLTCH_X``/``_Y`` (degrees of
   latitude/longitude) to a fresh Gaussian draw, σ = 2 m on each axis, 10 times per autopilot
   second (the GPS samples at 5 Hz: each fix gets its own draw; lag-1 correlation ≈ 0,
   measured). ArduPilot's EKF3 thus sees the same noisy GPS as pNav (but a noise-free GPS
   velocity, which it fuses and pNav cannot), and its error (AP_X/AP_Y, GLOBAL_POSITION_INT)
   is printed beside pNav's. Also: NAV_SPEED against the true speed (from the truth positions)
   and the heading rate (EKF_YAW_VEL) against the true one (from TRUTH_HEADING); ``--gyro`` adds
   ATTITUDE's yaw rate as a sensor, otherwise the rate is estimated from compass and positions.
   Tuned on replays of recorded runs: ``EKF_XY_DYNAMICS 3`` and ``EKF_YAW_BIAS`` (ArduPilot's
   ATTITUDE yaw reads ~1.4° off the truth) took the replayed ratio from 0.45 to 0.41; tried and
   no better: EKF_XY_DYNAMICS 0.2-2 (turns lag), EKF_YAW_DYNAMICS 1/10, FIXEDSIDESLIP σ
   0.02-0.1, the gyro. The live figure is printed with the same pNav replayed offline over the
   run's .alog, and the number of GPS fixes the live pNav took (see the note it prints: the
   bridge stamps GPS_X and GPS_Y with two clock readings, so the live pNav drops fixes).
   Lateness: the GPS fixes reach the companion 0.16-0.26 s after the truth they measured:
   the SITL's 0.1 s GPS lag plus the fix's age on arrival, 0.06-0.18 s (GPS_RAW_INT's 5 Hz
   stream is out of step with the 5 Hz fixes, by a phase drawn anew each run), printed from
   the .tlog with the GPS's and NAV's lateness against the truth. Before the bridge posted
   that age (GPS_AGE) and pNav moved the fix on by it, NAV trailed the boat by the whole of
   it, and the published σ (EKF_TIME_SIGMA 0.1 s) missed the bias: four runs, ratio
   0.35-0.42, NEES 2.37-3.56, 87-93 % of ticks in the 95 % band. After (two runs): NAV
   0.08-0.11 s behind (the receiver's lag, which EKF_TIME_SIGMA covers), ratio 0.32, NEES
   2.16-2.17, 94 % in the band, 4 % above; what is left is along the track and no worse in
   turns (replayed: along-track NEES 1.3, cross 0.8).
2. **GPS off 120 s.** ``mavhelm instruments --truth tcp:127.0.0.1:<SERIAL2> --origin ...
   --ranging radio --beacons ...`` serves the simulator's serial instruments (HDT heading,
   $PMVHDVL body velocity, $PMVHRNG radio ranges to three beacons) from the real SITL's
   SIMSTATE/SIM_STATE; the companion reads them with iSerial blocks and pNav fuses GPS +
   compass + DVL + ATTITUDE gyro + ranges (``X = GPS @ 2, EKF @ 2``; the sim tests' lines, with
   ``EKF_XY_DYNAMICS``/``EKF_YAW_DYNAMICS 10`` for the real hull's turns, ``EKF_MAX_SPEED 15``,
   and ``LSQTimeOut NEVER``: the LSQ's static model seldom fixes on a boat moving at 4 m/s
   with round-robin ranges, one beacon each 0.5 s, and its 30 s time-out once declared
   navigation failure 5 s into the outage with the EKF within 0.5 m). The SITL runs with
   ``FS_EKF_ACTION 0`` (else ArduPilot's EKF failsafe takes the boat from GUIDED when its GPS
   goes) and ``GPS_FREE_GUIDED`` (below: stock Rover steers and throttles on EKF3's velocity,
   and runs away once EKF3 stops aiding; ``--stock-autopilot`` shows it). After a minute of
   patrol the ground station sets ``SIM_GPS1_ENABLE 0`` for 120 autopilot seconds, then 1.
   Printed: pNav's NAV error against truth throughout the outage (the span without GPS_X in
   the .alog), EKF3's drift (GLOBAL_POSITION_INT against SIMSTATE, both as the ground station
   received them; the companion takes AP_* only while EKF_STATUS_REPORT says the position is
   valid), and when NAV_X_SOURCE fell back to EKF and popped back to GPS. The NEES during the
   outage was 1.4-2.5 (91-96 % in the band) with the excess across the track in turns (the
   heading stamped ~0.1 s late: cross-track NEES 2.6-3.1 at 5-20 deg/s); a heading widened
   by EKF_TIME_SIGMA times the turn rate: 1.39, 97 % live (replays of four runs: 1.4-2.3,
   94.6-97.5 %).

3. **Faults.** The outage run's .alog replayed with each fault of the library made on it
   (``mavhelm nav replay --fault all``, scored against the SITL's truth): RMS and max of NAV
   and the EKF, the best source, NEES and decisions. NAV follows this mission's queue, the
   raw GPS first (glitches and all, as spec 2.1 maps a sensor straight through); the EKF is
   pNav's own. The same kept run before → after the fix watch (:mod:`mavhelm.nav.fix_watch`),
   the ranges asked for the heading every second and a GPS booting the filter among beacons
   (EKF RMS / max): the compass 176° out from the start 2.21 / 30.2 → 1.03 / 15.7 m (4 s of
   refused GPS fixes before); the gyro's sign reversed 1.82 / 26.5 → 1.00 / 14.4 m; a beacon
   5 m off its survey 1.35 m, NEES 8.1 → 0.46 m, NEES 1.35; GPS glitches max 3.5 → 1.8 m.
   On a second run a beacon off its survey was a navigation failure at 89 s before (the LSQ,
   fixing seldom on the moving boat, never booted the filter and its median shift passed
   20 m): 0.42 m after. A fresh run after all three: every fault 0.36-0.47 m but the compass
   turned (0.89 m), the gyro reversed (0.80 m) and 60 s without ranges inside the GPS
   outage (2.27 m, NEES 1.23: dead reckoning, honestly told).

Targets (issue 9): NAV error ≤ half the raw GPS error; ≤ 2 m throughout the outage.

Without MAVHELM_ARDUPILOT, says so and exits 0. About 2.5 minutes of wall time. Run:
``MAVHELM_ARDUPILOT=../shared/ardupilot/ardurover .venv/bin/python
-m benchmarks.bench_nav_ardupilot`` (``--only noise,outage``; ``--keep DIR`` runs in DIR and
keeps the logs: .alog, .olog/.xlog, the SITL's and the instruments' output).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import re
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.alog import read_alog
from mavhelm.core.bus import Message
from mavhelm.core.geodesy import Origin
from mavhelm.core.mission import parse_mission
from mavhelm.nav.replay import Accuracy, Consistency, accuracy, nees, replay
from tests.support.ardupilot import (
    SKIP_REASON,
    CompanionProcess,
    RealOperator,
    RealSitl,
    ardupilot_binary,
)
from tests.support.nav_sim_rig import BEACONS as RIG_BEACONS
from tests.support.nav_sim_rig import LAT, LON, SERIAL
from tests.support.nav_sim_rig import mission_text as rig_mission
from tests.support.processes import ConsoleProcess
from tests.support.waiting import wait_for

ROOT = Path(__file__).resolve().parent.parent
LAT0, LON0 = LAT, LON                  # the mission's origin = the SITL's home
HOME_HEADING = 90.0
SPEEDUP = 5                            # 10 starves the companion on 2 cores
HAND_OVER_WALL_S = 60.0
CALM = {"SIM_WIND_SPD": 0, "SIM_WAVE_ENABLE": 0}
GPS_FREE_GUIDED = {"ATC_SPEED_P": 0, "ATC_SPEED_I": 0, "ATC_SPEED_D": 0,
                   "MOT_SPD_SCA_BASE": 0, "ATC_STR_RAT_FF": 0.18, "ATC_STR_RAT_P": 0.048,
                   "ATC_STR_RAT_I": 0.048}
"""Rover's GUIDED made independent of its own EKF's velocity, for the GPS outage: ArduPilot
closes its speed loop on EKF3's velocity, and scales its steering down by EKF3's ground speed
above MOT_SPD_SCA_BASE (1 m/s). Once EKF3 "stopped aiding" (7 s without GPS) its velocity
decays, so the speed loop opens the throttle (the boat ran away at 10 m/s, measured) and the
steering runs unscaled, 3-4 times too strong (the rudder chattered, the hull swinging +-80 deg
in a second, measured). Here the throttle is the CRUISE_SPEED/CRUISE_THROTTLE feed-forward
alone (ATC_SPEED_P/I/D 0: Thrust 60 gives ~4.2 m/s) and the steering is never speed-scaled,
with the turn-rate gains (rover.parm's FF 0.75, P and I 0.2) cut to what the scaling gave at
that speed (x 1/4.2). ``--stock-autopilot`` leaves them as they are."""


NOISE_SIGMA_M = 2.0                    # per axis
NOISE_HZ = 10.0                        # glitch draws per autopilot second (the GPS: 5 Hz)
PATROL_S = 300.0                       # autopilot s of patrol with the noisy GPS
SETTLE_S = 30.0                        # autopilot s after the hand-over not scored

BEFORE_OUTAGE_S = 60.0
OUTAGE_S = 120.0
AFTER_OUTAGE_S = 50.0
BEACONS = tuple((int(b.id), b.x, b.y, b.z) for b in RIG_BEACONS)
"""The simulator tests' three radio beacons, as (id, x, y, z)."""
M_PER_DEG_LAT = 111_194.93             # the SITL's spherical earth (6371 km)

NAV_NOISE = """\
    X       = EKF @ 2
    Y       = EKF @ 2
    Speed   = EKF @ 2
    Heading = EKF @ 2
    SENSOR_XY          = GPS -> gps ~ 2
    SENSOR_ORIENTATION = INS -> compass ~ 1
    FIXEDSIDESLIP      = 0 @ 0.3
    EKF_XY_DYNAMICS    = 3
    EKF_YAW_BIAS       = true
"""
GYRO = "    SENSOR_BODY_VEL    = INS -> gyro ~ 0.5\n"

NAV_OUTAGE = """\
    X       = GPS @ 2, EKF @ 2
    Y       = GPS @ 2, EKF @ 2
    Speed   = GPS @ 2, EKF @ 2
    Heading = HDG @ 1, INS @ 1
    SENSOR_XY          = GPS -> gps ~ 2
    SENSOR_ORIENTATION = HDG -> compass ~ 0.5
    SENSOR_BODY_VEL    = DVL -> dvl @ 0,0,-0.3 ~ 0.02, 0.02
    SENSOR_BODY_VEL    = INS -> gyro ~ 0.5
    SENSOR_RANGE       = RNG -> radio @ 0,0,1 ~ 0.3
    EKF_XY_DYNAMICS    = 10
    EKF_YAW_DYNAMICS   = 10
    EKF_MAX_SPEED      = 15
    LSQTimeOut         = NEVER
""" + "".join(f"    BEACON = {i} @ {x:g},{y:g},{z:g}\n" for i, x, y, z in BEACONS)

INSTRUMENTS = {"heading": ("HDG", "HDT"), "dvl": ("DVL", "PMVHDVL"),
               "ranges": ("RNG", "PMVHRNG")}
"""The instruments' ports the companion reads: pty name → (iSerial Name, Sentences)."""


def mission_text(nav: str, serial: str = "", thrust: float = 60.0) -> str:
    """The simulator tests' box patrol (tests/support/nav_sim_rig.py), with SIMSTATE streamed to the
    companion: the truth every figure here is scored against."""
    return rig_mission(serial, nav, thrust=thrust, imavlink=[("Stream", "SIMSTATE@10")])


# ---- the ground station -------------------------------------------------------------------------

class Operator(RealOperator):
    """RealOperator that also keeps what the autopilot's EKF3 said (GLOBAL_POSITION_INT,
    EKF_STATUS_REPORT flags) and the parameter values it echoed."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.positions: list[tuple[int, int, int]] = []     # boot ms, lat, lon (1e-7 deg)
        self.ekf_flags: list[tuple[int | None, int]] = []   # boot ms, flags (changes only)
        self.param_values: dict[str, float] = {}

    def _handle(self, msg, now: float) -> None:
        super()._handle(msg, now)
        if msg.get_type() == "BAD_DATA" or (msg.get_srcSystem(), msg.get_srcComponent()) != (
                self.target_system, self.target_component):
            return
        kind = msg.get_type()
        if kind == "GLOBAL_POSITION_INT":
            self.positions.append((msg.time_boot_ms, msg.lat, msg.lon))
        elif kind == "EKF_STATUS_REPORT":
            if not self.ekf_flags or self.ekf_flags[-1][1] != msg.flags:
                self.ekf_flags.append((self.boot_ms, msg.flags))
        elif kind == "PARAM_VALUE":
            self.param_values[msg.param_id.rstrip("\x00")] = msg.param_value

    def set_param(self, name: str, value: float, timeout_s: float = 10.0) -> int | None:
        """PARAM_SET, again every 0.3 wall s until the autopilot echoes the value; returns the
        autopilot's boot ms when it did."""
        self.param_values.pop(name, None)
        t0 = time.monotonic()
        while time.monotonic() - t0 < timeout_s:
            self.conn.mav.param_set_send(self.target_system, self.target_component,
                                         name.encode(), value,
                                         mavlink.MAV_PARAM_TYPE_REAL32)
            t1 = time.monotonic()
            while time.monotonic() - t1 < 0.3:
                self.poll(0.01)
                got = self.param_values.get(name)
                if got is not None and abs(got - value) <= 1e-6 * max(1.0, abs(value)):
                    return self.boot_ms
        raise TimeoutError(f"{name} = {value:g} not acknowledged in {timeout_s:g} s")

    def truth_local(self, origin: Origin) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        rows = [(boot / 1000.0, *origin.to_local(lat * 1e-7, lng * 1e-7))
                for _, boot, lat, lng, _ in self.simstates if boot is not None]
        a = np.array(rows, dtype=float).reshape(-1, 3)
        return a[:, 0], a[:, 1], a[:, 2]


class GpsNoise:
    """Horizontal GPS noise for the real SITL: a new SIM_GPS1_GLTCH_X/_Y (degrees) from
    N(0, sigma) on each axis ``hz`` times per autopilot second, not waiting for the echoes.
    The ground station hears the autopilot's clock only at its stream rate (4 Hz), so the
    autopilot time is extrapolated in between at the speed-up."""

    def __init__(self, op: Operator, sigma_m: float, hz: float, speedup: float,
                 seed: int = 1) -> None:
        self.op, self.sigma, self.period_ms = op, sigma_m, 1000.0 / hz
        self.speedup = speedup
        self.rng = np.random.default_rng(seed)
        self.next_ms: float | None = None
        self.draws = 0
        self.m_per_deg_lon = M_PER_DEG_LAT * math.cos(math.radians(LAT0))
        self._heard: tuple[int, float] | None = None   # (boot ms, wall s when first seen)

    def autopilot_ms(self) -> float | None:
        boot = self.op.boot_ms
        if boot is None:
            return None
        now = time.monotonic()
        if self._heard is None or boot != self._heard[0]:
            self._heard = (boot, now)
        return boot + min(1000.0 * self.speedup * (now - self._heard[1]), 500.0)

    def step(self) -> None:
        boot = self.autopilot_ms()
        if boot is None:
            return
        if self.next_ms is None:
            self.next_ms = boot
        if boot < self.next_ms:
            return
        self.next_ms = max(self.next_ms + self.period_ms, boot + 0.5 * self.period_ms)
        north, east = self.rng.normal(0.0, self.sigma, 2)
        for axis, value in (("X", north / M_PER_DEG_LAT), ("Y", east / self.m_per_deg_lon)):
            self.op.conn.mav.param_set_send(self.op.target_system, self.op.target_component,
                                            f"SIM_GPS1_GLTCH_{axis}".encode(), value,
                                            mavlink.MAV_PARAM_TYPE_REAL32)
        self.draws += 1


def patrol(op: Operator, comp: CompanionProcess, until_boot_ms: float,
           noise: GpsNoise | None = None, wall_guard_s: float = 300.0) -> None:
    """Keep the ground station (and the noise) going until the autopilot's clock reaches
    ``until_boot_ms``, or the companion exits."""
    t0 = time.monotonic()
    while (op.boot_ms or 0) < until_boot_ms:
        if not comp.running():
            raise RuntimeError("the companion exited:\n" + comp.output(20))
        if time.monotonic() - t0 > wall_guard_s:
            raise TimeoutError(f"autopilot clock stuck at {op.boot_ms} ms")
        if noise is not None:
            noise.step()
        op.poll(0.002 if noise is not None else 0.02)


def hand_over(op: Operator, comp: CompanionProcess, speedup: float) -> None:
    """Arm in GUIDED, then wait until the companion says its helm is ONLINE (a Python
    process takes a few wall seconds to start: tens of autopilot seconds at the speed-up)."""
    op.hand_over("GUIDED", timeout_s=HAND_OVER_WALL_S, retry_s=1.0 / speedup)
    op.wait_until(lambda: comp.find("helm ONLINE") is not None or not comp.running(),
                  HAND_OVER_WALL_S, "the companion's helm ONLINE")
    if not comp.running():
        raise RuntimeError("the companion exited:\n" + comp.output(20))


def start_operator(sitl: RealSitl, speedup: float) -> Operator:
    # GLOBAL_POSITION_INT, EKF_STATUS_REPORT, SIMSTATE at 4 Hz
    return Operator(sitl.ports.serial0, heartbeat_s=1.0 / speedup).wait_first_heartbeat(4)


# ---- reading the .alog --------------------------------------------------------------------------

@dataclass
class Log:
    messages: list[Message]
    series: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        by_name: dict[str, list[tuple[float, float]]] = {}
        for m in self.messages:
            if m.is_double:
                by_name.setdefault(m.name, []).append((m.time, m.double))
        for name, rows in by_name.items():
            a = np.array(rows, dtype=float)
            order = np.argsort(a[:, 0], kind="stable")
            self.series[name] = (a[order, 0], a[order, 1])

    def get(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        return self.series.get(name, (np.zeros(0), np.zeros(0)))

    def strings(self, name: str) -> list[tuple[float, str]]:
        return [(m.time, str(m.value)) for m in self.messages if m.name == name]

    def xy(self, prefix: str, t0: float = -math.inf, t1: float = math.inf
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``<prefix>_X``/``_Y`` posted with the same stamp, within [t0, t1]."""
        tx, x = self.get(f"{prefix}_X")
        ty, y = self.get(f"{prefix}_Y")
        ys = dict(zip(ty.tolist(), y.tolist(), strict=True))
        rows = [(t, v, ys[t]) for t, v in zip(tx.tolist(), x.tolist(), strict=True)
                if t in ys and t0 <= t <= t1]
        a = np.array(rows, dtype=float).reshape(-1, 3)
        return a[:, 0], a[:, 1], a[:, 2]

    def score(self, prefix: str, t0: float = -math.inf, t1: float = math.inf) -> Accuracy:
        t, x, y = self.xy(prefix, t0, t1)
        tt, tx, ty = self.xy("TRUTH")
        if not len(t) or not len(tt):
            return Accuracy(math.nan, math.nan, math.nan, 0)
        return accuracy(t, x, y, tt, tx, ty)

    def first(self, name: str) -> float | None:
        return next((m.time for m in self.messages if m.name == name), None)

    def nees(self, t0: float = -math.inf, t1: float = math.inf) -> Consistency:
        """NEES of the live EKF's position (EKF_X/Y with EKF_SIGMA_X/Y, the cross term not
        posted: taken as 0) against the truth, within [t0, t1]."""
        t, x, y = self.xy("EKF", t0, t1)
        ts, sx = self.get("EKF_SIGMA_X")
        _, sy = self.get("EKF_SIGMA_Y")
        tt, tx, ty = self.xy("TRUTH")
        if not len(t) or not len(ts) or not len(tt):
            return Consistency(math.nan, math.nan, math.nan, 0)
        vx, vy = np.interp(t, ts, sx) ** 2, np.interp(t, ts, sy) ** 2
        return nees(t, x, y, vx, np.zeros(len(t)), vy, tt, tx, ty)


def lateness(log: Log, prefix: str, t0: float, t1: float) -> float:
    """How late ``<prefix>_X/Y`` are stamped against the truth (s): the shift of the truth's
    time that fits them best (least squares over a 10 ms grid; the noise averages out)."""
    t, x, y = log.xy(prefix, t0, t1)
    tt, tx, ty = log.xy("TRUTH")
    keep = (t >= tt[0] + 1.0) & (t <= tt[-1] - 1.0) if len(tt) else np.zeros(len(t), bool)
    if not keep.any():
        return math.nan
    t, x, y = t[keep], x[keep], y[keep]
    shifts = np.arange(-0.2, 0.6, 0.01)
    mse = [np.mean((x - np.interp(t - s, tt, tx)) ** 2 + (y - np.interp(t - s, tt, ty)) ** 2)
           for s in shifts]
    return float(shifts[int(np.argmin(mse))])


def lateness_report(log: Log, folder: Path, t0: float, t1: float) -> str:
    """The GPS's and NAV's lateness against the truth, and the fix's age on arrival."""
    age = gps_fix_age(folder)
    return (f"     GPS_X/Y stamped {lateness(log, 'GPS', t0, t1):.2f} s after the truth's time "
            f"(the SITL's GPS lag, 0.1 s, plus GPS_RAW_INT's age on arrival, "
            f"{'n/a' if age is None else f'{age:.2f}'} s: the 5 Hz stream's phase against "
            f"the 5 Hz fixes, which pNav moves the fix on by: GPS_AGE), NAV_X/Y "
            f"{lateness(log, 'NAV', t0, t1):.2f} s (EKF_TIME_SIGMA, 0.1 s, covers it)")


def derivative(t: np.ndarray, v: np.ndarray, half_window: float) -> tuple[np.ndarray,
                                                                          np.ndarray]:
    """Central difference over ±half_window (samples with the same stamp collapse first)."""
    t, idx = np.unique(t, return_index=True)
    v = v[idx]
    lo = np.searchsorted(t, t - half_window)
    hi = np.clip(np.searchsorted(t, t + half_window, side="right") - 1, 0, len(t) - 1)
    ok = hi > lo
    d = np.full(len(t), np.nan)
    d[ok] = (v[hi[ok]] - v[lo[ok]]) / (t[hi[ok]] - t[lo[ok]])
    return t[ok], d[ok]


def stats(err: np.ndarray) -> str:
    err = np.abs(err[np.isfinite(err)])
    if not err.size:
        return "no samples"
    return (f"RMS {math.sqrt(float(np.mean(err**2))):.3f}, p95 {np.percentile(err, 95):.3f}, "
            f"max {err.max():.3f} (n={err.size})")


def tick_period(log: Log, t0: float, t1: float) -> str:
    t, _ = log.get("DESIRED_THRUST")
    t = t[(t >= t0) & (t <= t1)]
    if t.size < 3:
        return "n/a"
    p = np.diff(t)
    return f"median {np.median(p):.3f} s, p99 {np.percentile(p, 99):.3f} s"


def gps_fix_age(folder: Path) -> float | None:
    """How old GPS_RAW_INT's fix is when the companion gets it (s, median): the autopilot's
    clock (the newest time_boot_ms heard on the link, from the companion's .tlog) less the
    fix's time_usec (ArduPilot: its boot time of the fix). None without a .tlog."""
    tlogs = sorted(folder.glob("*.tlog"))
    if not tlogs:
        return None
    link = mavutil.mavlink_connection(str(tlogs[0]))
    boot_ms, ages = None, []
    try:
        while (msg := link.recv_match(blocking=False)) is not None:
            if msg.get_type() == "GPS_RAW_INT":
                if boot_ms is not None and msg.fix_type >= mavlink.GPS_FIX_TYPE_3D_FIX:
                    ages.append(boot_ms / 1000.0 - msg.time_usec / 1e6)
            elif (ms := getattr(msg, "time_boot_ms", None)) is not None:
                boot_ms = max(boot_ms or 0, ms)
    finally:
        link.close()
    return float(np.median(ages)) if ages else None


def gps_fixes_used(folder: Path, t0: float, t1: float) -> int | None:
    """GPS fixes the live pNav took into its filter (accepted or rejected) in [t0, t1], from
    its .olog; None when there is no .olog."""
    ologs = sorted(folder.glob("pNav_*.olog"))
    if not ologs:
        return None
    n = 0
    for path in ologs:
        for line in path.read_text().splitlines():
            fields = line.split()
            if len(fields) > 4 and fields[1] == "gps" and fields[2] == "XY":
                with contextlib.suppress(ValueError):
                    if t0 <= float(fields[0]) <= t1:
                        n += 1
    return n


def replayed(mission: Path, log: Log, t0: float, t1: float) -> Accuracy:
    """The mission's pNav run offline over the .alog (``mavhelm nav replay``), scored in
    [t0, t1]: the alog's millisecond stamps pair every GPS_X with its GPS_Y again. The live
    run's own NAV_*/EKF_*/LSQ_* are left out of the input: ``replay`` would score them too."""
    block = parse_mission(mission.read_text(), str(mission)).process("pNav")
    result = replay(block, [m for m in log.messages
                            if not m.name.startswith(("NAV_", "EKF_", "LSQ_"))])
    track = result.tracks.get("NAV")
    if track is None:
        return Accuracy(math.nan, math.nan, math.nan, 0)
    t, x, y = (np.asarray(a, dtype=float) for a in (track.t, track.x, track.y))
    keep = (t >= t0) & (t <= t1)
    tt, tx, ty = log.xy("TRUTH")
    return accuracy(t[keep], x[keep], y[keep], tt, tx, ty)


def companion_alog(folder: Path) -> Path:
    paths = sorted(folder.glob("*.alog"))
    if len(paths) != 1:
        raise RuntimeError(f"expected one .alog in {folder}, found {paths}")
    return paths[0]


# ---- experiment 1: GPS noise --------------------------------------------------------------------

def run_noise(binary: Path, folder: Path, args: argparse.Namespace) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    mission = folder / "nav_noise.moos"
    mission.write_text(mission_text(NAV_NOISE + (GYRO if args.gyro else "")))
    params = {**({} if args.wind else CALM), "SIM_GPS1_NOISE": 2, "FS_EKF_ACTION": 0}
    wall0 = time.monotonic()
    with RealSitl(folder / "sitl", binary=binary, model="motorboat", speedup=args.speedup,
                  home=(LAT0, LON0, 0, HOME_HEADING), params=params) as sitl:
        op = start_operator(sitl, args.speedup)
        try:
            sitl.wait_listening(sitl.ports.serial1)
            comp = CompanionProcess(mission, sitl.ports.serial1, folder / "companion")
            try:
                hand_over(op, comp, args.speedup)
                noise = GpsNoise(op, NOISE_SIGMA_M, NOISE_HZ, args.speedup)
                start_ms = op.boot_ms or 0
                patrol(op, comp, start_ms + args.patrol * 1000.0, noise)
            finally:
                comp.stop()
            modes = [(boot, mode, armed) for wall_t, boot, mode, armed in op.modes
                     if wall_t > (op.handed_over_wall or 0.0)]
        finally:
            op.close()
    wall = time.monotonic() - wall0
    alog_path = companion_alog(folder / "companion")
    log = Log(read_alog(alog_path))
    online = log.first("HELM_ONLINE")
    if online is None:
        print("GPS noise: the helm never went online; companion output:\n" + comp.output(30))
        return
    t0 = online + SETTLE_S
    t1 = log.get("TRUTH_X")[0].max()

    gps, nav, ap = log.score("GPS", t0, t1), log.score("NAV", t0, t1), log.score("AP", t0, t1)
    ekf = log.score("EKF", t0, t1)
    ratio_rms = nav.rms / gps.rms if gps.rms else math.nan
    ratio_p95 = nav.p95 / gps.p95 if gps.p95 else math.nan

    # true speed and heading rate from the truth track
    tt, tx, ty = log.xy("TRUTH")
    ts, vx = derivative(tt, tx, 1.0)
    _, vy = derivative(tt, ty, 1.0)
    true_speed = np.hypot(vx, vy)
    th, hd = log.get("TRUTH_HEADING")
    th, hdot = derivative(th, np.degrees(np.unwrap(np.radians(hd))), 0.5)

    def speed_err(name: str) -> np.ndarray:
        t, v = log.get(name)
        keep = (t >= t0) & (t <= t1) & (t >= ts[0]) & (t <= ts[-1])
        return v[keep] - np.interp(t[keep], ts, true_speed)

    def rate_err(name: str) -> np.ndarray:
        t, v = log.get(name)      # rad/s of yaw = −heading
        keep = (t >= t0) & (t <= t1) & (t >= th[0]) & (t <= th[-1])
        return -np.degrees(v[keep]) - np.interp(t[keep], th, hdot)

    window = (th >= t0) & (th <= t1)
    travelled = float(np.sum(np.hypot(np.diff(tx[(tt >= t0) & (tt <= t1)]),
                                      np.diff(ty[(tt >= t0) & (tt <= t1)]))))
    print()
    print(f"1. GPS noise: real ArduPilot Rover SITL (motorboat, --speedup {args.speedup:g}, "
          f"{'stock wind and waves' if args.wind else 'calm'}), mavhelm run --clock autopilot, "
          f"box patrol")
    print(f"   SIM_GPS1_NOISE 2 set (ArduPilot: vertical only); horizontal noise injected as "
          f"SIM_GPS1_GLTCH_X/Y ~ N(0, {NOISE_SIGMA_M:g} m) per axis, {noise.draws} draws at "
          f"{NOISE_HZ:g} Hz; FS_EKF_ACTION 0")
    print(f"   pNav: SENSOR_XY GPS (GPS_RAW_INT) + SENSOR_ORIENTATION INS (ATTITUDE)"
          f"{' + BODY_VEL INS gyro' if args.gyro else ''} + FIXEDSIDESLIP; X/Y/Speed/Heading "
          f"= EKF")
    print(f"   scored {t1 - t0:.0f} autopilot s (hand-over + {SETTLE_S:g} s to the end), "
          f"{travelled:.0f} m travelled; wall {wall:.1f} s; companion tick "
          f"{tick_period(log, t0, t1)}")
    print(f"   raw GPS (GPS_X/Y)    vs truth: {gps}")
    print(f"   pNav    (NAV_X/Y)    vs truth: {nav}")
    print(f"   pNav EKF (EKF_X/Y)   vs truth: {ekf}")
    print(f"   pNav EKF NEES (2 dof): {log.nees(t0, t1)}")
    print(lateness_report(log, folder / "companion", t0, t1))
    print(f"   ArduPilot EKF3 (AP_X/Y, GLOBAL_POSITION_INT) vs truth: {ap}")
    posted = int(np.sum((log.get("GPS_X")[0] >= t0) & (log.get("GPS_X")[0] <= t1)))
    used = gps_fixes_used(folder / "companion", t0, t1)
    offline = replayed(mission, log, t0, t1)
    print(f"   GPS fixes posted (GPS_X) {posted}, taken by the live pNav (.olog) "
          f"{'n/a' if used is None else used}; the same pNav replayed offline over this "
          f".alog: {offline} (ratio {offline.rms / gps.rms:.2f})")
    if used is not None and used < 0.9 * posted:
        print(f"   note: the live pNav missed {1 - used / posted:.0%} of the fixes. The bridge "
              "posts GPS_X and GPS_Y with two readings of the autopilot clock (notify without "
              "a time: clock.now() each), which runs between ticks, so the pair's stamps "
              "differ by microseconds and SENSOR_XY, which pairs on equal stamps, drops the "
              "fix as incomplete (and takes ATTITUDE's INS_YAW and INS_HEADING as two compass "
              "readings). In a .alog (millisecond stamps) they pair again: the replay line.")
    verdict = "met" if ratio_rms <= 0.5 else "MISSED"
    print(f"   NAV / raw GPS error: RMS ratio {ratio_rms:.2f}, p95 ratio {ratio_p95:.2f} "
          f"(target <= 0.5: {verdict})")
    print(f"   speed (m/s) vs truth (d/dt of truth over 2 s; true mean "
          f"{np.mean(true_speed[(ts >= t0) & (ts <= t1)]):.2f}):")
    print(f"     NAV_SPEED (pNav EKF)          {stats(speed_err('NAV_SPEED'))}")
    print(f"     GPS_SPEED (GPS velocity)      {stats(speed_err('GPS_SPEED'))}  "
          f"(the SITL's GPS velocity carries no noise)")
    print(f"     AP_SPEED  (ArduPilot EKF3)    {stats(speed_err('AP_SPEED'))}")
    print(f"   heading rate (deg/s) vs truth (d/dt of TRUTH_HEADING over 1 s; true RMS "
          f"{math.sqrt(float(np.mean(hdot[window] ** 2))):.2f}, max "
          f"{np.abs(hdot[window]).max():.1f}):")
    print(f"     EKF_YAW_VEL (pNav EKF)        {stats(rate_err('EKF_YAW_VEL'))}")
    print(f"     INS_YAW_VEL (ATTITUDE gyro)   {stats(rate_err('INS_YAW_VEL'))}")
    changed = [m for m in modes if m[1] != "GUIDED" or not m[2]]
    if changed:
        print(f"   note: mode changes during the patrol: {changed}")
    if args.keep:
        print(f"   alog: {alog_path}")


# ---- experiment 2: GPS off for 120 s ------------------------------------------------------------

class Instruments(ConsoleProcess):
    """``mavhelm instruments`` in its own process; its console lines collected (and logged)."""

    PORT_LINE = re.compile(r"mavhelm instruments: (\w+) on (/dev/pts/\d+)")

    def __init__(self, truth_port: int, log_path: Path) -> None:
        beacons = ";".join(f"{i}:{x:g},{y:g},{z:g}" for i, x, y, z in BEACONS)
        super().__init__([sys.executable, "-m", "mavhelm.cli", "instruments",
                          "--truth", f"tcp:127.0.0.1:{truth_port}", "--origin",
                          f"{LAT0},{LON0}", "--ranging", "radio", "--beacons", beacons],
                         log_path=log_path)

    def ports(self, timeout_s: float = 10.0) -> dict[str, str]:
        def found() -> dict[str, str] | None:
            paths = dict(m.groups() for _, line in list(self.lines)
                         if (m := self.PORT_LINE.search(line)))
            if all(name in paths for name in INSTRUMENTS):
                return paths
            if not self.running():
                raise RuntimeError("mavhelm instruments exited:\n" + self.output())
            return None
        return wait_for(found, timeout_s, "mavhelm instruments' ports", self.output,
                        error=RuntimeError)

    def stop(self, sig: int = signal.SIGINT, grace_s: float = 5.0) -> int:
        return super().stop(sig, grace_s)


def run_outage(binary: Path, folder: Path, args: argparse.Namespace) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    params = {**({} if args.wind else CALM), "FS_EKF_ACTION": 0,
              **({} if args.stock_autopilot else GPS_FREE_GUIDED), **dict(args.param)}
    origin = Origin(LAT0, LON0)
    wall0 = time.monotonic()
    with RealSitl(folder / "sitl", binary=binary, model="motorboat", speedup=args.speedup,
                  home=(LAT0, LON0, 0, HOME_HEADING), params=params) as sitl:
        op = start_operator(sitl, args.speedup)
        inst = Instruments(sitl.ports.serial2, folder / "instruments.log")
        try:
            ports = inst.ports()
            serial = "".join(SERIAL.format(label=name, name=INSTRUMENTS[name][0], port=pty,
                                           sentences=INSTRUMENTS[name][1])
                             for name, pty in ports.items() if name in INSTRUMENTS)
            mission = folder / "nav_outage.moos"
            mission.write_text(mission_text(NAV_OUTAGE, serial, args.outage_thrust))
            sitl.wait_listening(sitl.ports.serial1)
            comp = CompanionProcess(mission, sitl.ports.serial1, folder / "companion")
            try:
                hand_over(op, comp, args.speedup)
                start_ms = op.boot_ms or 0
                patrol(op, comp, start_ms + BEFORE_OUTAGE_S * 1000.0)
                off_ms = op.set_param("SIM_GPS1_ENABLE", 0) or 0
                off_wall = time.monotonic()
                patrol(op, comp, off_ms + OUTAGE_S * 1000.0)
                on_ms = op.set_param("SIM_GPS1_ENABLE", 1) or 0
                on_wall = time.monotonic()
                patrol(op, comp, on_ms + AFTER_OUTAGE_S * 1000.0)
            finally:
                comp.stop()
        finally:
            inst.stop()
            op.close()
    wall = time.monotonic() - wall0
    alog_path = companion_alog(folder / "companion")
    log = Log(read_alog(alog_path))

    # the outage as the companion saw it: the longest span without GPS_X
    tg, _ = log.get("GPS_X")
    gaps = np.diff(tg)
    k = int(np.argmax(gaps)) if gaps.size else None
    if k is None or gaps[k] < 10.0:
        print("GPS off: no GPS outage in the .alog; companion output:\n" + comp.output(30))
        return
    g0, g1 = float(tg[k]), float(tg[k + 1])
    nav_out = log.score("NAV", g0, g1)
    nav_before = log.score("NAV", g0 - BEFORE_OUTAGE_S + SETTLE_S, g0)
    nav_after = log.score("NAV", g1, g1 + AFTER_OUTAGE_S)
    ekf_out = log.score("EKF", g0, g1)
    ap_out = log.score("AP", g0, g1)
    tt, tx, ty = log.xy("TRUTH", g0, g1)
    travelled = float(np.sum(np.hypot(np.diff(tx), np.diff(ty))))

    # ArduPilot's EKF3 as the ground station heard it: GLOBAL_POSITION_INT vs SIMSTATE
    st, sx, sy = op.truth_local(origin)
    pos = np.array([(b / 1000.0, *origin.to_local(la * 1e-7, lo * 1e-7))
                    for b, la, lo in op.positions], dtype=float).reshape(-1, 3)
    in_out = (pos[:, 0] >= off_ms / 1000.0) & (pos[:, 0] <= on_ms / 1000.0)
    drift = accuracy(pos[in_out, 0], pos[in_out, 1], pos[in_out, 2], st, sx, sy)
    end_err = np.nan
    if in_out.any():
        last = np.flatnonzero(in_out)[-1]
        end_err = math.hypot(pos[last, 1] - np.interp(pos[last, 0], st, sx),
                             pos[last, 2] - np.interp(pos[last, 0], st, sy))
    lost = next(((b, f) for b, f in op.ekf_flags
                 if b is not None and b >= off_ms and not f & mavlink.EKF_POS_HORIZ_ABS), None)
    back = next(((b, f) for b, f in op.ekf_flags
                 if lost and b is not None and b > lost[0] and f & mavlink.EKF_POS_HORIZ_ABS),
                None)
    lsq_fixes = int(np.sum((log.get("LSQ_X")[0] >= g0) & (log.get("LSQ_X")[0] <= g1)))
    sources = log.strings("NAV_X_SOURCE")
    fell = next((t for t, s in sources if s == "EKF" and g0 - 1.0 <= t <= g1), None)
    popped = next((t for t, s in sources if s == "GPS" and t >= g1 - 1.0), None)
    texts = [text for wall_t, text in op.statustexts if off_wall <= wall_t <= on_wall + 5.0]
    modes = [(boot, mode, armed) for wall_t, boot, mode, armed in op.modes
             if wall_t > (op.handed_over_wall or 0.0)]
    ts, vx = derivative(tt, tx, 1.0)
    _, vy = derivative(tt, ty, 1.0)
    true_speed = np.hypot(vx, vy)

    print()
    print(f"2. GPS off for {OUTAGE_S:g} autopilot s: real ArduPilot Rover SITL (motorboat, "
          f"--speedup {args.speedup:g}, {'stock wind and waves' if args.wind else 'calm'}), "
          f"FS_EKF_ACTION 0 (else ArduPilot's EKF failsafe leaves GUIDED when the GPS goes)"
          + ("" if args.stock_autopilot else
             "; GUIDED freed from EKF3's velocity: " + " ".join(
                 f"{k} {v:g}" for k, v in GPS_FREE_GUIDED.items())
             + " (stock Rover closes its speed loop and scales its steering on EKF3's "
             "velocity, which decays once EKF3 stops aiding: the boat ran away at 10 m/s and "
             "its rudder chattered)"))
    print(f"   instruments: mavhelm instruments --truth tcp:127.0.0.1:{sitl.ports.serial2} "
          f"(heading HDT, DVL, radio ranges to 3 beacons) driven by the SITL's SIMSTATE")
    print("   pNav: GPS + HDG compass + DVL + ATTITUDE gyro + RANGE radio, EKF_XY/YAW_DYNAMICS 10, "
          "LSQTimeOut NEVER; X/Y = GPS @ 2, EKF @ 2; "
          f"wall {wall:.1f} s; companion tick {tick_period(log, g0, g1)}")
    print(f"   SIM_GPS1_ENABLE 0 at autopilot {off_ms / 1000:.1f} s, 1 at {on_ms / 1000:.1f} s "
          f"({(on_ms - off_ms) / 1000:.1f} s); the companion had no GPS_X for "
          f"{g1 - g0:.1f} s, {travelled:.0f} m travelled meanwhile")
    verdict = "met" if nav_out.max <= 2.0 else "MISSED"
    print(f"   pNav NAV_X/Y vs truth during the outage: {nav_out} (target max <= 2 m: "
          f"{verdict})")
    print(f"     (EKF_X/Y during: {ekf_out}; NAV before: {nav_before}; after: {nav_after}; "
          f"LSQ fixes during the outage: {lsq_fixes})")
    print(f"     pNav EKF NEES (2 dof) during the outage: {log.nees(g0, g1)}")
    print(f"   ArduPilot EKF3 (GLOBAL_POSITION_INT vs SIMSTATE, ground station) during the "
          f"outage: {drift}; error at the end {end_err:.1f} m")
    if lost:
        print(f"     EKF_STATUS_REPORT: horizontal position invalid from autopilot "
              f"{lost[0] / 1000:.1f} s ({(lost[0] - off_ms) / 1000:.1f} s after the GPS went)"
              + (f", valid again at {back[0] / 1000:.1f} s" if back else ""))
    else:
        print("     EKF_STATUS_REPORT kept saying the horizontal position was valid")
    tap = log.xy("AP", g0, g1)[0]
    print(f"     AP_X/Y the companion took during the outage: {ap_out.n}"
          + (f", all in its first {tap.max() - g0:.1f} s, none after (the bridge takes AP_* "
             f"only while EKF_STATUS_REPORT says the position is valid): {ap_out}"
             if ap_out.n else " (it stopped publishing a position)"))
    if texts:
        print(f"     autopilot texts from GPS off to 5 wall s after GPS on: "
              f"{' | '.join(dict.fromkeys(texts))}")
    print("   NAV_X_SOURCE: fell back to EKF "
          + (f"{fell - g0:+.1f} s after the last fix" if fell is not None else "NEVER")
          + ", popped back to GPS "
          + (f"{popped - g1:+.1f} s after the first fix" if popped is not None else "NEVER"))
    changed = [m for m in modes if m[1] != "GUIDED" or not m[2]]
    print(f"   mode: {'GUIDED, armed throughout' if not changed else changed}; true speed "
          f"during the outage mean {true_speed.mean():.1f} m/s, max {true_speed.max():.1f} m/s "
          f"(Thrust {args.outage_thrust:g})")
    velocity = inst.find_all("velocity from")
    if velocity:
        print(f"   instruments: {velocity[0].split(': ', 1)[1]}")
    fault_table(mission, alog_path)
    if args.keep:
        print(f"   alog: {alog_path}")


def fault_table(mission: Path, alog: Path) -> None:
    """The outage run's .alog replayed with each fault of the library made on it
    (``mavhelm nav replay --fault all``, the real SITL's truth): per fault, NAV's and the
    EKF's RMS/max, the best of the sources, the NEES and the decisions taken."""
    done = subprocess.run([sys.executable, "-m", "mavhelm.cli", "nav", "replay", str(mission),
                           str(alog), "--fault", "all", "--no-nav-log"],
                          capture_output=True, text=True, check=False)
    if done.returncode != 0:
        print(f"   fault replays failed: {done.stdout[-400:]}{done.stderr[-400:]}")
        return
    runs = re.split(r"^== fault (\S+) ==$", done.stdout, flags=re.M)
    print("   the same run replayed with each fault made on it (mavhelm nav replay --fault all;"
          " RMS / max m; NAV follows the mission's X = GPS @ 2, EKF @ 2: the raw fixes while "
          "they come, glitches and all, as spec 2.1 maps a sensor straight through):")
    print(f"     {'fault':20s} {'NAV':>13s} {'EKF':>13s}  best source  NEES   decisions")
    for name, text in [("none", runs[0]), *zip(runs[1::2], runs[2::2], strict=True)]:
        scores = {m[0]: (float(m[1]), float(m[2])) for m in re.findall(
            r"^(\w+)\s+position: RMS ([\d.]+) m, p95 [\d.]+ m, max ([\d.]+) m", text,
            flags=re.M)}
        best = min((v[0], k) for k, v in scores.items() if k != "NAV")
        nees = re.search(r"^NEES \(EKF position, 2 dof\): mean ([\d.]+)", text, flags=re.M)
        decided = re.search(r"^decisions: (.*)$", text, flags=re.M)
        made = ", ".join(d for d in (decided.group(1).split(", ") if decided else [])
                         if not d.endswith(" 0"))
        nav, ekf = scores.get("NAV", (math.nan,) * 2), scores.get("EKF", (math.nan,) * 2)
        print(f"     {name:20s} {nav[0]:5.2f} / {nav[1]:5.1f} {ekf[0]:5.2f} / {ekf[1]:5.1f}  "
              f"{best[1]:4s} {best[0]:5.2f}  {float(nees.group(1)) if nees else math.nan:5.2f}  "
              f"{made}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", default="noise,outage", help="noise, outage (default both)")
    parser.add_argument("--speedup", type=float, default=SPEEDUP)
    parser.add_argument("--patrol", type=float, default=PATROL_S,
                        help="autopilot s of noisy patrol (default 300)")
    parser.add_argument("--gyro", action="store_true",
                        help="noise run: add ATTITUDE's yaw rate as a BODY_VEL sensor")
    parser.add_argument("--stock-autopilot", action="store_true",
                        help="outage run: keep Rover's stock speed loop and steering scaling, "
                             "which run on EKF3's velocity (the boat runs away and chatters "
                             "once EKF3 stops aiding)")
    parser.add_argument("--outage-thrust", type=float, default=60.0,
                        help="outage run: the box's Thrust (percent of WP_SPEED 5 m/s)")
    parser.add_argument("--param", type=lambda t: (t.split("=")[0], float(t.split("=")[1])),
                        action="append", default=[], metavar="NAME=VALUE",
                        help="outage run: an extra SITL parameter")
    parser.add_argument("--wind", action="store_true",
                        help="the stock motorboat.parm wind and waves instead of calm water")
    parser.add_argument("--keep", type=Path, default=None,
                        help="run in this folder and keep the logs (.alog, nav logs, SITL)")
    args = parser.parse_args(argv)
    binary = ardupilot_binary()
    if binary is None:
        print(f"bench_nav_ardupilot: skipped: {SKIP_REASON}")
        return 0
    only = {w.strip() for w in args.only.split(",")}
    with tempfile.TemporaryDirectory(prefix="mavhelm-bench-nav-ardupilot-") as tmp:
        base = args.keep.resolve() if args.keep else Path(tmp)
        base.mkdir(parents=True, exist_ok=True)
        t0 = time.monotonic()
        if "noise" in only:
            run_noise(binary, base / "noise", args)
        if "outage" in only:
            run_outage(binary, base / "outage", args)
        print(f"\ntotal wall {time.monotonic() - t0:.1f} s"
              + (f"; logs kept in {base}" if args.keep else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
