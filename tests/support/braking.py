"""How a steering + throttle boat brakes under its autopilot: one script, two sides.

``run_braking(side, cases)`` plays the same ground-station script against the real ArduPilot
Rover SITL (``sides.RealSide``) or ``mavhelm sim`` (``sides.SimSide``): arm, GUIDED, and for each
case drive straight east at the case's speed with a refreshed SET_POSITION_TARGET_LOCAL_NED
velocity target, then stop it one of two ways,

- ``timeout``: stop refreshing; 3 s later ArduPilot says "target not received last 3secs,
  stopping" and (a boat) loiters at its stopping point (ModeGuided::update → start_loiter),
- ``hold``: switch to HOLD (ModeHold::update: throttle 0, steering 0),

recording SIMSTATE ground truth and SERVO_OUTPUT_RAW. ``figures()`` reduces each stop to the
numbers compared: speed at the stop and 1 s after, time to 0.3 m/s and to < 0.1 m/s, the lowest
throttle servo. Times are the autopilot's (``time_boot_ms``), never wall time; the stop starts
at the GUIDED time-out text or at the HOLD command.

A plain helper module (not a test module), imported by tests/test_sitl_braking.py and
benchmarks/bench_braking.py.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as M

from tests.support.sides import Side

HOME = (56.4120, -5.4760, 0, 90)
CALM = {"SIM_WIND_SPD": 0, "SIM_WAVE_ENABLE": 0}
# The stock files' lines that matter here (Tools/autotest/default_params of the reference
# build), for running the simulator where the binary and its params/ are absent.
ROVER_PARM = ("ATC_SPEED_P 0.1\nATC_STR_RAT_FF 0.75\nCRUISE_SPEED 5\nCRUISE_THROTTLE 30\n"
              "RC1_MAX 2000\nRC1_MIN 1000\nRC3_MAX 2000\nRC3_MIN 1000\nSERVO1_MIN 1000\n"
              "SERVO1_MAX 2000\nSERVO3_MAX 2000\nSERVO3_MIN 1000\nWP_RADIUS 3\nWP_SPEED 5\n")
MOTORBOAT_PARM = "FRAME_CLASS 2\nSIM_TIDE_0.5\nSIM_WIND_SPD 3\nSIM_WIND_T 1\nSIM_WAVE_ENABLE 1\n"
GUIDED, HOLD = 15, 4
STREAM_HZ = 50            # autopilot hertz asked of EXTRA1 (ATTITUDE, SIMSTATE) and RC_CHANNELS
TARGET_PERIOD_S = 0.1     # velocity target refresh while driving
DRIVE_S = 10.0            # driving at the case's speed before the stop
RECORD_S = 8.0            # recorded after the stop starts
SPEED_WINDOW_S = 0.3      # speed: a line fitted to SIMSTATE positions over this window
STAY_S = 2.0              # stopped: |speed| < 0.1 m/s held this long
WALL_LIMIT_S = 120.0
CASES: tuple[tuple[str, float], ...] = (
    ("timeout", 1.6), ("hold", 1.6), ("timeout", 4.0), ("hold", 4.0))


@dataclass
class Stop:
    """One stop: what was recorded from DRIVE_S before it to RECORD_S after."""

    how: str
    speed: float
    t0: float = math.nan        # autopilot s when the stop started
    track: list[tuple[float, float, float, float]] = field(default_factory=list)
    servos: list[tuple[float, int]] = field(default_factory=list)   # (t, servo3)
    texts: list[tuple[float, str]] = field(default_factory=list)    # the autopilot's, (t, text)


class BrakeDriver:
    """Plays the script on one side on the autopilot's clock."""

    def __init__(self, side: Side) -> None:
        self.side = side
        self.t = 0.0
        self.mode: int | None = None
        self.armed = False
        self.texts: list[tuple[float, str]] = []
        self.track: list[tuple[float, float, float, float]] = []   # t, lat, lng (1e-7), yaw
        self.servos: list[tuple[float, int]] = []
        self._hb_due = 0.0
        self._wall0 = time.monotonic()

    def pump(self) -> None:
        if time.monotonic() - self._wall0 > WALL_LIMIT_S:
            raise TimeoutError(f"braking script ran {WALL_LIMIT_S:g} s of wall time; "
                               f"autopilot at {self.t:.1f} s")
        if self.t >= self._hb_due:
            self._hb_due = self.t + 1.0
            self.side.gcs.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0,
                                              M.MAV_STATE_ACTIVE)
        for _, msg in self.side.pump():
            self._take(msg)

    def _take(self, msg: Any) -> None:
        kind = msg.get_type()
        if kind == "BAD_DATA" or (msg.get_srcSystem(), msg.get_srcComponent()) != (1, 1):
            return
        boot = getattr(msg, "time_boot_ms", None)
        if kind == "SERVO_OUTPUT_RAW":
            boot = msg.time_usec // 1000
        if isinstance(boot, int) and boot / 1000.0 > self.t:
            self.t = boot / 1000.0
        if kind == "HEARTBEAT":
            self.mode = msg.custom_mode
            self.armed = bool(msg.base_mode & M.MAV_MODE_FLAG_SAFETY_ARMED)
        elif kind == "STATUSTEXT":
            self.texts.append((self.t, msg.text))
        elif kind == "SIMSTATE":   # sent right after ATTITUDE, in the same loop: its time
            self.track.append((self.t, msg.lat, msg.lng, msg.yaw))
        elif kind == "SERVO_OUTPUT_RAW":
            self.servos.append((self.t, msg.servo3_raw))

    def until(self, t: float) -> None:
        while self.t < t:
            self.pump()

    def command(self, cmd: int, *params: float) -> None:
        p = list(params) + [0.0] * (7 - len(params))
        self.side.gcs.mav.command_long_send(1, 1, cmd, 0, *p)

    def streams(self) -> None:
        for sid in (M.MAV_DATA_STREAM_EXTRA1, M.MAV_DATA_STREAM_RC_CHANNELS):
            self.side.gcs.mav.request_data_stream_send(1, 1, sid, STREAM_HZ, 1)

    def hand_over(self, max_s: float = 120.0) -> None:
        """Arm, then GUIDED, retried each autopilot second as an operator would."""
        end = self.t + max_s
        while not (self.armed and self.mode == GUIDED):
            if self.t > end:
                raise TimeoutError(f"not armed in GUIDED by {self.t:.1f} s; texts "
                                   f"{[s for _, s in self.texts[-6:]]}")
            if self.armed:
                self.command(M.MAV_CMD_DO_SET_MODE, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, GUIDED)
            else:
                self.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
            self.until(self.t + 1.0)

    def velocity(self, east: float) -> None:
        """SET_POSITION_TARGET_LOCAL_NED with only a velocity (east, m/s)."""
        self.side.gcs.mav.set_position_target_local_ned_send(
            0, 1, 1, M.MAV_FRAME_LOCAL_NED, 0xDC7, 0, 0, 0, 0.0, east, 0, 0, 0, 0, 0, 0)

    def drive(self, speed: float, seconds: float) -> float:
        """Refresh the velocity target for ``seconds``; the time of the last one sent."""
        end = self.t + seconds
        last = self.t
        while self.t < end:
            self.velocity(speed)
            last = self.t
            self.until(self.t + TARGET_PERIOD_S)
        return last

    def wait_text(self, fragment: str, since: float, max_s: float) -> float | None:
        def hit() -> float | None:
            return next((t for t, s in self.texts if t >= since and fragment in s), None)
        end = self.t + max_s
        while hit() is None and self.t < end:
            self.pump()
        return hit()


