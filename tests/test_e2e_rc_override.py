"""The rc_override profile and servo outputs end to end in the simulator, over real TCP:
the companion drives a MANUAL boat through RC_CHANNELS_OVERRIDE only while the operator's
engage switch is up, releases every channel it drove the moment it goes offline, refuses to
engage when MAV_GCS_SYSID is not its system id, and a SetActuator vote reaches a servo."""

from __future__ import annotations

import math

import pytest

from mavhelm.core.mission import parse_mission
from mavhelm.demo.harness import SimulatedRun
from tests.support.mission import mission_text

pytestmark = pytest.mark.slow

TASKS = """
    Task = ConstantHeading
    {
        Name = East
        Heading = 90
        Thrust = 60
        TimeOut = NEVER
    }
    Task = SetActuator
    {
        Name = Winch
        Actuator = WINCH
        Value = 50
        TimeOut = NEVER
    }
"""

RECORD = {"HELM_ONLINE", "HELM_STATUS", "AP_CMD_RC_STEER", "AP_CMD_RC_THROTTLE",
          "AP_CMD_SERVO9", "AP_MODE"}


def start(sysid: int) -> SimulatedRun:
    mission = parse_mission(mission_text(TASKS, imavlink={
        "Actuation": "rc_override", "SystemID": sysid, "EngageChannel": 7, "EngagePWM": 1800,
        "Servo": "WINCH@9:1100-1900"}), "rc.moos")
    run = SimulatedRun.start(mission, fast_start=True, operator_mode="MANUAL", record=RECORD)
    run.hand_over()
    return run


def statuses(run: SimulatedRun) -> list[str]:
    return [m.string for m in run.values("HELM_STATUS")]


def test_rc_override_engages_on_the_switch_drives_and_releases():
    with start(sysid=255) as run:
        run.run_for(3.0)
        assert statuses(run)[-1] == "offline: engage switch RC7 is low (1500 < 1800)"
        assert not run.values("AP_CMD_RC_THROTTLE"), "nothing is overridden before the switch"
        assert run.companion_link.received["RC_CHANNELS_OVERRIDE"] == 0
        x0, y0 = run.sim.truth.x, run.sim.truth.y
        run.operator.hold_switch(7, 1900)
        run.run_until(lambda _now: run.companion.bridge.online, 5.0)
        engaged_at = run.clock.now()
        assert statuses(run)[-1] == "ONLINE: autopilot armed in MANUAL"
        run.run_for(30.0)
        truth = run.sim.truth
        assert math.hypot(truth.x - x0, truth.y - y0) > 20.0, "the boat was driven"
        assert abs((truth.heading - 90.0 + 180.0) % 360.0 - 180.0) < 10.0
        throttle = [m.double for m in run.values("AP_CMD_RC_THROTTLE")]
        assert throttle and all(p == 1500 + 0.6 * 400 for p in throttle), "60 % of RC3 range"
        overrides = [m.time for m in run.values("AP_CMD_RC_STEER")]
        assert max(b - a for a, b in zip(overrides, overrides[1:], strict=False)) < 0.15, \
            "refreshed every tick, far inside RC_OVERRIDE_TIME"
        assert [m.double for m in run.values("AP_CMD_SERVO9")][0] == 1700, "+50 % of 1100-1900"
        assert run.sim.autopilot.servo_outputs()[8] == 1700, "the winch output moved"
        # the operator drops the switch: offline within a tick, every driven channel released
        run.operator.hold_switch(7, 1100)
        run.run_until(lambda _now: not run.companion.bridge.online, 3.0)
        dropped_at = run.clock.now()
        run.run_for(0.2)
        overrides_left = run.sim.autopilot.rc_override
        assert overrides_left[0] is None and overrides_left[2] is None, \
            "released at once (0), not left to time out after RC_OVERRIDE_TIME"
        assert not [m for m in run.values("AP_CMD_RC_THROTTLE") if m.time > dropped_at]
        assert dropped_at - engaged_at > 29.0


def test_a_mav_gcs_sysid_mismatch_is_refused_with_a_clear_reason():
    with start(sysid=1) as run:
        run.operator.hold_switch(7, 1900)
        run.run_for(5.0)
        assert not run.companion.bridge.online
        assert statuses(run)[-1] == (
            "offline: MAV_GCS_SYSID is 255 but the companion speaks as system 1, so ArduPilot "
            "would ignore its RC override: set SystemID = 255 in iMAVLink")
        assert run.companion_link.received["RC_CHANNELS_OVERRIDE"] == 0


def test_a_silent_ground_station_takes_the_rc_override_helm_offline():
    """ArduPilot counts the companion's overrides as the ground station's sign of life, so the
    companion watches the operator's HEARTBEAT itself and lets go when it stops."""
    with start(sysid=255) as run:
        run.operator.hold_switch(7, 1900)
        run.run_until(lambda _now: run.companion.bridge.online, 5.0)
        run.run_for(2.0)
        run.gcs._next_heartbeat = float("inf")  # the operator's station falls silent
        silent_from = run.clock.now()
        run.run_until(lambda _now: not run.companion.bridge.online, 10.0)
        went = run.clock.now() - silent_from
        assert 4.0 < went < 6.5, f"offline {went:.1f} s after the last GCS heartbeat"
        assert statuses(run)[-1].startswith("offline: no ground station HEARTBEAT for 5 s")
        run.run_for(0.2)
        assert run.sim.autopilot.rc_override[2] is None, "the throttle was released"
