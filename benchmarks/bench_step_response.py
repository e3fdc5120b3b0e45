"""Benchmark: step responses of the real ArduPilot SITL against mavhelm's vehicle models.

For each of ``motorboat``, ``motorboat-skid``, ``rover``, ``rover-skid`` (with their stock
``--defaults``): start the real SITL (``--speedup 5``), arm in MANUAL and drive RC override
through ``STEP_SCHEDULE`` (surge up, coast down, cruise, full steering at cruise and at
low speed, reverse, spin), recording SIMSTATE ground truth (speed from differenced positions,
turn rate from its gyro) and SERVO_OUTPUT_RAW. The same recorded servo outputs then drive the
mavhelm model, and both responses are reduced to the same figures: steady values, and the time
from the servo starting to move to 63 % of the change. A last run of ``motorboat`` with
SIM_WIND_SPD 0 and SIM_WAVE_ENABLE 0 (and one of ``motorboat-skid``) shows what the stock wind
and waves change.

RC_OVERRIDE_TIME is raised to 10 s (it does not touch the physics) so a busy machine that
delays an override refresh cannot hand the sticks back to the (neutral) radio mid-step.
Figures only; asserts nothing. Needs MAVHELM_ARDUPILOT (the ardurover SITL binary); without it,
says so and exits 0. ``--save DIR`` keeps the captures as JSON, ``--load DIR`` re-analyses them
without the binary.

Run: ``MAVHELM_ARDUPILOT=../shared/ardupilot/ardurover .venv/bin/python
-m benchmarks.bench_step_response``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from mavhelm.sitl.boat import SimEnvironment
from mavhelm.sitl.models import MODELS, get_model
from mavhelm.sitl.parm_file import read_defaults
from tests.support.ardupilot import (
    SKIP_REASON,
    RealOperator,
    RealSitl,
    ardupilot_binary,
)

ROOT = Path(__file__).resolve().parent.parent
# Stick steps this benchmark drives the real SITL and the models through, in MANUAL with RC
# override: (autopilot seconds from the first step, steering, throttle, name). Sticks in
# [-1, 1]; ArduPilot turns them into servo outputs (throttle slewed by MOT_SLEWRATE).
STEP_SCHEDULE: tuple[tuple[float, float, float, str], ...] = (
    (0.0, 0.0, 1.0, "surge up"),
    (10.0, 0.0, 0.0, "surge down"),
    (20.0, 0.0, 0.5, "cruise"),
    (28.0, 1.0, 0.5, "turn"),
    (34.0, 0.0, 0.0, "stop"),
    (40.0, 0.0, 0.2, "slow"),
    (46.0, 1.0, 0.2, "slow turn"),
    (52.0, 0.0, 0.0, "stop"),
    (58.0, 0.0, -1.0, "reverse"),
    (68.0, 0.0, 0.0, "reverse stop"),
    (75.0, 1.0, 0.0, "spin"),
    (81.0, 0.0, 0.0, "end"),
    (83.0, 0.0, 0.0, "end"),
)


SPEEDUP = 5
STREAM_HZ = 50            # autopilot hertz of every stream while recording
SETTLE_S = 3.0            # autopilot seconds of neutral sticks before the schedule
EXTRA = {"RC_OVERRIDE_TIME": 10.0}
CALM = {"SIM_WIND_SPD": 0.0, "SIM_WAVE_ENABLE": 0.0}
RUNS: tuple[tuple[str, str, dict[str, float]], ...] = (
    ("motorboat", "motorboat", {}),
    ("motorboat-skid", "motorboat-skid", {}),
    ("rover", "rover", {}),
    ("rover-skid", "rover-skid", {}),
    ("motorboat calm", "motorboat", CALM),
    ("motorboat-skid calm", "motorboat-skid", CALM),
)
MODEL_DT = 0.02           # the simulator's physics sub-step


# ------------------------------------------------------------------------------ capture

def schedule_at(t: float) -> tuple[float, float]:
    """(steering, throttle) sticks the schedule asks for at t (neutral before it starts)."""
    steer, thr = 0.0, 0.0
    for start, s, th, _ in STEP_SCHEDULE:
        if t >= start:
            steer, thr = s, th
    return steer, thr


def _pwm(value: float) -> int:
    return int(round(1500 + 500 * max(-1.0, min(1.0, value))))


def capture(model: str, tmp: Path, binary: Path, params: dict[str, float]) -> dict[str, Any]:
    """One real-SITL run of the schedule. Rows: truth (t, lat, lon, yaw, gyro_z, roll, pitch),
    servos (t, servo1, servo3); t in autopilot seconds from the start of the schedule."""
    truth: list[tuple[float, ...]] = []
    servos: list[tuple[float, int, int]] = []
    all_params = {**EXTRA, **params}
    with RealSitl(tmp, model=model, speedup=SPEEDUP, params=all_params, binary=binary) as sitl, \
            RealOperator(sitl.ports.serial0, heartbeat_s=1.0 / SPEEDUP) as op:
        op.hand_over("MANUAL", timeout_s=120.0)
        op.request_streams(STREAM_HZ)
        clock_ms: float | None = None
        t0_ms: float | None = None
        end_s = STEP_SCHEDULE[-1][0]
        last_sent = -math.inf
        while True:
            for msg in op.poll(0.005):
                if msg.get_type() == "BAD_DATA" or msg.get_srcSystem() != 1 \
                        or msg.get_srcComponent() != 1:
                    continue
                kind = msg.get_type()
                if kind == "SERVO_OUTPUT_RAW":
                    clock_ms = msg.time_usec / 1000.0
                elif kind == "ATTITUDE":
                    clock_ms = float(msg.time_boot_ms)
                if clock_ms is None:
                    continue
                if t0_ms is None:
                    t0_ms = clock_ms + SETTLE_S * 1000.0
                t = (clock_ms - t0_ms) / 1000.0
                if kind == "SERVO_OUTPUT_RAW":
                    servos.append((t, msg.servo1_raw, msg.servo3_raw))
                elif kind == "SIMSTATE":
                    truth.append((t, msg.lat * 1e-7, msg.lng * 1e-7, msg.yaw, msg.zgyro,
                                  msg.roll, msg.pitch))
            if t0_ms is None or clock_ms is None:
                continue
            t = (clock_ms - t0_ms) / 1000.0
            if t > end_s:
                break
            if t - last_sent >= 0.1:
                last_sent = t
                steer, thr = schedule_at(t)
                op.conn.mav.rc_channels_override_send(
                    op.target_system, op.target_component, _pwm(steer), 65535, _pwm(thr),
                    65535, 65535, 65535, 65535, 65535)
            if not op.armed:
                raise RuntimeError(f"{model}: disarmed mid-run; last texts {op.texts()[-5:]}")
    return {"model": model, "params": all_params, "truth": truth, "servos": servos}


# ------------------------------------------------------------------------------ analysis

def real_series(run: dict[str, Any]) -> list[tuple[float, float, float, float]]:
    """(t, speed m/s signed along the heading, yaw rate deg/s, tilt deg) from a capture:
    speed by differencing positions over ±5 samples (SIMSTATE positions are 1e-7°, ~1 cm)."""
    rows = run["truth"]
    k = math.radians(1.0) * 6_371_000.0
    out = []
    for i, (t, lat, _lon, yaw, gz, roll, pitch) in enumerate(rows):
        j0, j1 = max(0, i - 5), min(len(rows) - 1, i + 5)
        dt = rows[j1][0] - rows[j0][0]
        if dt <= 0:
            continue
        dn = (rows[j1][1] - rows[j0][1]) * k
        de = (rows[j1][2] - rows[j0][2]) * k * math.cos(math.radians(lat))
        v = math.hypot(dn, de) / dt
        if dn * math.cos(yaw) + de * math.sin(yaw) < 0:
            v = -v
        out.append((t, v, math.degrees(gz), math.degrees(math.hypot(roll, pitch))))
    return out


def model_series(name: str, run: dict[str, Any], env: SimEnvironment
                 ) -> list[tuple[float, float, float, float]]:
    """The mavhelm model driven by the run's recorded servo outputs (held between samples)."""
    model = get_model(name)
    servos = run["servos"]
    t = servos[0][0]
    state = model.initial_state(math.radians(90.0))
    i = 0
    out = []
    while t < servos[-1][0]:
        while i + 1 < len(servos) and servos[i + 1][0] <= t:
            i += 1
        state = model.step(state, model.inputs_from_servos(servos[i][1], servos[i][2]), env,
                           MODEL_DT)
        t += MODEL_DT
        tr = model.truth(state, t, env)
        out.append((t, tr.surge, tr.yaw_rate, math.hypot(tr.roll, tr.pitch)))
    return out


