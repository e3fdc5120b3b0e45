"""``mavhelm tune``'s safety, against the built-in simulator in lockstep: it refuses without a
box and a confirmation, ends in the tick the operator changes the mode, stops at the box's
edge and stays within its margin, and refuses to start outside the box."""

from __future__ import annotations

from pathlib import Path

import pytest

from mavhelm.cli import main
from mavhelm.companion.tune import TuneSession, write_gains
from mavhelm.core.mission import load_mission, parse_mission
from mavhelm.demo.harness import SimulatedRun
from mavhelm.tuning.manoeuvre import Box, Manoeuvre, tune_mission_text
from tests.support.mission import mission_text

MARGIN = 5.0
USER = mission_text("""
    Task = TrackLine
    {
        Name   = Out
        P1     = 0, 0
        P2     = 0, 100
        Thrust = 80
    }
    Task = Survey
    {
        Center  = 0, 50
        A       = 80
        B       = 40
        Spacing = 20
        Lead    = 5
    }
""", imavlink={"OnlineModes": "GUIDED", "MaxTurnRate": 45}, helm={"AppTick": 10})
RECORD = {"HELM_STATE", "AP_CMD_YAW_RATE", "AP_CMD_THRUST", "TuneStop"}


def fly(box: Box, manoeuvre: Manoeuvre, *, start_heading: float = 0.0,
        until=None, max_time: float = 200.0) -> tuple[SimulatedRun, TuneSession]:
    mission = parse_mission(tune_mission_text(parse_mission(USER, "user.moos"), box, manoeuvre),
                            "tune.moos")
    run = SimulatedRun.start(mission, fast_start=True, record=RECORD,
                             start_heading=start_heading)
    session = TuneSession.attach(run.companion, box, manoeuvre)
    try:
        run.hand_over()
        done = until or (lambda now: session.finished)
        assert run.run_until(done, max_time), "the tune never finished"
    except BaseException:
        run.close()
        raise
    return run, session


@pytest.mark.parametrize("argv, says", [
    ([], "--box"),
    (["--box=-60,-40,60,40"], "--confirm-open-water"),
    (["--box=0,0,5,5", "--confirm-open-water"], "at least 20 m"),
    (["--box=0,0,nan,50", "--confirm-open-water"], "finite"),
])
def test_tune_refuses_without_a_box_and_a_confirmation(tmp_path, capsys, argv, says):
    path = tmp_path / "m.moos"
    path.write_text(USER)
    # an address nothing listens on: a refusal must come before any link is opened
    assert main(["tune", str(path), "--connect", "tcp:127.0.0.1:9", *argv]) == 2
    out = capsys.readouterr().out
    assert "refused" in out and says in out


def test_tune_flies_the_manoeuvre_inside_the_box_and_writes_the_gains(tmp_path):
    box = Box(-60.0, -40.0, 60.0, 40.0)
    run, session = fly(box, Manoeuvre(step_seconds=5.0))
    with run:
        assert session.watch.aborted is None and session.watch.stopped is None
        started = [m.string for m in run.values("TASK_STARTED")]
        for step in ("TuneStart", "TuneSpeedUp", "TuneZig1", "TuneTurn", "TuneSlow", "TuneEnd"):
            assert step in started
        assert max(box.outside_by(s.x, s.y) for s in run.track) == 0.0
        tuning = session.tuning()
    g = tuning.gains
    print("\n".join(tuning.report()))
    assert 0.0 < g.yaw_kp < 10.0 and 0.0 <= g.yaw_kd < 10.0 and 5.0 <= g.max_turn_rate <= 180
    assert 0.05 < tuning.yaw.time_constant < 3.0 and tuning.yaw.delay < 1.0
    assert 1.0 < tuning.speed.speed_at(100.0) < 6.0
    assert tuning.prediction.heading_settle < 10.0
    source = tmp_path / "user.moos"
    source.write_text(USER)
    out, backup = write_gains(source, tuning, tmp_path / "tuned.moos")
    assert backup is None and source.read_text() == USER
    tuned = load_mission(out)
    helm = tuned.process("pHelm")
    assert helm is not None and float(helm.require("YAW_PID_KP").value) == g.yaw_kp
    link = tuned.process("iMAVLink")
    assert link is not None and float(link.require("MaxTurnRate").value) == g.max_turn_rate
    leads = [float(t.require("Lead").value) for t in helm.tasks
             if t.name.lower() in ("trackline", "survey")]
    assert leads == [tuning.lead_for(80.0), tuning.lead_for(None)]
    _, backup = write_gains(source, tuning, None)
    assert backup is not None and Path(backup).read_text() == USER
    assert load_mission(source).process("pHelm").require("YAW_PID_KP").value == f"{g.yaw_kp:g}"


def test_a_mode_change_ends_the_tune_in_that_tick():
    box = Box(-60.0, -40.0, 60.0, 40.0)
    state: dict = {}

    def zigging(now: float) -> bool:
        return any(m.string == "TuneZig1" for m in state["run"].values("TASK_STARTED"))

    mission = parse_mission(tune_mission_text(parse_mission(USER, "user.moos"), box,
                                              Manoeuvre(step_seconds=5.0)), "tune.moos")
    with SimulatedRun.start(mission, fast_start=True, record=RECORD) as run:
        state["run"] = run
        session = TuneSession.attach(run.companion, box, Manoeuvre(step_seconds=5.0))
        run.hand_over()
        assert run.run_until(zigging, 120.0)
        run.gcs.set_mode("MANUAL")
        assert run.run_until(lambda now: session.finished, 5.0)
        offline = [m.time for m in run.values("HELM_STATE") if m.string == "OFFLINE"]
        assert offline, "the helm never went offline"
        assert "MANUAL" in (session.watch.aborted or "")
        # finished in the tick the helm went offline, and nothing was sent from then on
        assert run.clock.now() - offline[-1] <= run.companion.tick_period + 1e-9
        sent = [m.time for m in run.values("AP_CMD_YAW_RATE") + run.values("AP_CMD_THRUST")]
        assert sent and max(sent) < offline[-1]


def test_the_manoeuvre_stops_at_the_box_edge_within_the_margin():
    # a box too short for the outbound run: the look-ahead stops it at the edge
    box = Box(-20.0, -20.0, 20.0, 20.0)
    run, session = fly(box, Manoeuvre(step_seconds=8.0, high_thrust=100.0))
    with run:
        assert session.watch.stopped is not None, "the manoeuvre fitted: make the box smaller"
        assert run.values("TuneStop")
        worst = max(box.outside_by(s.x, s.y) for s in run.track)
        print(f"furthest outside the box: {worst:.2f} m")
        assert worst <= MARGIN
        assert session.watch.worst_excursion <= MARGIN


def test_tune_will_not_start_outside_the_box():
    box = Box(200.0, 200.0, 260.0, 260.0)  # the vehicle starts at the origin
    mission = parse_mission(tune_mission_text(parse_mission(USER, "user.moos"), box,
                                              Manoeuvre()), "tune.moos")
    with SimulatedRun.start(mission, fast_start=True, record=RECORD) as run:
        session = TuneSession.attach(run.companion, box, Manoeuvre())
        assert run.run_until(lambda now: session.finished, 60.0)
        assert "outside the box" in (session.watch.aborted or "")
        assert not run.values("AP_CMD_YAW_RATE")
