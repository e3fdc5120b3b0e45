"""RC channels checked against each other: the RC override must never write the channel of
the switch that engages the helm. Refused at load (``file:line: reason``, against ArduPilot's
default RCMAP when the mission does not say), and at run time when the autopilot's own
RCMAP_* parameters put steering or throttle on the engage channel."""

from __future__ import annotations

from pathlib import Path

import pytest

from mavhelm.companion.actuation import AutopilotView, RcOverride
from mavhelm.companion.companion import Plan
from mavhelm.core.clock import SimClock
from mavhelm.core.mission import MissionError, parse_mission
from mavhelm.demo.harness import SimulatedRun

MISSION = """LatOrigin = 56.4120
LongOrigin = -5.4760
ProcessConfig = iMAVLink
{{
    Actuation     = rc_override
    SystemID      = 255
{imavlink}
}}
ProcessConfig = pNav
{{
    X = GPS @ 2.0
    Y = GPS @ 2.0
    Yaw = INS @ 1.0
}}
ProcessConfig = pHelm
{{
    Task = ConstantHeading
    {{
        Name = East
        Heading = 90
        Thrust = 60
        TimeOut = NEVER
    }}
    Task = OverallTimeOut
    {{
        TimeOut = 3600
        FinishFlag = EndMission
    }}
    Task = EndMission
    {{
        StartFlag = EndMission
    }}
}}
"""


def write(tmp_path: Path, imavlink: str) -> Path:
    path = tmp_path / "rc.moos"
    path.write_text(MISSION.format(imavlink=imavlink))
    return path


@pytest.mark.parametrize("imavlink, line, words", [
    ("    EngageChannel = 3", 7, "EngageChannel = 3 is also the ThrottleChannel by default "
     "(ArduPilot's default RCMAP: steering 1, throttle 3): the RC override would drive the "
     "switch that engages the helm; choose another channel"),
    ("    EngageChannel = 1", 7, "EngageChannel = 1 is also the SteerChannel by default"),
    ("    EngageChannel = 7\n    ThrottleChannel = 7", 8,
     "ThrottleChannel = 7 is also the EngageChannel: the RC override would drive the switch"),
    ("    EngageChannel = 7\n    SteerChannel = 3", 8,
     "SteerChannel = 3 is also the ThrottleChannel by default (ArduPilot's default RCMAP: "
     "steering 1, throttle 3): steering and throttle need their own channels"),
])
def test_an_engage_channel_on_a_driven_channel_is_refused_at_load(tmp_path, imavlink, line,
                                                                   words):
    path = write(tmp_path, imavlink)
    with pytest.raises(MissionError) as err:
        Plan.from_mission(path, SimClock())
    assert str(err.value).startswith(f"{path}:{line}: "), str(err.value)
    assert words in str(err.value)


def test_channels_moved_together_are_accepted(tmp_path):
    path = write(tmp_path, "    EngageChannel = 3\n    ThrottleChannel = 2")
    plan = Plan.from_mission(path, SimClock())
    assert plan is not None


def test_guided_actuation_does_not_check_rc_channels(tmp_path):
    text = MISSION.format(imavlink="    EngageChannel = 3").replace("rc_override", "guided")
    path = tmp_path / "guided.moos"
    path.write_text(text)
    Plan.from_mission(path, SimClock())


def profile(engage: int) -> RcOverride:
    return RcOverride(1, 1, 20.0, 255, engage, 1800)


def params(roll: int, throttle: int) -> dict[str, float]:
    values = {"RCMAP_ROLL": roll, "RCMAP_THROTTLE": throttle, "MAV_GCS_SYSID": 255}
    for ch in (roll, throttle):
        values |= {f"RC{ch}_MIN": 1100, f"RC{ch}_TRIM": 1500, f"RC{ch}_MAX": 1900}
    return {k: float(v) for k, v in values.items()}


@pytest.mark.parametrize("roll, throttle, param", [(7, 3, "RCMAP_ROLL"),
                                                    (1, 7, "RCMAP_THROTTLE")])
def test_the_autopilots_rcmap_on_the_engage_channel_refuses_to_engage(roll, throttle, param):
    view = AutopilotView(params=params(roll, throttle), rc=[1500] * 8, gcs_silent_s=0.0)
    view.rc[6] = 1900
    refusal = profile(7).refusal(view)
    assert refusal is not None and refusal.startswith(f"the autopilot's {param} = 7 puts ")
    assert "engage switch RC7" in refusal
    assert profile(8).refusal(view) == "engage switch RC8 is low (1500 < 1800)"


@pytest.mark.slow
def test_the_simulator_with_throttle_on_the_engage_channel_never_engages(tmp_path):
    """RCMAP_THROTTLE = 7 on the simulated autopilot, engage switch RC7 held high: the helm
    stays offline with the reason (console and STATUSTEXT: HELM_STATUS) and sends no
    override at all."""
    mission = parse_mission(MISSION.format(imavlink="    EngageChannel = 7"), "rc.moos")
    run = SimulatedRun.start(mission, fast_start=True, operator_mode="MANUAL",
                             params={"RCMAP_THROTTLE": 7}, record={"HELM_STATUS"})
    sent: list[str] = []
    path = run.companion.bridge.send_path
    send = path.send_statustext
    path.send_statustext = lambda text, severity: (sent.append(text), send(text, severity))
    with run:
        run.hand_over()
        run.operator.hold_switch(7, 1900)
        run.run_for(5.0)
        assert not run.companion.bridge.online
        statuses = [m.string for m in run.values("HELM_STATUS")]
        assert statuses[-1] == (
            "offline: the autopilot's RCMAP_THROTTLE = 7 puts throttle on the engage switch "
            "RC7: the RC override would drive the switch that engages the helm; move "
            "EngageChannel in iMAVLink (or the autopilot's RCMAP)")
        assert run.companion_link.received["RC_CHANNELS_OVERRIDE"] == 0
        assert any("RCMAP_THROTTLE = 7 puts throttle on the engage switch" in text
                   for text in sent), "the ground station was told (STATUSTEXT)"


def test_mavhelm_check_fails_an_rcmap_on_the_engage_channel():
    from pymavlink.dialects.v20 import ardupilotmega as mavlink

    from mavhelm.companion.bridge import BridgeConfig
    from mavhelm.companion.check import Observed, checklist
    from mavhelm.core.geodesy import Origin

    origin = Origin(56.412, -5.476)
    config = BridgeConfig(actuation="rc_override", engage_channel=7, system_id=255)
    seen = Observed(connected=True, heard=set(config.streams), gps_fix=6,
                    position=origin.to_global(40.0, 30.0), ekf_flags=mavlink.EKF_POS_HORIZ_ABS,
                    params={"WP_SPEED": 2.0, "MAV_GCS_SYSID": 255.0, "RCMAP_ROLL": 1.0,
                            "RCMAP_THROTTLE": 7.0},
                    heartbeat=mavlink.MAVLink_heartbeat_message(
                        mavlink.MAV_TYPE_SURFACE_BOAT, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                        0x41, 0, 4, 3))
    fails = [str(line) for line in checklist(seen, config, origin) if line.status == "FAIL"]
    assert fails == ["FAIL  the autopilot's RCMAP_THROTTLE = 7 puts throttle on the engage "
                     "switch RC7: the RC override would drive the switch that engages the "
                     "helm; move EngageChannel in iMAVLink (or the autopilot's RCMAP)"], fails
    seen.params["RCMAP_THROTTLE"] = 3.0
    assert not [line for line in checklist(seen, config, origin) if line.status == "FAIL"]
