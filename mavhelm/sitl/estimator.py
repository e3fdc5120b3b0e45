"""The autopilot's GPS receiver and a stand-in for its EKF, as pure logic.

``Estimator`` is what the simulated autopilot knows about where it is. The simulator records the
true track into it every physics sub-step (``record``), asks it for a GPS sample
(``update_gps``) and then advances the autopilot's ``Estimate`` (``update``); telemetry reads the
current fix (``gps``) and the EKF status (``ekf_flags``). Nothing here reads a clock, opens a
socket or touches a scenario directly: time is passed in, and faults and random streams come
from the callables it is given, so a test can drive it with plain numbers.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from typing import Any

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as M

from mavhelm.sitl.autopilot import Estimate, Timeline
from mavhelm.sitl.truth import Truth

GPS_DETECTED_AT = 9.7  # s on the measured timeline: "GPS 1: detected u-blox" (fix 0 before)
GPS_NO_FIX_DOP = 9999  # a receiver without a fix reports DOP 99.99
GPS_WANDER_TAU = 30.0  # s, correlation time of the receiver's slow random-walk error
HISTORY_LEN = 500  # truth samples kept for GPS latency: the last 10 s at 50 Hz
GLITCH_GATE = 10.0  # m, innovation beyond which a fix is treated as a glitch
GLITCH_RESET = 5.0  # s a glitch must last before the filter resets onto the GPS
FIX_GAIN = 0.3  # share of the innovation a good fix pulls the estimate by
VEL_FRESH = 0.5  # s a fix's velocity is trusted for
# The real SITL's EKF3 yaw (ATTITUDE) against its own truth (SIMSTATE), measured on Rover
# 4.8-dev: +0.45° at rest, and it trails the truth while turning (-0.8° at ~17°/s): an offset
# and a lag of ~70 ms reproduce both.
EKF_YAW_OFFSET_DEG = 0.45
EKF_YAW_LAG_S = 0.07

FaultSource = Callable[[str, float], list[Any]]
RngSource = Callable[[str], np.random.Generator]


def _no_faults(kind: str, t: float) -> list[Any]:
    return []


def _no_named_rng(name: str) -> np.random.Generator:
    raise LookupError(f"no random stream {name!r} without a scenario")


class GpsSample:
    """One receiver output: fix type (1 none, 3 3D), local position and velocity, quality."""

    __slots__ = ("t", "fix", "x", "y", "vx", "vy", "sats", "eph")

    def __init__(self, t: float, fix: int, x: float, y: float, vx: float, vy: float,
                 sats: int, eph: int) -> None:
        self.t, self.fix, self.x, self.y = t, fix, x, y
        self.vx, self.vy, self.sats, self.eph = vx, vy, sats, eph


class Estimator:
    """GPS receiver + EKF stand-in for one vehicle.

    boot is the sim time of power-on, gps_period the receiver's update interval (GPS_RATE_MS;
    may be changed at run time), rng the stream for the receiver's noise, timeline the
    autopilot's start-up milestones. faults(kind, t) lists the active faults of a kind and
    named_rng(name) returns a scenario's named random stream; both default to "no scenario".
    """

    def __init__(self, boot: float, gps_period: float, rng: np.random.Generator,
                 timeline: Timeline, *, faults: FaultSource | None = None,
                 named_rng: RngSource | None = None) -> None:
        self.boot = boot
        self.gps_period = gps_period
        self.rng = rng
        self.timeline = timeline
        self._detected_at = timeline.map(GPS_DETECTED_AT)  # s after boot, on this timeline
        self.faults: FaultSource = faults or _no_faults
        self.named_rng: RngSource = named_rng or _no_named_rng
        self.next_gps = boot
        self.gps: GpsSample | None = None  # the receiver's latest output (None: not detected)
        self.has_fix = False  # the latest sample is a 3D fix
        self.ever_fix = False  # a 3D fix has been seen since boot (GPS time is known)
        self.last_loc: tuple[float, float] = (0, 0)  # last fixed position, held during outages
        self.last_fix_t: float | None = None  # time of the last 3D fix the filter saw
        self.glitch_since: float | None = None  # fixes rejected by the gate since this time
        self.bias = [0.0, 0.0]  # receiver wander, m east/north
        # (t, x, y, vx, vy) of the true track, newest last, for GPS latency
        self.history: deque[tuple[float, float, float, float, float]] = deque(
            maxlen=HISTORY_LEN)

    # ------------------------------------------------------------------ truth in
    def record(self, t: float, x: float, y: float, vx: float, vy: float) -> None:
        """Remember the true position and ground velocity at t (a delayed GPS reports these)."""
        self.history.append((t, x, y, vx, vy))

    def history_at(self, t: float, truth: Truth) -> tuple[float, float, float, float, float]:
        """The newest recorded (t, x, y, vx, vy) not after t; truth if nothing is recorded."""
        h = self.history
        if not h:
            return (truth.t, truth.x, truth.y, truth.vx, truth.vy)
        if t >= h[-1][0]:
            return h[-1]
        for item in reversed(h):
            if item[0] <= t:
                return item
        return h[0]

    # ------------------------------------------------------------------ GPS receiver
    def update_gps(self, t: float, truth: Truth, noise: float) -> bool:
        """Take a GPS sample at t if one is due; True if one was taken (has_fix is then new).

        noise is SIM_GPS_NOISE: σ of the slow wander in m, the white noise being σ/8. The
        noise is drawn for every sample, fix or not, so a fault never shifts later draws.
        """
        if t + 1e-9 < self.next_gps:
            return False
        self.next_gps += self.gps_period
        if self.next_gps <= t:
            self.next_gps = t + self.gps_period
        up = t - self.boot
        rng = self.rng
        # slow random-walk error (a real receiver's wander) plus white noise, every sample
        tau, sigma = GPS_WANDER_TAU, noise
        k = self.gps_period / tau
        bias = self.bias
        # the sample's four standard normal draws in one call (the same numbers as one at a
        # time): two steps of the walk, then the white noise east and north. Kept as Python
        # floats: numpy scalars would make every later sum with a position slow.
        z = rng.normal(0.0, 1.0, 4).tolist()
        for i in range(2):
            bias[i] += -k * bias[i] + sigma * math.sqrt(2 * k) * z[i]
        white = (z[2] * (sigma / 8.0), z[3] * (sigma / 8.0))
        fix_at = self.timeline.gps_fix
        if up < self._detected_at:
            self.gps = None  # not yet detected
            self.has_fix = False
            return True
        delay = 0.0
        for f in self.faults("sensor_latency", t):
            if str(f.params.get("sensor", "gps")).lower() in ("gps", "gps1", "mavlink_gps"):
                d = float(f.params.get("delay", 0.0))
                jit = float(f.params.get("jitter", 0.0) or 0.0)
                if jit > 0:
                    d += float(self.named_rng("gps_latency").uniform(0, jit))
                delay = max(delay, d)
        _, x, y, vx, vy = self.history_at(t - delay, truth)
        outage = up < fix_at or bool(self.faults("gps_outage", t))
        if outage:
            self.gps = g = GpsSample(t, 1, x, y, 0.0, 0.0, 0, GPS_NO_FIX_DOP)
            if self.ever_fix:
                g.x, g.y = self.last_loc
            self.has_fix = False
            return True
        x += bias[0] + white[0]
        y += bias[1] + white[1]
        for f in self.faults("gps_jump", t):
            x += float(f.params.get("dx", 0.0))
            y += float(f.params.get("dy", 0.0))
        for f in self.faults("gps_outlier", t):
            r = self.named_rng("gps_outlier")
            if r.random() < float(f.params.get("prob", 0.0)):
                s = float(f.params.get("sigma", 10.0))
                x += float(r.normal(0.0, s))
                y += float(r.normal(0.0, s))
        self.gps = GpsSample(t, 3, x, y, vx, vy, 10, 121)
        self.last_loc = (x, y)
        self.ever_fix = True
        self.has_fix = True
        return True

    # ------------------------------------------------------------------ EKF stand-in
    def update(self, est: Estimate, t: float, dt: float, *, heading: float, yaw_rate: float,
               surge: float, sway: float | None, compass_bias: float, have_origin: bool,
               dr_time: float, vx: float | None = None, vy: float | None = None) -> None:
        """Advance est to t: GPS-corrected position, dead reckoning without GPS.

        heading (rad, true) and yaw_rate (rad/s) come from the vehicle; compass_bias (deg)
        offsets the heading the autopilot believes. surge/sway are body speeds through the
        water (sway None for a wheeled vehicle, which cannot slip). vx, vy (m/s east, north)
        are the vehicle's true ground velocity now: while GPS fixes arrive, the EKF's velocity
        is the IMU-propagated one, current between the 5 Hz fixes (EKF3's output predictor),
        so the estimate follows it; without them (None) it holds the latest fix's velocity.
        Before the EKF origin (have_origin) the filter sits on the fix; afterwards it keeps an
        absolute position for dr_time (SIM_EKF_DR_TIME) seconds after the last fix, then
        gives up on it.
        """
        est.yaw_rate = math.degrees(yaw_rate)
        est.heading = (math.degrees(heading) + compass_bias + EKF_YAW_OFFSET_DEG
                       - EKF_YAW_LAG_S * est.yaw_rate) % 360.0
        g = self.gps
        fresh = g is not None and g.fix >= 3 and g.t == t
        was_lost = self.last_fix_t is None or t - self.last_fix_t >= dr_time
        if g is not None and g.fix >= 3:
            self.last_fix_t = g.t
        up = t - self.boot
        using_gps = up >= self.timeline.ekf_gps
        recent = self.last_fix_t is not None and t - self.last_fix_t < VEL_FRESH
        if recent and g is not None:
            if vx is not None and vy is not None:
                est.vx, est.vy = vx, vy
            else:
                est.vx, est.vy = g.vx, g.vy
        else:
            self._dead_reckon(est, surge, sway)
        if not have_origin:
            # before the origin the EKF sits at the first fix (const-position mode)
            if g is not None and g.fix >= 3:
                est.x, est.y = g.x, g.y
            est.position_ok = False
            return
        est.x += est.vx * dt
        est.y += est.vy * dt
        if fresh and g is not None:
            self._correct(est, g, t, was_lost)
        dr_ok = self.last_fix_t is not None and t - self.last_fix_t < dr_time
        est.position_ok = using_gps and dr_ok

    @staticmethod
    def _dead_reckon(est: Estimate, surge: float, sway: float | None) -> None:
        """The velocity without a recent fix: the body speeds along the believed heading."""
        h = math.radians(est.heading)
        if sway is not None:
            est.vx = surge * math.sin(h) + sway * math.cos(h)
            est.vy = surge * math.cos(h) - sway * math.sin(h)
        else:
            est.vx, est.vy = surge * math.sin(h), surge * math.cos(h)

    def _correct(self, est: Estimate, g: GpsSample, t: float, was_lost: bool) -> None:
        """A fresh fix pulls the position towards it, through the innovation gate."""
        ix, iy = g.x - est.x, g.y - est.y
        if was_lost:
            # the filter had given up on position: it resets onto the first new fix
            est.x, est.y = g.x, g.y
            self.glitch_since = None
        elif math.hypot(ix, iy) > GLITCH_GATE:
            # innovation gate: a glitching GPS is ignored, then the EKF resets onto it
            if self.glitch_since is None:
                self.glitch_since = t
            if t - self.glitch_since > GLITCH_RESET:
                est.x, est.y = g.x, g.y
                self.glitch_since = None
        else:
            self.glitch_since = None
            est.x += FIX_GAIN * ix
            est.y += FIX_GAIN * iy

    def ekf_flags(self, t: float, est: Estimate, gps_has_fix: bool) -> tuple[int, float]:
        """EKF_STATUS_REPORT (flags, position variance) at t, as a companion's checks see it."""
        if t - self.boot < self.timeline.initialised:
            return M.EKF_UNINITIALIZED, 1.0
        flags = M.EKF_ATTITUDE | M.EKF_VELOCITY_VERT | M.EKF_POS_VERT_ABS
        var = 0.5
        if est.position_ok:
            flags |= (M.EKF_VELOCITY_HORIZ | M.EKF_POS_HORIZ_REL | M.EKF_POS_HORIZ_ABS
                      | M.EKF_PRED_POS_HORIZ_REL | M.EKF_PRED_POS_HORIZ_ABS)
            var = 0.02 if gps_has_fix else 0.3
        else:
            flags |= M.EKF_CONST_POS_MODE
            if gps_has_fix:
                flags |= M.EKF_PRED_POS_HORIZ_REL | M.EKF_PRED_POS_HORIZ_ABS
        if self.glitch_since is not None:
            flags |= M.EKF_GPS_GLITCHING
            var = 1.0
        return flags, var
