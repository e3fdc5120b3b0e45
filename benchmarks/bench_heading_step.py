"""Benchmark: heading steps on the real ArduPilot SITL — how far the heading loop overshoots a
change of heading, and how soon it settles, at the product's defaults or given gains.

The line-holding benchmark (``bench_tracking``) judges the heading loop by the lines it holds;
a task that asks for a new heading (ConstantHeading, GoToWayPoint's first turn) sees the loop's
step response instead, and the two can want different gains (``docs/tracking.md``, "What a line
wants of the heading loop"). Here a mission of ConstantHeading tasks at Thrust 100 steps the
heading 90 → 120 → 90 → 60 → 90° on the real SITL (its own autopilot in GUIDED, the companion
as ``mavhelm run`` runs it), and SIMSTATE's yaw (the truth, 20 Hz) gives per step, counted from
the yaw's first 3° towards the new heading: the overshoot past it (degrees) and the time after
which it stays within 2°.

Prints the figures; asserts nothing. Needs MAVHELM_ARDUPILOT (the ardurover SITL binary);
without it, says so and exits 0. Run: ``MAVHELM_ARDUPILOT=../shared/ardupilot/ardurover
.venv/bin/python -m benchmarks.bench_heading_step --model motorboat-skid [--yaw-kp 1 --yaw-kd 0]``.

Measured on 2026-12-02 (WP_SPEED 5, calm, one run each; overshoot per step, then the time to
stay within 2°):

- motorboat, the defaults (KP 0.75, KD 0.2, MaxTurnRate 90): 1.1–7.3°, 2.2–6.8 s; again after a
  refactor of the flight, 1.5–4.3°, 1.5–2.2 s (in the stock wind 2.0–3.7°, 2.2–3.2 s); KP 1.0
  with KD 0: 13.1–16.2°, 2.1–2.7 s; the gains the tune wrote for it that day (KP 0.61, KD 0,
  MaxTurnRate 57): 0–0.7°, 1.0–1.3 s;
- motorboat-skid, the defaults: 2.5–8.7°, 2.8–6.4 s; KP 1.0 with KD 0: 11.9–22.5°, 2.3–3.9 s;
  the tune's gains from a trusted fit in the wind (KP 0.45, KD 0.045, MaxTurnRate 99):
  0–0.3°, 1.2–1.4 s.

So the tune's gains turn the heading as its model predicts, better than the defaults, where
on lines at 5 m/s they do no better (``bench_tracking``); KP 1.0 with no KD holds lines best and
overshoots a heading step most.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

from benchmarks.bench_tracking import CALM, LAT0, LON0, WIND, fly_real, product_defaults
from tests.support.ardupilot import SKIP_REASON, ardupilot_binary
from tests.support.mission import NAV_AP_FALLBACK
from tests.support.mission import mission_text as standard_mission

STEPS: tuple[tuple[float, float], ...] = ((90.0, 6.0), (120.0, 8.0), (90.0, 8.0), (60.0, 8.0),
                                          (90.0, 8.0))
"""(heading, seconds) of each ConstantHeading: the first settles the course, then ±30° steps."""
ONSET = 3.0
"""Degrees the yaw must move towards the new heading for the step to count as begun."""
WITHIN = 2.0
"""Degrees: the step is settled once the yaw stays this close to the new heading."""


@dataclass(frozen=True)
class StepFigures:
    start: float
    target: float
    overshoot: float
    """Degrees past the new heading (negative: it never reached it)."""
    settle: float | None
    """Seconds from the onset until the yaw stays within WITHIN; None: not by the step's end."""