def _servo_start(run: dict[str, Any], t_cmd: float) -> float:
    """When the servo outputs first change at or after the schedule time t_cmd."""
    servos = run["servos"]
    before = next((s for s in reversed(servos) if s[0] < t_cmd), servos[0])
    for s in servos:
        if s[0] >= t_cmd and (s[1], s[2]) != (before[1], before[2]):
            return s[0]
    return t_cmd


def _mean(series: list[tuple[float, ...]], col: int, t0: float, t1: float) -> float:
    vals = [row[col] for row in series if t0 <= row[0] <= t1]
    return sum(vals) / len(vals) if vals else math.nan


def _at(series: list[tuple[float, ...]], col: int, t: float) -> float:
    return min(series, key=lambda row: abs(row[0] - t))[col]


def _t63(series: list[tuple[float, ...]], col: int, t0: float, t1: float, start: float,
         end: float) -> float:
    """Seconds from t0 until the value has made 63 % of its change from start to end."""
    target = start + 0.632 * (end - start)
    rising = end > start
    for row in series:
        if t0 <= row[0] <= t1 and ((row[col] >= target) if rising else (row[col] <= target)):
            return row[0] - t0
    return math.nan


def figures(series: list[tuple[float, ...]], run: dict[str, Any]) -> dict[str, float]:
    """The step figures of one response (real or model), keyed 'test: figure'."""
    seg = {name: (start, STEP_SCHEDULE[i + 1][0]) for i, (start, _, _, name)
           in enumerate(STEP_SCHEDULE[:-1]) if name not in ("stop", "end")}
    f: dict[str, float] = {}
    a, b = seg["surge up"]
    t0 = _servo_start(run, a)
    top = _mean(series, 1, b - 3, b)
    f["surge up: speed m/s"] = top
    f["surge up: t63 s"] = _t63(series, 1, t0, b, 0.0, top)
    a, b = seg["surge down"]
    t0 = _servo_start(run, a)
    v0 = _at(series, 1, t0)
    f["surge down: speed 1 s after, m/s"] = _at(series, 1, t0 + 1.0)
    f["surge down: speed 3 s after, m/s"] = _at(series, 1, t0 + 3.0)
    f["surge down: t to 37 % s"] = _t63(series, 1, t0, b, v0, 0.0)
    a, b = seg["cruise"]
    f["cruise (stick 0.5): speed m/s"] = _mean(series, 1, b - 3, b)
    a, b = seg["turn"]
    t0 = _servo_start(run, a)
    rate = _mean(series, 2, b - 3, b)
    f["turn at cruise: yaw rate deg/s"] = rate
    f["turn at cruise: t63 s"] = _t63(series, 2, t0, b, 0.0, rate)
    a, b = seg["slow"]
    f["slow (stick 0.2): speed m/s"] = _mean(series, 1, b - 3, b)
    a, b = seg["slow turn"]
    f["turn at slow: yaw rate deg/s"] = _mean(series, 2, b - 3, b)
    a, b = seg["reverse"]
    t0 = _servo_start(run, a)
    v0 = _at(series, 1, t0)
    back = _mean(series, 1, b - 3, b)
    f["reverse: speed m/s"] = back
    f["reverse: t63 s"] = _t63(series, 1, t0, b, v0, back)
    a, b = seg["spin"]
    f["spin (stick 0): yaw rate deg/s"] = _mean(series, 2, b - 3, b)
    f["waves: largest tilt deg"] = max(r[3] for r in series)
    a, b = seg["surge down"]
    f["waves: mean tilt coasting deg"] = _mean(series, 3, a, b)
    return f


