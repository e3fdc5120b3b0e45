"""Benchmark: the demo mission with ``mavhelm run`` against the real ArduPilot Rover SITL.

The SITL runs at ``--speedup 20``; the companion (``mavhelm run examples/demo.moos --clock
autopilot``) sits on its SERIAL1 and paces itself on the autopilot's ``time_boot_ms``; a ground
station on SERIAL0 (tests/support/ardupilot.py's ``RealOperator``) arms the boat in GUIDED.
Prints the wall-clock time from start to MISSION_ENDED, the autopilot time of the mission, the
speed-up achieved and the companion's tick period (from the .alog stamps of DESIRED_THRUST,
posted once a tick while the helm drives) in autopilot seconds. Asserts nothing.

Needs MAVHELM_ARDUPILOT (the ardurover SITL binary); without it, says so and exits 0.
Run: ``MAVHELM_ARDUPILOT=../shared/ardupilot/ardurover .venv/bin/python
-m benchmarks.bench_ardupilot_demo``.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from mavhelm.companion.alog import read_alog
from tests.support.ardupilot import (
    ARDUPILOT_ENV,
    RealOperator,
    RealSitl,
    _set_parent_death_signal,
    ardupilot_binary,
)

ROOT = Path(__file__).resolve().parent.parent
DEMO = ROOT / "examples" / "demo.moos"
SPEEDUP = 20
MISSION_WALL_S = 120.0     # a hang guard, not a figure


def main() -> int:
    binary = ardupilot_binary()
    if binary is None:
        print(f"bench_ardupilot_demo: skipped: {ARDUPILOT_ENV} is not set (point it at the "
              "ardurover SITL binary, e.g. ../shared/ardupilot/ardurover)")
        return 0
    with tempfile.TemporaryDirectory(prefix="mavhelm-bench-ardupilot-") as tmp:
        return run(binary, Path(tmp))


def run(binary: Path, tmp: Path) -> int:
    t_start = time.monotonic()
    with RealSitl(tmp / "sitl", binary=binary, model="motorboat", speedup=SPEEDUP) as sitl, \
            RealOperator(sitl.ports.serial0) as op:
        op.request_streams(4)
        sitl.wait_listening(sitl.ports.serial1)
        log_dir = tmp / "companion"
        log_dir.mkdir()
        lines: list[tuple[float, str]] = []
        comp = subprocess.Popen(
            [sys.executable, "-m", "mavhelm.cli", "run", str(DEMO), "--connect",
             f"tcp:127.0.0.1:{sitl.ports.serial1}", "--clock", "autopilot",
             "--log-dir", str(log_dir)],
            cwd=log_dir, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, text=True, bufsize=1,
            preexec_fn=_set_parent_death_signal if sys.platform == "linux" else None)

        def read() -> None:
            assert comp.stdout is not None
            for line in comp.stdout:
                lines.append((time.monotonic(), line.rstrip("\n")))

        reader = threading.Thread(target=read, daemon=True)
        reader.start()

        def line_wall(fragment: str) -> float | None:
            return next((t for t, line in list(lines) if fragment in line), None)

        try:
            op.hand_over("GUIDED", timeout_s=60.0, retry_s=1.0 / SPEEDUP)
            op.wait_until(lambda: line_wall("MISSION ENDED") is not None
                          or comp.poll() is not None, MISSION_WALL_S, "MISSION ENDED")
            ended_wall = line_wall("MISSION ENDED")
            ended_boot = op.boot_ms
        finally:
            comp.send_signal(signal.SIGTERM)
            try:
                comp.wait(10.0)
            except subprocess.TimeoutExpired:
                comp.kill()
                comp.wait()
            reader.join(5.0)
        if ended_wall is None:
            print("bench_ardupilot_demo: the companion exited before MISSION ENDED:")
            print("\n".join(line for _, line in lines[-30:]))
            return 1
        online_wall = line_wall("helm ONLINE")
        alog = read_alog(next(log_dir.glob("*.alog")))

    started = [m for m in alog if m.name == "TASK_STARTED"]
    ended = next(m for m in alog if m.name == "MISSION_ENDED")
    t0, t1 = started[0].time, ended.time
    ticks = np.array([m.time for m in alog if m.name == "DESIRED_THRUST" and t0 <= m.time <= t1])
    period = np.diff(ticks)
    mission_ap = t1 - t0
    mission_wall = ended_wall - (online_wall or op.handed_over_wall)
    boot_ap = (ended_boot - op.handed_over_boot_ms) / 1000.0
    print(f"demo mission, mavhelm run --clock autopilot on real ArduPilot Rover SITL "
          f"(motorboat, --speedup {SPEEDUP}, -I {sitl.instance})")
    print(f"  tasks: {' -> '.join(m.string for m in started)}")
    print(f"  wall from start (SITL launch) to MISSION_ENDED   {ended_wall - t_start:7.2f} s")
    print(f"    of which SITL start + hand-over (armed GUIDED)  "
          f"{op.handed_over_wall - t_start:7.2f} s")
    print(f"    of which the mission (ONLINE -> MISSION_ENDED)  {mission_wall:7.2f} s")
    print(f"  autopilot time of the mission (.alog)            {mission_ap:7.2f} s "
          f"(autopilot's own time_boot_ms, hand-over -> end: {boot_ap:.2f} s)")
    print(f"  speed-up achieved                                x{mission_ap / mission_wall:.1f} "
          f"(asked x{SPEEDUP})")
    print(f"  tick period (DESIRED_THRUST stamps, autopilot s) median {np.median(period):.3f} "
          f"p99 {np.percentile(period, 99):.3f} max {period.max():.3f} (n={period.size}, "
          f"AppTick 10 Hz)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
