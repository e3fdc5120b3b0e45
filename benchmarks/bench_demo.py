"""Benchmark: helm + nav tick time on the demo mission, and the lockstep speed-up.

Prints figures; asserts nothing (a shared machine's speed is not a test result).
Run: ``make bench`` or ``.venv/bin/python -m benchmarks.bench_demo``.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from mavhelm.demo.harness import SimulatedRun

DEMO = Path(__file__).resolve().parent.parent / "examples" / "demo.moos"


def percentiles_us(samples: list[float]) -> str:
    a = np.asarray(samples) * 1e6
    return f"median {np.median(a):7.1f} us   p99 {np.percentile(a, 99):7.1f} us   (n={a.size})"


def main() -> None:
    t0 = time.perf_counter()
    with SimulatedRun.start(DEMO, fast_start=False) as run:
        run.companion.community.profile = True
        ended = run.run_mission(max_time=500.0)
        wall = time.perf_counter() - t0
        seconds = run.companion.community.app_seconds
        helm_nav = [a + b for a, b in zip(seconds["pNav"], seconds["pHelm"], strict=True)]
        print("demo mission (examples/demo.moos, real ArduPilot start-up timeline)")
        print(f"  mission reached EndMission: {ended}")
        print(f"  helm+nav tick        {percentiles_us(helm_nav)}")
        print(f"  whole companion tick {percentiles_us(run.companion_tick_seconds)}"
              "  (incl. MAVLink parse/encode)")
        for name in ("iMAVLink", "pNav", "pHelm", "iMAVLinkOut"):
            print(f"    {name:<12s} {percentiles_us(seconds[name])}")
        sim_time = run.clock.now()
        print(f"  simulated {sim_time:.0f} s in {run.wall_seconds:.2f} s of lockstep wall time: "
              f"speed-up {sim_time / run.wall_seconds:.0f}x "
              f"(incl. setup: {sim_time / wall:.0f}x)")


if __name__ == "__main__":
    main()
