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

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from tests.support.ardupilot import (
    SKIP_REASON,
    CompanionProcess,
    RealOperator,
    RealSitl,
    ardupilot_binary,
)

ROOT = Path(__file__).resolve().parent.parent
DEMO = ROOT / "examples" / "demo.moos"
SPEEDUP = 20
MISSION_WALL_S = 120.0     # a hang guard, not a figure


def main() -> int:
    binary = ardupilot_binary()
    if binary is None:
        print(f"bench_ardupilot_demo: skipped: {SKIP_REASON}")
        return 0
    with tempfile.TemporaryDirectory(prefix="mavhelm-bench-ardupilot-") as tmp:
        return run(binary, Path(tmp))


def run(binary: Path, tmp: Path) -> int:
    t_start = time.monotonic()
    with RealSitl(tmp / "sitl", binary=binary, model="motorboat", speedup=SPEEDUP) as sitl, \
            RealOperator(sitl.ports.serial0) as op:
        op.request_streams(4)
        sitl.wait_listening(sitl.ports.serial1)
        comp = CompanionProcess(DEMO, sitl.ports.serial1, tmp / "companion")

        def line_wall(fragment: str) -> float | None:
            hit = comp.find(fragment)
            return hit[0] if hit is not None else None

        try:
            op.hand_over("GUIDED", timeout_s=60.0, retry_s=1.0 / SPEEDUP)
            op.wait_until(lambda: line_wall("MISSION ENDED") is not None or not comp.running(),
                          MISSION_WALL_S, "MISSION ENDED")
            ended_wall = line_wall("MISSION ENDED")
            ended_boot = op.boot_ms
        finally:
            comp.stop()
        if ended_wall is None:
            print("bench_ardupilot_demo: the companion exited before MISSION ENDED:")
            print(comp.output(30))
            return 1
        online_wall = line_wall("helm ONLINE")
        alog = comp.alog()

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
