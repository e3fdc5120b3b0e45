"""EndMission's HandBack in the simulator: the vehicle is given to the autopilot in HOLD,
confirmed from the HEARTBEAT, and the helm goes offline; never over an operator's mode."""

from __future__ import annotations

from pathlib import Path

import pytest

from mavhelm.core.mission import parse_mission
from mavhelm.demo.harness import SimulatedRun

pytestmark = pytest.mark.slow

DEMO = (Path(__file__).resolve().parents[1] / "examples" / "demo.moos").read_text()


def mission(hand_back: str, overall: str = "400"):
    text = DEMO.replace("        StartFlag = EndMission\n    }",
                        f"        StartFlag = EndMission\n        HandBack  = {hand_back}\n    }}")
    text = text.replace("TimeOut    = 400", f"TimeOut    = {overall}")
    assert f"HandBack  = {hand_back}" in text
    return parse_mission(text, "handback.moos")


def test_end_mission_hands_the_boat_back_in_hold():
    record = {"HELM_HANDBACK", "HELM_HANDBACK_DONE", "HELM_ONLINE", "AP_MODE", "MISSION_ENDED"}
    with SimulatedRun.start(mission("HOLD", overall="60"), record=record) as run:
        assert run.run_mission(max_time=200.0)
        ended = run.values("MISSION_ENDED")[0].time
        run.run_for(5.0)
        done = run.values("HELM_HANDBACK_DONE")
        assert [m.string for m in done] == ["HOLD"]
        assert done[0].time - ended < 1.0, "confirmed from the next HEARTBEAT"
        assert run.gcs.mode == "HOLD"
        assert run.values("HELM_ONLINE")[-1].double == 0.0, "HOLD is not an online mode"
        assert run.companion.mission_over()


def test_a_mission_that_ends_while_the_operator_has_the_boat_leaves_the_mode_alone():
    record = {"HELM_HANDBACK_ERROR", "MISSION_ENDED"}
    with SimulatedRun.start(mission("HOLD"), record=record) as run:
        run.hand_over()
        run.run_for(10.0)
        run.operator.mode = "MANUAL"
        run.gcs.set_mode("MANUAL")
        run.run_until(lambda _now: run.gcs.mode == "MANUAL", 10.0)
        run.companion.bus.notify("EndMission", "operator abort", "test")
        run.run_for(5.0)
        assert run.values("MISSION_ENDED"), "EndMission heard its StartFlag while offline"
        errors = [m.string for m in run.values("HELM_HANDBACK_ERROR")]
        assert errors == ["mission ended while the helm was offline: the operator's mode "
                          "MANUAL is left alone"]
        assert run.gcs.mode == "MANUAL"