def run_braking(side: Side, cases: tuple[tuple[str, float], ...] = CASES) -> list[Stop]:
    """The script: every case's drive and stop, in order, on one armed vehicle."""
    d = BrakeDriver(side)
    d.until(1.0)
    d.streams()
    d.until(3.0)
    d.streams()
    d.hand_over()
    stops: list[Stop] = []
    for how, speed in cases:
        if d.mode != GUIDED:
            d.command(M.MAV_CMD_DO_SET_MODE, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, GUIDED)
            d.until(d.t + 0.5)
        start = d.t
        stop = Stop(how, speed)
        last = d.drive(speed, DRIVE_S)
        if how == "timeout":
            t_text = d.wait_text("target not received", last, 5.0)
            if t_text is None:
                raise AssertionError(f"no GUIDED time-out text after {last:.1f} s")
            stop.t0 = t_text
        elif how == "hold":
            d.command(M.MAV_CMD_DO_SET_MODE, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, HOLD)
            stop.t0 = d.t
        else:
            raise ValueError(how)
        d.until(stop.t0 + RECORD_S)
        stop.track = [r for r in d.track if start <= r[0]]
        stop.servos = [r for r in d.servos if start <= r[0]]
        stop.texts = [r for r in d.texts if start <= r[0]]
        stops.append(stop)
    return stops


# ---------------------------------------------------------------------------- analysis
def speed_series(track: list[tuple[float, float, float, float]]
                 ) -> list[tuple[float, float]]:
    """(t, speed m/s along the heading) from SIMSTATE positions: the slope of a straight line
    fitted to the positions within SPEED_WINDOW_S centred on each sample (the positions are
    whole 1e-7°, about 1 cm, so a plain difference would jump by 0.03 m/s)."""
    if not track:
        return []
    k = math.radians(1e-7) * 6_371_000.0
    coslat = math.cos(math.radians(track[0][1] * 1e-7))
    lat0, lng0 = track[0][1], track[0][2]
    rows = [(t, (lat - lat0) * k, (lng - lng0) * k * coslat, yaw) for t, lat, lng, yaw in track]
    out = []
    j0 = j1 = 0
    half = SPEED_WINDOW_S / 2
    for t, _n, _e, yaw in rows:
        while rows[j0][0] < t - half:
            j0 += 1
        while j1 + 1 < len(rows) and rows[j1 + 1][0] <= t + half:
            j1 += 1
        win = rows[j0:j1 + 1]
        if len(win) < 3 or win[-1][0] - win[0][0] < 0.5 * SPEED_WINDOW_S:
            continue
        tm = sum(r[0] for r in win) / len(win)
        var = sum((r[0] - tm) ** 2 for r in win)
        vn = sum((r[0] - tm) * r[1] for r in win) / var
        ve = sum((r[0] - tm) * r[2] for r in win) / var
        out.append((t, vn * math.cos(yaw) + ve * math.sin(yaw)))
    return out


