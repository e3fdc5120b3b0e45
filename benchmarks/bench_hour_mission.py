"""Benchmark: a one-hour boat mission with the companion attached, in lockstep.

A 150 m box patrolled with chained GoToWayPoint legs until an OverallTimeOut of one hour ends it.
Prints the simulator's speed-up over real time and the tracking error (cross-track distance
from each leg's line, ground truth). Asserts nothing.

Run twice: the simulator and the companion in lockstep, the operator's ground station closed
once it has handed over (what "the simulator with the companion" means), and the same with the
ground station kept connected and stepped throughout (its 1 Hz default streams are encoded,
sent and decoded every simulated second: about a tenth of the work).
"""

from __future__ import annotations

import math
import tempfile
import time
from pathlib import Path

import numpy as np

from mavhelm.demo.harness import SimulatedRun
from tests.support.mission import mission_text

CORNERS = [(0.0, 150.0), (150.0, 150.0), (150.0, 0.0), (0.0, 0.0)]
LAPS = 18
"""Laps of the 150 m box: 72 legs, about an hour at the rover.parm WP_SPEED (5 m/s × 80 %
thrust, less the turns); the OverallTimeOut ends it at 3600 s either way."""


def hour_mission() -> str:
    legs = []
    n = LAPS * len(CORNERS)
    for i in range(n):
        x, y = CORNERS[i % len(CORNERS)]
        start = ("InitialState = ON" if i == 0
                 else f"InitialState = OFF\n        StartFlag = Leg{i}Go")
        finish = f"Leg{i + 1}Go" if i + 1 < n else "EndMission"
        legs.append(f"""
    Task = GoToWayPoint
    {{
        Name = Leg{i}
        Location = {x}, {y}
        Radius = 5
        Thrust = 80
        TimeOut = 300
        {start}
        FinishFlag = {finish}
    }}""")
    return mission_text("".join(legs), nav={"X": "GPS @ 2.0, AP @ 2.0",
                                            "Y": "GPS @ 2.0, AP @ 2.0", "Yaw": "INS @ 1.0"})


def cross_track(track, legs) -> np.ndarray:
    """Distance of each truth sample from the line of the leg being driven."""
    errors = []
    for s in track:
        leg = legs(s.t)
        if leg is None:
            continue
        (x0, y0), (x1, y1) = leg
        dx, dy = x1 - x0, y1 - y0
        length = math.hypot(dx, dy)
        errors.append(abs((s.x - x0) * dy - (s.y - y0) * dx) / length)
    return np.asarray(errors)


def run_hour(keep_ground_station: bool) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "hour.moos"
        path.write_text(hour_mission())
        t0 = time.perf_counter()
        with SimulatedRun.start(path, fast_start=False) as run:
            run.hand_over()
            if not keep_ground_station:
                run.close_ground_station()
            run.run_until(lambda _n: run.mission_ended(), 3700.0)
            wall = time.perf_counter() - t0
            sim_time = run.clock.now()
            started = {m.string: m.time for m in run.values("TASK_STARTED")}
            windows = []
            for i in range(LAPS * len(CORNERS)):
                if f"Leg{i}" in started and i > 0:
                    windows.append((started[f"Leg{i}"], CORNERS[(i - 1) % 4], CORNERS[i % 4]))

            def leg_at(t: float):
                """The leg being driven at t, or None during the first 15 s (the turn onto it)."""
                current = None
                for when, a, b in windows:
                    if when <= t:
                        current = (a, b) if t >= when + 15.0 else None
                return current

            xte = cross_track(run.track, leg_at)
            legs_done = len([m for m in run.values("TASK_ENDED") if m.string.endswith(":complete")])
            gcs = ("ground station kept connected" if keep_ground_station
                   else "ground station closed after the hand-over")
            print(f"one-hour mission, box patrol, companion attached, lockstep over TCP; {gcs}")
            print(f"  reached EndMission: {run.mission_ended()}  legs completed: {legs_done}")
            print(f"  simulated {sim_time:.0f} s in {wall:.1f} s wall: speed-up "
                  f"{sim_time / wall:.0f}x real time")
            if xte.size:
                print(f"  cross-track error (truth): median {np.median(xte):.2f} m, "
                      f"p95 {np.percentile(xte, 95):.2f} m, max {xte.max():.2f} m")


def main() -> None:
    run_hour(keep_ground_station=False)
    run_hour(keep_ground_station=True)


if __name__ == "__main__":
    main()
