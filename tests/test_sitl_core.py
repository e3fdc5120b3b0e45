"""Conformance of the simulator's MAVLink side with ArduPilot Rover, through real sockets.

Each test drives a Simulator with a SimClock and talks to it with pymavlink, as a companion or
a ground station would. ``Rig`` (tests/support/sitl_rig.py; the ``rig`` fixture is in conftest.py)
delivers bytes exactly (byte counters + FIONREAD), so the tests are deterministic and need no
sleeps. The lockstep driver's own stall limit is tested at the end.
"""

from __future__ import annotations

import socket
import time

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.core.clock import SimClock
from mavhelm.sitl.lockstep import STALL_ENV, Lockstep, LockstepError, stall_limit
from tests.support.sitl_rig import FakeFault, FakeScenario, Rig, arm_guided, command

M = mavlink


# ---------------------------------------------------------------------------- stage 1


def test_heartbeat_identifies_a_boat_autopilot(rig):
    c = rig.connect()
    rig.run(2.0)
    hb = [m for m in c.of("HEARTBEAT")]
    assert len(hb) >= 2
    assert hb[-1].type == M.MAV_TYPE_SURFACE_BOAT
    assert hb[-1].autopilot == M.MAV_AUTOPILOT_ARDUPILOTMEGA
    assert hb[-1].custom_mode == 0 and hb[-1].base_mode == 0x41
    assert hb[0].custom_mode == 16  # INITIALISING at boot


def test_rover_heartbeat_type():
    r = Rig(model="mavhelm-rover")
    try:
        c = r.connect()
        r.run(1.0)
        assert c.last("HEARTBEAT").type == M.MAV_TYPE_GROUND_ROVER
    finally:
        r.close()


def test_byte_counters_are_exact(rig):
    c = rig.connect()
    rig.run(2.0)
    c.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 4)
    rig.step()
    assert c.link.bytes_sent == c.mav.total_bytes_received
    assert c.link.bytes_received == c.mav.total_bytes_sent


def test_do_set_mode_is_acked_and_set_mode_is_not(rig):
    c = rig.connect()
    rig.run(1.0)
    command(c, M.MAV_CMD_DO_SET_MODE, 1, 4)
    rig.step()
    assert [a.result for a in c.acks(M.MAV_CMD_DO_SET_MODE)] == [M.MAV_RESULT_ACCEPTED]
    assert rig.sim.mode == "HOLD"
    assert c.last("HEARTBEAT").custom_mode == 4 and c.last("HEARTBEAT").base_mode == 0x01
    c.mav.set_mode_send(1, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 0)
    rig.step(n=3)
    assert rig.sim.mode == "MANUAL"
    assert len(c.acks()) == 1


def test_auto_without_mission_and_unknown_mode_are_refused(rig):
    c = rig.connect()
    rig.run(1.0)
    command(c, M.MAV_CMD_DO_SET_MODE, 1, 10)
    command(c, M.MAV_CMD_DO_SET_MODE, 1, 2)
    rig.step()
    assert [a.result for a in c.acks()] == [M.MAV_RESULT_FAILED] * 2
    assert "No Mission. Can't set AUTO." in c.texts()
    assert "No such mode 2" in c.texts()
    assert rig.sim.mode == "MANUAL"


