"""Reload at sea and remote flags, end to end in the simulator: a ground station sends
COMMAND_LONG to the companion (system 1, component 191) through the autopilot, exactly as
MAVProxy's ``long`` command does after ``set target_component 191``."""

from __future__ import annotations

from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.demo.harness import SimulatedRun
from tests.support.mission import mission_text

pytestmark = pytest.mark.slow

TASKS = """
    Task = ConstantHeading
    {
        Name = Leg
        Heading = %s
        Thrust = 60
        TimeOut = NEVER
    }
    Task = GoToWayPoint
    {
        Name = Home
        Priority = 2
        Location = 0,0
        Thrust = 60
        StartFlag = GoHome
        FinishFlag = EndMission
    }
"""


def mission(heading: object) -> str:
    """A leg on ``heading`` (line 19), and Home on the ground station's GoHome flag."""
    return mission_text(TASKS % heading, imavlink={"RemoteFlag": "GoHome"})


RECORD = {"HELM_RELOADED", "HELM_RELOAD_ERROR", "HELM_WARNING", "TASK_STARTED", "GoHome",
          "REMOTE_FLAG", "MAVLINK_WARNING"}


def heading_error(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def to_companion(run: SimulatedRun, command: int, param1: float) -> None:
    run.gcs.conn.mav.command_long_send(1, 191, command, 0, param1, 0, 0, 0, 0, 0, 0)


def acks(run: SimulatedRun, command: int) -> list[int]:
    return [result for _, cmd, result in run.gcs.acks if cmd == command]


@pytest.fixture
def running(tmp_path: Path):
    path = tmp_path / "mission.moos"
    path.write_text(mission(90))
    with SimulatedRun.start(path, record=RECORD) as run:
        run.hand_over()
        run.run_for(20.0)
        yield run, path


def test_a_broken_reload_keeps_the_running_mission(running):
    run, path = running
    path.write_text(mission("nan"))
    to_companion(run, mavlink.MAV_CMD_USER_1, 1)
    run.run_for(2.0)
    assert acks(run, mavlink.MAV_CMD_USER_1) == [mavlink.MAV_RESULT_ACCEPTED]
    [error] = [m.string for m in run.values("HELM_RELOAD_ERROR")]
    assert error == (f"reload refused, the running mission continues: {path}:19: Heading "
                     "must be a finite number, got 'nan'")
    assert any("reload refused" in text for _, text in run.gcs.statustexts), \
        "the operator's ground station was told"
    assert not run.values("HELM_RELOADED")
    run.run_for(10.0)
    assert heading_error(run.sim.truth.heading, 90.0) < 10.0, "still on the old leg"
    assert run.companion.helm.task("Leg").active


def test_a_good_reload_replaces_the_mission(running):
    run, path = running
    old_helm = run.companion.helm
    path.write_text(mission(270))
    to_companion(run, mavlink.MAV_CMD_USER_1, 1)
    run.run_for(40.0)
    assert [m.string for m in run.values("HELM_RELOADED")] == [f"{path}: 4 tasks"]
    assert run.companion.helm is not old_helm
    assert heading_error(run.sim.truth.heading, 270.0) < 10.0, "the new leg is flown"
    assert not run.values("HELM_WARNING"), "only the helm changed: no restart needed"


def test_a_ground_station_posts_a_remote_flag(running):
    run, _ = running
    to_companion(run, mavlink.MAV_CMD_USER_2, 5)
    to_companion(run, mavlink.MAV_CMD_USER_2, 1)
    run.run_for(2.0)
    assert acks(run, mavlink.MAV_CMD_USER_2) == [mavlink.MAV_RESULT_DENIED,
                                                 mavlink.MAV_RESULT_ACCEPTED]
    assert [m.string for m in run.values("REMOTE_FLAG")] == ["GoHome"]
    assert "Home" in [m.string for m in run.values("TASK_STARTED")]
    assert run.companion.helm.last_winners["RUDDER"][1].name == "Home", \
        "the priority-2 task took the rudder from the priority-3 leg"


def test_a_guest_asks_over_mavlink_and_gets_its_answer(tmp_path: Path):
    from mavhelm.companion.guest import send_request
    from mavhelm.companion.link import AutopilotLink
    from mavhelm.core.thirdparty import ThirdPartyRequest

    text = mission(90).replace(
        "    Task = ConstantHeading", "    Allow = Sample@iScience:GoToWayPoint | From = 1:25\n"
        "    Task = ConstantHeading", 1)
    path = tmp_path / "guest.moos"
    path.write_text(text)
    with SimulatedRun.start(path, record=RECORD | {"THIRDPARTY_REPLY"}) as run:
        run.hand_over()
        run.run_for(5.0)
        guest = AutopilotLink(f"tcp:127.0.0.1:{run.sim.ports[2]}", system_id=1,
                              component_id=25)
        clock = iter(range(10**6))

        def steps() -> float:
            run.step()  # the simulator forwards between its links as it steps
            return next(clock) * 0.05

        try:
            granted = send_request(guest, ThirdPartyRequest("Sample", "iScience")
                                   .add_property("Location", "0,0").add_property("Thrust", 60)
                                   .execute_task("GoToWayPoint"), (1, 191), 50.0, steps)
            denied = send_request(guest, ThirdPartyRequest("Spy", "iModem")
                                  .add_property("Location", "0,0")
                                  .execute_task("GoToWayPoint"), (1, 191), 50.0, steps)
        finally:
            guest.close()
        assert granted == "Sample@iScience:ACCEPTED:task Sample_iScience at priority 2"
        assert denied == ("Spy@iModem:DENIED:not allowed: no Allow line grants Spy@iModem a "
                          "GoToWayPoint task")
        assert run.companion.helm.last_winners["RUDDER"][1].name == "Sample_iScience"