def steps_mission(kp: float, kd: float, max_turn_rate: float) -> str:
    tasks = []
    for k, (heading, seconds) in enumerate(STEPS):
        start = f"        StartFlag = Step{k}\n" if k else ""
        finish = f"Step{k + 1}" if k < len(STEPS) - 1 else "EndMission"
        tasks.append(f"""
    Task = ConstantHeading
    {{
        Name = Heading{k}
        Heading = {heading:g}
        Thrust = 100
        TimeOut = {seconds:g}
{start}        FinishFlag = {finish}
    }}
""")
    return standard_mission(
        "".join(tasks), origin=(LAT0, LON0), nav=NAV_AP_FALLBACK,
        imavlink=[("OnlineModes", "GUIDED"), ("MaxTurnRate", f"{max_turn_rate:g}")],
        helm={"AppTick": 10, "MAXRUDDER": 20, "MAXTHRUST": 100, "YAW_PID_KP": f"{kp:g}",
              "YAW_PID_KD": f"{kd:g}"},
        overall_timeout=120, clock_name="Clock", end_name="AllStop")


def measure(yaw: list[tuple[float, float]]) -> list[StepFigures]:
    """Each step's figures from the truth's (autopilot s, yaw degrees)."""
    out: list[StepFigures] = []
    i = 0
    previous = STEPS[0][0]
    for target, seconds in STEPS[1:]:
        sign = 1.0 if target > previous else -1.0
        while i < len(yaw) and sign * (yaw[i][1] - previous) < ONSET:
            i += 1
        if i >= len(yaw):
            break
        onset = yaw[i][0]
        span = [(t, y) for t, y in yaw[i:] if t - onset < seconds - 1.0]
        overshoot = max(sign * (y - target) for _, y in span)
        outside = [t for t, y in span if abs(y - target) > WITHIN]
        settle = None if outside and outside[-1] == span[-1][0] else \
            (outside[-1] - onset if outside else 0.0)
        out.append(StepFigures(previous, target, overshoot, settle))
        previous = target
        while i < len(yaw) and yaw[i][0] - onset < seconds - 1.5:
            i += 1
    return out


def fly(binary: Path, folder: Path, model: str, params: dict[str, float], kp: float, kd: float,
        max_turn_rate: float) -> list[tuple[float, float]]:
    """Fly the steps on a fresh SITL; the truth's (autopilot s, yaw degrees) after the
    hand-over."""
    mission = folder / "steps.moos"
    mission.write_text(steps_mission(kp, kd, max_turn_rate))
    flight = fly_real(binary, folder, mission, params, model)
    return [(boot / 1000.0, math.degrees(yaw) % 360.0)
            for wall, boot, _lat, _lng, yaw in flight.simstates
            if boot is not None and wall >= flight.online]


def main(argv: list[str] | None = None) -> int:
    defaults = product_defaults()
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", default="motorboat",
                        help="real SITL model: motorboat, motorboat-skid, rover, rover-skid")
    parser.add_argument("--wp-speed", type=float, default=5.0, help="WP_SPEED, m/s (default 5)")
    parser.add_argument("--condition", choices=["calm", "wind"], default="calm",
                        help="calm, or the stock wind and waves (default calm)")
    parser.add_argument("--yaw-kp", type=float, default=defaults.yaw_kp)
    parser.add_argument("--yaw-kd", type=float, default=defaults.yaw_kd)
    parser.add_argument("--max-turn-rate", type=float, default=defaults.max_turn_rate)
    args = parser.parse_args(argv)
    binary = ardupilot_binary()
    if binary is None:
        print(f"bench_heading_step: {SKIP_REASON}")
        return 0
    params = {**(CALM if args.condition == "calm" else WIND), "WP_SPEED": args.wp_speed}
    with tempfile.TemporaryDirectory(prefix="bench-heading-step-") as folder:
        yaw = fly(binary, Path(folder), args.model, params, args.yaw_kp, args.yaw_kd,
                  args.max_turn_rate)
    print(f"{args.model}, WP_SPEED {args.wp_speed:g}, {args.condition}: YAW_PID_KP "
          f"{args.yaw_kp:g}, KD {args.yaw_kd:g}, MaxTurnRate {args.max_turn_rate:g}")
    figures = measure(yaw)
    if not figures:
        print("  no step was seen in the truth's yaw")
        return 1
    for f in figures:
        settle = "not by the step's end" if f.settle is None else f"after {f.settle:.1f} s"
        print(f"  {f.start:g} -> {f.target:g} deg: overshoot {f.overshoot:5.1f} deg, within "
              f"{WITHIN:g} deg {settle}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