def test_start_up_timeline_real_pace():
    """The milestones measured on the real Rover 4.8-dev SITL (docs/sim-differences.md)."""
    r = Rig(fast_start=False, ports=(0,))
    try:
        c = r.connect()
        dt = 0.2
        r.run(1.2, dt)
        assert r.sim.mode == "INITIALISING"
        assert c.last("HEARTBEAT").system_status == M.MAV_STATE_CALIBRATING
        r.run(0.4, dt)
        assert r.sim.mode == "MANUAL"
        r.run(8.0, dt)  # 9.6 s
        assert c.last("GPS_RAW_INT").fix_type == M.GPS_FIX_TYPE_NO_GPS  # u-blox not detected
        assert c.last("HEARTBEAT").system_status == M.MAV_STATE_ACTIVE  # disarmed MANUAL
        r.run(0.4, dt)  # 10.0 s
        assert c.last("GPS_RAW_INT").fix_type == M.GPS_FIX_TYPE_RTK_FIXED  # SITL's u-blox: 6
        assert "GPS 1: detected u-blox" in c.texts()
        command(c, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        r.step(dt)
        assert c.acks()[-1].result == M.MAV_RESULT_FAILED
        assert c.texts()[-1] == "Arm: Accels inconsistent"
        r.run(4.0, dt)  # 14.2 s
        command(c, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        r.step(dt)
        assert c.acks()[-1].result == M.MAV_RESULT_FAILED
        assert c.texts()[-1] == "Arm: Gyros inconsistent"
        r.run(9.2, dt)  # 23.6 s
        command(c, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        r.step(dt)
        assert c.acks()[-1].result == M.MAV_RESULT_ACCEPTED and r.sim.armed
        command(c, M.MAV_CMD_DO_SET_MODE, 1, 15)
        r.step(dt)
        assert c.acks()[-1].result == M.MAV_RESULT_FAILED  # EKF not using GPS yet
        assert r.sim.mode == "MANUAL"
        r.run(2.0, dt)  # armed without a position: EKF failsafe, silent in MANUAL
        assert c.last("HEARTBEAT").system_status == M.MAV_STATE_CRITICAL
        r.run(17.8, dt)  # 43.8 s: using GPS at 41.9, failsafe cleared ~1 s later
        assert "EKF3 IMU0 is using GPS" in c.texts() and "EKF failsafe cleared" in c.texts()
        command(c, M.MAV_CMD_DO_SET_MODE, 1, 15)
        r.step(dt)
        assert c.acks()[-1].result == M.MAV_RESULT_ACCEPTED and r.sim.mode == "GUIDED"
    finally:
        r.close()


def test_guided_turn_rate_and_thrust_drive_the_boat_then_time_out(rig):
    c = rig.connect()
    arm_guided(rig, c)
    h0 = rig.sim.truth.heading
    for _ in range(60):  # 6 s at 10 Hz: 0.2 rad/s, half thrust
        c.mav.set_attitude_target_send(0, 1, 1, 0x03, [1, 0, 0, 0], 0, 0, 0.2, 0.5)
        rig.step(0.1)
    t = rig.sim.truth
    assert t.yaw_rate == pytest.approx(11.46, abs=2.0)
    assert t.surge == pytest.approx(2.5, abs=0.3)  # thrust 0.5 × WP_SPEED 5 m/s
    assert (t.heading - h0) % 360 > 40
    assert len(c.acks()) == 2  # arm + mode only: attitude targets are never ACKed
    rig.run(3.5, 0.1)
    assert "target not received last 3secs, stopping" in c.texts()


def test_guided_quaternion_heading(rig):
    c = rig.connect()
    arm_guided(rig, c)
    import math
    yaw = math.radians(90.0)
    q = [math.cos(yaw / 2), 0, 0, math.sin(yaw / 2)]
    for _ in range(150):
        c.mav.set_attitude_target_send(0, 1, 1, 0x07, q, 0, 0, 0, 0.5)
        rig.step(0.1)
    assert rig.sim.truth.heading == pytest.approx(90.0, abs=5.0)
    assert c.last("ATTITUDE").yaw == pytest.approx(yaw, abs=0.1)


def test_guided_inputs_ignored_outside_guided_and_without_thrust(rig):
    c = rig.connect()
    rig.run(3.0)
    command(c, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    rig.step()
    for _ in range(30):
        c.mav.set_attitude_target_send(0, 1, 1, 0x03, [1, 0, 0, 0], 0, 0, 0.3, 1.0)
        rig.step(0.1)
    assert abs(rig.sim.truth.surge) < 0.05  # MANUAL: ignored
    command(c, M.MAV_CMD_DO_SET_MODE, 1, 15)
    rig.step()
    for _ in range(30):
        c.mav.set_attitude_target_send(0, 1, 1, 0x03 | 0x40, [1, 0, 0, 0], 0, 0, 0.3, 1.0)
        rig.step(0.1)
    assert abs(rig.sim.truth.surge) < 0.05  # thrust ignored → message dropped
    assert not c.texts() or "target not received" not in " ".join(c.texts())


def test_set_message_interval_is_acked_and_exact(rig):
    c = rig.connect()
    rig.run(3.0)
    command(c, M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_GPS_RAW_INT, 200_000)
    command(c, M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE, 100_000)
    rig.step()
    assert [a.result for a in c.acks(M.MAV_CMD_SET_MESSAGE_INTERVAL)] == [0, 0]
    c.msgs.clear()
    rig.run(10.0, 0.05)
    assert len(c.of("GPS_RAW_INT")) == 50
    assert len(c.of("ATTITUDE")) == 100
    assert len(c.of("GLOBAL_POSITION_INT")) == 10


def test_each_link_has_its_own_rates(rig):
    a = rig.connect(0)
    b = rig.connect(1, sysid=254)
    rig.run(1.0)
    command(a, M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE, 100_000)
    rig.step()
    a.msgs.clear()
    b.msgs.clear()
    rig.run(5.0)
    assert len(a.of("ATTITUDE")) == 50
    assert len(b.of("ATTITUDE")) == 5


def test_rc_override_drives_manual_only_from_gcs_sysid(rig):
    comp = rig.connect(0, sysid=1, compid=191)  # companion with the vehicle's sysid: ignored
    gcs = rig.connect(1, sysid=255)
    rig.run(3.0)
    command(gcs, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    rig.step()
    for _ in range(20):
        comp.mav.rc_channels_override_send(1, 1, 1500, 0, 1900, 0, 0, 0, 0, 0)
        rig.step(0.1)
    assert abs(rig.sim.truth.surge) < 0.05
    for _ in range(40):
        gcs.mav.rc_channels_override_send(1, 1, 1500, 0, 1900, 0, 0, 0, 0, 0)
        rig.step(0.1)
    assert rig.sim.truth.surge > 2.5
    assert gcs.last("RC_CHANNELS").chan3_raw == 1900
    # the override holds RC_OVERRIDE_TIME (3 s), then the channel returns to the radio
    rig.run(2.5, 0.1)
    assert gcs.last("RC_CHANNELS").chan3_raw == 1900
    rig.run(1.6, 0.1)
    assert gcs.last("RC_CHANNELS").chan3_raw == 1500


def test_rc_override_zero_releases_and_65535_ignores(rig):
    gcs = rig.connect()
    rig.run(1.0)
    gcs.mav.rc_channels_override_send(1, 1, 1600, 0, 1700, 0, 0, 0, 0, 0)
    rig.step()
    assert rig.sim.autopilot.rc_in(rig.clock.now())[:3] == [1600, 1500, 1700]
    gcs.mav.rc_channels_override_send(1, 1, 65535, 65535, 0, 65535, 65535, 65535, 65535, 65535)
    rig.step()
    assert rig.sim.autopilot.rc_in(rig.clock.now())[:3] == [1600, 1500, 1500]


def test_guided_ignores_rc_override(rig):
    gcs = rig.connect()
    arm_guided(rig, gcs)
    for _ in range(30):
        gcs.mav.rc_channels_override_send(1, 1, 1900, 0, 1500, 0, 0, 0, 0, 0)
        rig.step(0.1)
    assert gcs.last("RC_CHANNELS").chan1_raw == 1900
    so = gcs.last("SERVO_OUTPUT_RAW")
    assert (so.servo1_raw, so.servo3_raw) == (1500, 1500)
    assert abs(rig.sim.truth.yaw_rate) < 1.0


def test_link_drop_fault_discards_traffic_on_one_link():
    sc = FakeScenario([FakeFault("link_drop", 2.0, 4.0, {"link": 0})])
    r = Rig(scenario=sc)
    try:
        a = r.connect(0)
        b = r.connect(1)
        r.run(2.0)
        sent_a, n_a, n_b = a.link.bytes_sent, len(a.msgs), len(b.msgs)
        r.run(1.9)
        assert a.link.bytes_sent == sent_a and len(a.msgs) == n_a
        assert len(b.msgs) > n_b
        command(a, M.MAV_CMD_DO_SET_MODE, 1, 4)  # lost
        r.step()
        assert r.sim.mode == "MANUAL"
        r.run(1.5)
        assert len(a.msgs) > n_a
    finally:
        r.close()


def test_gps_outage_fault_drops_the_fix_and_dead_reckons():
    sc = FakeScenario([FakeFault("gps_outage", 5.0, 18.0, {})])
    r = Rig(scenario=sc)
    try:
        c = r.connect()
        command(c, M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_GPS_RAW_INT, 200_000)
        r.run(4.9)
        assert c.last("GPS_RAW_INT").fix_type == 6
        r.run(1.0)
        g = c.last("GPS_RAW_INT")
        assert g.fix_type == M.GPS_FIX_TYPE_NO_FIX and g.satellites_visible == 0
        assert c.last("GLOBAL_POSITION_INT").lat != 0  # the EKF carries on dead reckoning
        r.run(11.0)  # > 10 s without GPS: position lost
        flags = c.last("EKF_STATUS_REPORT").flags
        assert flags & M.EKF_CONST_POS_MODE and not flags & M.EKF_POS_HORIZ_ABS
        r.run(2.0)
        assert c.last("GPS_RAW_INT").fix_type == 6
        assert c.last("EKF_STATUS_REPORT").flags & M.EKF_POS_HORIZ_ABS
    finally:
        r.close()


# ---------------------------------------------------------------------------- lockstep stall limit


class _SilentSim:
    """A simulator that never accepts a connection: every lockstep wait on it stalls."""

    links: list = []

    def service(self, now: float) -> None:
        pass


class _Endpoint:
    """A peer's end that is connected but that the simulator never accepts."""

    def __init__(self, sock: socket.socket) -> None:
        self.sock = sock

    def socket(self) -> socket.socket:
        return self.sock

    def connect(self, now: float) -> bool:
        return True

    def bytes_received(self) -> int:
        return 0

    def bytes_sent(self) -> int:
        return 0


def test_lockstep_stall_limit_defaults_to_5_s(monkeypatch):
    monkeypatch.delenv(STALL_ENV, raising=False)
    assert stall_limit() == 5.0
    assert Lockstep(_SilentSim(), SimClock(0.0), 0.1).wall_timeout == 5.0


def test_lockstep_stall_limit_is_taken_from_the_environment(monkeypatch):
    monkeypatch.setenv(STALL_ENV, "0.2")
    lockstep = Lockstep(_SilentSim(), SimClock(0.0), 0.1)
    assert lockstep.wall_timeout == 0.2
    assert Lockstep(_SilentSim(), SimClock(0.0), 0.1, wall_timeout=7.0).wall_timeout == 7.0
    a, b = socket.socketpair()
    try:
        t0 = time.monotonic()
        with pytest.raises(LockstepError, match="never accepted"):
            lockstep.add_peer(_Endpoint(a), lambda now: None)
        assert 0.2 <= time.monotonic() - t0 < 4.5, "gave up after 0.2 s, not the default 5 s"
    finally:
        a.close()
        b.close()


def test_rig_stall_limit_follows_the_environment(monkeypatch):
    monkeypatch.setenv(STALL_ENV, "12.5")
    r = Rig(ports=(0,))
    try:
        assert r.wall_timeout == 12.5
    finally:
        r.close()


@pytest.mark.parametrize("bad", ["soon", "", "nan", "inf", "-inf", "0", "-3"])
def test_lockstep_refuses_a_bad_stall_limit(monkeypatch, bad):
    monkeypatch.setenv(STALL_ENV, bad)
    with pytest.raises(ValueError, match=rf"^{STALL_ENV} must be a positive, finite number"):
        Lockstep(_SilentSim(), SimClock(0.0), 0.1)
    with pytest.raises(ValueError, match=repr(bad)):
        stall_limit()


def test_wait_for_client_holds_the_clock_and_the_other_ports_like_the_real_sitl():
    """Real SITL: its clock starts, and SERIAL1/2 open, only when a client connects to SERIAL0."""
    r = Rig(fast_start=False, ports=(0, 0), wait_for_client=True)
    try:
        r.sim.step(r.clock.advance(5.0))  # nobody connected: nothing moves
        assert not r.sim.started and len(r.sim.ports) == 1
        assert r.sim.mode == "INITIALISING"
        c = r.connect(0)
        assert r.sim.started and r.sim.boot == pytest.approx(5.0) and len(r.sim.ports) == 2
        r.connect(1)
        r.run(1.6)
        assert r.sim.mode == "MANUAL"
        assert c.texts()[:2] == ["Calibrating barometer", "Barometer 1 calibration complete"]
        assert c.of("ATTITUDE")[0].time_boot_ms < 100  # time counts from the connection
    finally:
        r.close()