def compare(label: str, name: str, run: dict[str, Any]) -> list[tuple[str, str, float, float]]:
    env = SimEnvironment.from_params(read_defaults(
        [str(_params_dir() / f) for f in MODELS[name].defaults], strict=False).values
        | run["params"])
    real = figures(real_series(run), run)
    sim = figures(model_series(name, run, env), run)
    return [(label, key, real[key], sim[key]) for key in real]


def _params_dir() -> Path:
    binary = ardupilot_binary()
    if binary is not None:
        return binary.parent / "params"
    return ROOT.parent / "shared" / "ardupilot" / "params"


def print_table(rows: list[tuple[str, str, float, float]]) -> None:
    print(f"{'model':<20} {'test: figure':<38} {'real':>9} {'model':>9} {'diff':>7}")
    for label, key, real, sim in rows:
        if math.isnan(real) and math.isnan(sim):
            continue
        diff = ""
        if abs(real) > 0.05 and not math.isnan(sim):
            diff = f"{100.0 * (sim - real) / abs(real):+.0f} %"
        elif not math.isnan(sim):
            diff = f"{sim - real:+.2f}"
        print(f"{label:<20} {key:<38} {real:9.2f} {sim:9.2f} {diff:>7}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--save", type=Path, help="keep the captures as JSON in this folder")
    parser.add_argument("--load", type=Path, help="analyse captures saved earlier instead")
    args = parser.parse_args(argv)
    runs: dict[str, dict[str, Any]] = {}
    if args.load:
        for label, _, _ in RUNS:
            path = args.load / f"{label.replace(' ', '_')}.json"
            if path.exists():
                runs[label] = json.loads(path.read_text())
    else:
        binary = ardupilot_binary()
        if binary is None:
            print(f"bench_step_response: skipped: {SKIP_REASON}")
            return 0
        with tempfile.TemporaryDirectory(prefix="mavhelm-bench-steps-") as tmp:
            for label, model, params in RUNS:
                t = time.monotonic()
                runs[label] = capture(model, Path(tmp) / label.replace(" ", "_"), binary,
                                      params)
                print(f"captured {label}: {len(runs[label]['truth'])} SIMSTATE in "
                      f"{time.monotonic() - t:.1f} s wall", flush=True)
        if args.save:
            args.save.mkdir(parents=True, exist_ok=True)
            for label, run in runs.items():
                (args.save / f"{label.replace(' ', '_')}.json").write_text(json.dumps(run))
    rows: list[tuple[str, str, float, float]] = []
    for label, model, _ in RUNS:
        if label in runs:
            rows.extend(compare(label, model, runs[label]))
    print_table(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