def _at(series: list[tuple[float, float]], t: float) -> float:
    return min(series, key=lambda r: abs(r[0] - t))[1] if series else math.nan


def _first(series: list[tuple[float, float]], t0: float, pred) -> float:
    """Seconds from t0 to the first sample at or after t0 where pred(value) holds (and keeps
    holding for 0.2 s), or nan."""
    rows = [r for r in series if r[0] >= t0]
    for i, (t, v) in enumerate(rows):
        if pred(v) and all(pred(w) for u, w in rows[i:] if u <= t + 0.2):
            return t - t0
    return math.nan


def _settled(series: list[tuple[float, float]], t0: float, band: float) -> float:
    """Seconds from t0 to the last sample at or above band before |value| stays below it for
    STAY_S, or nan. Held for STAY_S, not to the record's end: the braking is over then, and a
    later move is the loiter's own business (the real SITL at ×10 on a loaded machine now and
    then moves again 5-8 s after the stop, see Stop.texts)."""
    rows = [r for r in series if r[0] >= t0]
    last_out = t0
    for t, x in rows:
        if abs(x) >= band:
            last_out = t
        elif t - last_out >= STAY_S:
            return last_out - t0
    return math.nan


FIGURES = ("speed at stop m/s", "speed 1 s after m/s", "speed 3 s after m/s", "t to 0.3 m/s s",
           "t to < 0.1 m/s s", "t to stay |v| < 0.1 s", "least speed m/s",
           "min throttle servo us", "t to min servo s")


def figures(stop: Stop) -> dict[str, float]:
    """The braking figures of one stop (see module doc)."""
    v = speed_series(stop.track)
    t0 = stop.t0
    after = [(t, s) for t, s in stop.servos if t0 <= t <= t0 + RECORD_S]
    lo = min(after, key=lambda r: r[1]) if after else (math.nan, math.nan)
    return {
        "speed at stop m/s": _at(v, t0 - SPEED_WINDOW_S / 2),
        "speed 1 s after m/s": _at(v, t0 + 1.0),
        "speed 3 s after m/s": _at(v, t0 + 3.0),
        "t to 0.3 m/s s": _first(v, t0, lambda x: x <= 0.3),
        "t to < 0.1 m/s s": _first(v, t0, lambda x: x < 0.1),
        "t to stay |v| < 0.1 s": _settled(v, t0, 0.1),
        "least speed m/s": min((x for t, x in v if t >= t0), default=math.nan),
        "min throttle servo us": float(lo[1]),
        "t to min servo s": lo[0] - t0,
    }


def label(stop: Stop) -> str:
    return f"{stop.how} from {stop.speed:g} m/s"


def print_table(real: list[Stop] | None, sim: list[Stop]) -> None:
    print(f"{'stop':<22} {'figure':<24} {'real':>8} {'sim':>8} {'diff':>8}")
    for i, s in enumerate(sim):
        fs = figures(s)
        fr = figures(real[i]) if real else {}
        for key in FIGURES:
            r = fr.get(key, math.nan)
            diff = "" if math.isnan(r) else f"{fs[key] - r:+.2f}"
            print(f"{label(s):<22} {key:<24} {r:8.2f} {fs[key]:8.2f} {diff:>8}")


def write_stock_parms(folder: Path) -> Path:
    """rover.parm and motorboat.parm (their lines that matter here) written into folder."""
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "rover.parm").write_text(ROVER_PARM)
    (folder / "motorboat.parm").write_text(MOTORBOAT_PARM)
    return folder


def sim_rig(params_dir: Any, *, fast_start: bool = True, **params: float) -> Any:
    """A Rig running ``--model motorboat --defaults rover.parm,motorboat.parm`` (from
    ``params_dir``), calm, at the real SITL's home and heading."""
    from mavhelm.sitl.flat_earth import Origin
    from tests.support.sitl_rig import Rig

    files = [str(params_dir / "rover.parm"), str(params_dir / "motorboat.parm")]
    return Rig(model="motorboat", defaults=files, params={**CALM, **params},
               home=Origin(HOME[0], HOME[1]), start_heading=HOME[3], fast_start=fast_start)
