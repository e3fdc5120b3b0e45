"""The spec's Figure 1 mission, adapted to a boat (examples/figure1.moos), flown end to end in
the simulator: the flags chain transit → survey → return → EndMission, the safety box never
fires, and the boat comes home."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from mavhelm.demo.harness import SimulatedRun

pytestmark = pytest.mark.slow

FIGURE1 = Path(__file__).resolve().parents[1] / "examples" / "figure1.moos"
FLAGS = ("Transit", "StartSurvey", "GoHome", "EndMission")


def test_figure1_flies_its_flag_chain_to_the_end():
    record = {*FLAGS, "TASK_STARTED", "TASK_ENDED", "MISSION_ENDED", "Survey_LEG"}
    with SimulatedRun.start(FIGURE1, record=record) as run:
        assert run.run_mission(max_time=1800.0), "EndMission never went active"
        flags = [m.name for m in run.messages if m.name in FLAGS]
        firsts = [name for i, name in enumerate(flags) if name not in flags[:i]]
        assert firsts == list(FLAGS), flags
        started = [m.string for m in run.values("TASK_STARTED")]
        assert [n for n in started if n != "OneHour" and n != "WorkingArea"] == [
            "InitialDelay", "Transit", "Survey", "Return", "AllStop"]
        ended = dict(m.string.split(":") for m in run.values("TASK_ENDED"))
        assert ended == {"InitialDelay": "timeout", "Transit": "complete",
                         "Survey": "complete", "Return": "complete"}, ended
        assert [int(m.double) for m in run.values("Survey_LEG")][:4] == [0, 1, 2, 3]
        end = run.values("MISSION_ENDED")[0]
        assert end.string == "AllStop"
        farthest = max(math.hypot(s.x - 200.0, s.y - 400.0) for s in run.track)
        at_end = min(run.track, key=lambda s: abs(s.t - end.time))
        assert math.hypot(at_end.x, at_end.y) < 10.0, "home again"
        assert farthest > 400.0
        print(f"\nfigure1: mission {end.time - run.operator.handed_over_at:.0f} s simulated "
              f"in {run.wall_seconds:.1f} s wall")
