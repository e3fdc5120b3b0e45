"""Issue 19, reproduced and closed end to end in the simulator, unsigned: a stranger (system 77)
on another autopilot port sends the companion a restart, a remote flag and a third-party
request, and gets COMMAND_ACK DENIED (nothing for the request), with a line naming it on the
operator's ground station; the operator (MAV_GCS_SYSID 255) is still obeyed; a guest bound to
42:191 gets its answer, and 77:191 claiming to be it gets nothing done."""

from __future__ import annotations

from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.guest import send_request
from mavhelm.companion.link import AutopilotLink
from mavhelm.core.thirdparty import TUNNEL_PAYLOAD_TYPE, ThirdPartyRequest
from mavhelm.demo.harness import SimulatedRun

pytestmark = pytest.mark.slow

MISSION = """
LatOrigin = 56.4120
LongOrigin = -5.4760
ProcessConfig = iMAVLink
{
    RemoteFlag = GoHome
}
ProcessConfig = pNav
{
    X = GPS @ 2.0
    Y = GPS @ 2.0
    Yaw = INS @ 1.0
}
ProcessConfig = pHelm
{
    Allow = Sample@iScience:GoToWayPoint | From = 42:191
    Task = ConstantHeading
    {
        Name = Leg
        Heading = 90
        Thrust = 60
        TimeOut = NEVER
    }
    Task = Timer
    {
        Name = Home
        TimeOut = 600
        StartFlag = GoHome
    }
    Task = OverallTimeOut
    {
        TimeOut = 3600
        FinishFlag = EndMission
    }
    Task = EndMission
    {
        StartFlag = EndMission
    }
}
"""
REQUEST = (ThirdPartyRequest("Sample", "iScience").add_property("Location", "0,0")
           .execute_task("GoToWayPoint"))


def test_a_stranger_is_refused_and_the_operator_and_the_bound_guest_obeyed(tmp_path: Path):
    path = tmp_path / "mission.moos"
    path.write_text(MISSION)
    record = {"RESTART_HELM", "REMOTE_FLAG", "THIRDPARTY_REQUEST", "THIRDPARTY_REPLY",
              "MAVLINK_SENDER_REFUSED"}
    with SimulatedRun.start(path, record=record) as run:
        run.hand_over()
        run.run_for(3.0)
        port = f"tcp:127.0.0.1:{run.sim.ports[2]}"
        stranger = AutopilotLink(port, system_id=77, component_id=191)
        acks: list[tuple[int, int]] = []
        clock = iter(range(10**6))

        def steps() -> float:
            run.step()
            now = next(clock) * 0.05
            for msg in stranger.poll(now):
                if msg.get_type() == "COMMAND_ACK" and msg.target_system == 77:
                    acks.append((msg.command, msg.result))
            return now

        try:
            while not stranger.connected:
                steps()
            for command in (mavlink.MAV_CMD_USER_1, mavlink.MAV_CMD_USER_2):
                stranger.mav.command_long_send(1, 191, command, 0, 1, 0, 0, 0, 0, 0, 0)
            payload = REQUEST.encode()
            stranger.mav.tunnel_send(1, 191, TUNNEL_PAYLOAD_TYPE, len(payload),
                                     payload.ljust(128, b"\0"))
            for _ in range(60):
                steps()
        finally:
            stranger.close()
        assert acks == [(mavlink.MAV_CMD_USER_1, mavlink.MAV_RESULT_DENIED),
                        (mavlink.MAV_CMD_USER_2, mavlink.MAV_RESULT_DENIED)]
        assert not run.values("RESTART_HELM") and not run.values("REMOTE_FLAG")
        assert not run.values("THIRDPARTY_REQUEST"), "the stranger's request never reached pHelm"
        assert any("REFUSED COMMAND_LONG USER_1 from 77:191: not an allowed sender" in text
                   for _, text in run.gcs.statustexts), run.gcs.statustexts[-5:]
        assert run.companion.bridge.gate.refused == 3

        run.gcs.conn.mav.command_long_send(1, 191, mavlink.MAV_CMD_USER_2, 0, 1, 0, 0, 0, 0,
                                           0, 0)
        run.run_for(2.0)
        assert [m.string for m in run.values("REMOTE_FLAG")] == ["GoHome"], \
            "the operator is still obeyed"

        guest = AutopilotLink(port, system_id=42, component_id=191)
        try:
            reply = send_request(guest, REQUEST, (1, 191), 50.0, steps)
        finally:
            guest.close()
        assert reply == "Sample@iScience:ACCEPTED:task Sample_iScience at priority 2"
