"""``mavhelm demo``: a skipper's way to try a mission in the built-in simulator before the water.

Runs the mission end to end (companion ↔ simulator over TCP, an operator's ground station
handing over in GUIDED) faster than real time, then writes the run's .alog, ground-truth track,
summary and plot under ``runs/<timestamp>/``.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass
from pathlib import Path

from mavhelm.companion.moos import mission_notes
from mavhelm.core.mission import load_mission
from mavhelm.demo.harness import SimulatedRun
from mavhelm.demo.report import Summary, format_summary, plot_run, summarize, write_track_csv
from mavhelm.sitl.models import DEFAULT_MODEL

DEFAULT_MISSION = Path(__file__).resolve().parent / "demo.moos"
"""The demo mission ships inside the package (``examples/demo.moos`` in the repository is a link
to it), so ``mavhelm demo`` runs from any folder after ``pip install``."""


@dataclass
class DemoResult:
    out_dir: Path
    summary: Summary
    ended: bool


def overall_timeout(mission) -> float:
    """The mission's OverallTimeOut, which bounds how long the demo may run."""
    for block in mission.tasks:
        if block.name.lower() == "overalltimeout":
            value = block.get("TimeOut")
            if value is not None and value.upper() != "NEVER":
                return float(value)
    return 3600.0


def run_demo(mission_path: str | Path = DEFAULT_MISSION, out_root: str | Path = "runs", *,
             model: str = DEFAULT_MODEL, defaults: str | None = None, fast_start: bool = False,
             scenario=None, seed: int = 0, echo=print) -> DemoResult:
    mission = load_mission(mission_path)
    stamp = dt.datetime.now().strftime("%Y%m%d-%H%M%S")
    out_dir = Path(out_root) / stamp
    suffix = 1
    while out_dir.exists():
        out_dir = Path(out_root) / f"{stamp}-{suffix}"
        suffix += 1
    out_dir.mkdir(parents=True)
    echo(f"mission {mission_path}; simulated {model}; logs in {out_dir}")
    for note in mission_notes(mission):
        echo(f"  not used: {note}")
    with SimulatedRun.start(mission, model=model,
                            defaults=defaults, fast_start=fast_start,
                            scenario=scenario, seed=seed,
                            alog_path=out_dir / "mission.alog") as run:
        handed = run.hand_over()
        echo(f"operator armed the autopilot and switched to GUIDED at {handed:.1f} s")
        ended = run.run_until(lambda _now: run.mission_ended(),
                              overall_timeout(mission) + 60.0)
        if ended:
            run.run_for(5.0)
        summary = summarize(run.messages, run.track, run.wall_seconds)
        write_track_csv(run.track, out_dir / "track.csv")
        plot_run(run.track, run.messages, mission, out_dir / "track.png",
                 title=f"{Path(mission_path).name} in the simulator")
    text = format_summary(summary)
    (out_dir / "summary.txt").write_text(text + "\n")
    echo(text)
    echo(f"wrote {out_dir / 'mission.alog'}, {out_dir / 'track.png'}, {out_dir / 'summary.txt'}")
    return DemoResult(out_dir, summary, ended)
