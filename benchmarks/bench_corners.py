"""Benchmark: sharp corners. A zig-zag of chained TrackLines (a 20 m run-in east, then four
60 m lines turning by the corner's angle alternately to starboard and port) flown at the
product's defaults in calm water, on the real ArduPilot Rover SITL (``MAVHELM_ARDUPILOT``) or in
``mavhelm sim`` (``--sim``; its figures include the simulated GPS's wander, ~0.2 m RMS and 0.5 m
at most on a straight line). The RMS and largest |XTE| (m, ground truth) in the held part of
each line after the run-in, from 10 m along it to 5 m before its end (``tests.support.routes``),
and the mission's time.

    MAVHELM_ARDUPILOT=../shared/ardupilot/ardurover python -m benchmarks.bench_corners \\
        --wp-speed 5 --turns 90,135,160

Measured 2026-12-02, motorboat, one run each (``docs/tracking.md``, "Sharp corners").
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

from mavhelm.core.mission import parse_mission
from mavhelm.demo.harness import SimulatedRun
from tests.support.routes import chained, held_xte, zigzag

from . import bench_tracking as bt

MAX_TIME_S = 400.0


def mission_kind(turn: float) -> str:
    """Register the zig-zag of ``turn``° as one of ``bench_tracking``'s missions; its name."""
    name = f"Zig{turn:g}"
    text = chained(zigzag(turn), "LEAD_LINE")
    bt.TASKS[name] = text.replace("{", "{{").replace("}", "}}").replace("LEAD_LINE", "{lead}")
    return name


def fly_real(turn: float, speed: float, model: str, folder: Path) -> tuple[list, str, float]:
    binary = Path(os.environ["MAVHELM_ARDUPILOT"])
    fig = bt.run_real(binary, folder / f"{model}-{speed:g}-{turn:g}", mission_kind(turn),
                      bt.DEFAULTS, {**bt.CALM, "WP_SPEED": speed}, model)
    track = [(x, y) for _, x, y in fig.track]
    duration = fig.track[-1][0] - fig.track[0][0] if fig.track else 0.0
    return track, fig.note, duration


def fly_sim(turn: float, speed: float) -> tuple[list, str, float]:
    mission = parse_mission(bt.mission_text(mission_kind(turn), bt.DEFAULTS), "zigzag.moos")
    with SimulatedRun.start(mission, fast_start=True, start_heading=90.0,
                            params={"WP_SPEED": speed}) as run:
        ended = run.run_mission(max_time=MAX_TIME_S, linger=0.0)
        samples = list(run.track)
    track = [(s.x, s.y) for s in samples]
    duration = samples[-1].t - samples[0].t if samples else 0.0
    return track, "" if ended else "did not end", duration


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--wp-speed", type=float, default=2.0, help="WP_SPEED, m/s")
    parser.add_argument("--turns", default="90,135,160", help="corner angles, degrees")
    parser.add_argument("--model", default="motorboat", help="real SITL model")
    parser.add_argument("--sim", action="store_true", help="mavhelm sim, not the real SITL")
    parser.add_argument("--logs", type=Path, help="keep the real runs' logs in this folder")
    args = parser.parse_args(argv)
    if not args.sim and "MAVHELM_ARDUPILOT" not in os.environ:
        print("set MAVHELM_ARDUPILOT to the ardurover SITL binary, or use --sim")
        return 2
    folder = args.logs or Path(tempfile.mkdtemp(prefix="bench_corners-"))
    where = "mavhelm sim" if args.sim else f"real {args.model}"
    for turn in (float(a) for a in args.turns.split(",")):
        if args.sim:
            track, note, duration = fly_sim(turn, args.wp_speed)
        else:
            track, note, duration = fly_real(turn, args.wp_speed, args.model, folder)
        worst = held_xte(track, zigzag(turn)) if track else []
        cells = "  ".join("-" if w is None else f"{w[0]:.2f}/{w[1]:.2f}" for w in worst)
        print(f"{where} zig-zag {turn:3g} deg @ {args.wp_speed:g} m/s: RMS/max |XTE| per line "
              f"{cells}  ({duration:.0f} s) {note}", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
