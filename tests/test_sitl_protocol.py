"""The rest of the simulator's ArduPilot conformance: parameters, servos, position targets,
streams, several links, the GCS failsafe and the MAVLink-side faults."""

from __future__ import annotations

import math
import socket

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.sitl.modes import GuidedSubMode
from tests.support.sitl_rig import FakeFault, FakeScenario, Rig, arm_guided, command

M = mavlink

# rig: fixture in conftest.py


# ---------------------------------------------------------------------------- parameters


def test_param_read_set_and_list(rig):
    c = rig.connect()
    rig.run(1.0)
    c.mav.param_request_read_send(1, 1, b"MAV_GCS_SYSID", -1)
    rig.step()
    pv = c.last("PARAM_VALUE")
    assert pv.param_id == "MAV_GCS_SYSID" and pv.param_value == 255
    c.mav.param_set_send(1, 1, b"WP_SPEED", 3.5, M.MAV_PARAM_TYPE_REAL32)
    rig.step()
    pv = c.last("PARAM_VALUE")
    assert pv.param_id == "WP_SPEED" and pv.param_value == pytest.approx(3.5)
    assert rig.sim.params["WP_SPEED"] == pytest.approx(3.5)
    c.msgs.clear()
    c.mav.param_request_list_send(1, 1)
    rig.step()
    names = {p.param_id for p in c.of("PARAM_VALUE")}
    for name in ("MAV_GCS_SYSID", "MAV_SYSID", "RC_OVERRIDE_TIME", "WP_SPEED",
                 "FS_GCS_ENABLE", "FS_ACTION", "FS_TIMEOUT", "RCMAP_ROLL", "RCMAP_THROTTLE",
                 "CRUISE_SPEED", "FRAME_CLASS", *(f"SERVO{i}_FUNCTION" for i in range(1, 9))):
        assert name in names
    count = c.of("PARAM_VALUE")[0].param_count
    assert len(c.of("PARAM_VALUE")) == count


def test_servo_functions_per_frame():
    for vehicle, model, fns in (("boat", "mavhelm-boat", (73, 74)),
                                ("boat", "mavhelm-boat-rudder", (26, 70)),
                                ("rover", "mavhelm-rover", (26, 70)),
                                ("rover", "mavhelm-rover-skid", (73, 74))):
        r = Rig(model=model, ports=(0,))
        try:
            assert (r.sim.params["SERVO1_FUNCTION"], r.sim.params["SERVO3_FUNCTION"]) == fns
            assert r.sim.params["FRAME_CLASS"] == (2 if vehicle == "boat" else 1)
        finally:
            r.close()


def test_gcs_sysid_param_moves_rc_override_authority(rig):
    comp = rig.connect(0, sysid=1, compid=191)
    rig.run(3.0)
    comp.mav.param_set_send(1, 1, b"MAV_GCS_SYSID", 1, M.MAV_PARAM_TYPE_INT16)
    command(comp, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    rig.step()
    for _ in range(30):
        comp.mav.rc_channels_override_send(1, 1, 1500, 0, 1800, 0, 0, 0, 0, 0)
        rig.step(0.1)
    assert rig.sim.truth.surge > 1.0


# ---------------------------------------------------------------------------- servos


def test_do_set_servo_on_motor_output_fails_and_free_output_accepted(rig):
    c = rig.connect()
    rig.run(1.0)
    command(c, M.MAV_CMD_DO_SET_SERVO, 1, 1700)
    command(c, M.MAV_CMD_DO_SET_SERVO, 5, 1234)
    rig.step()
    assert [a.result for a in c.acks(M.MAV_CMD_DO_SET_SERVO)] == [M.MAV_RESULT_FAILED,
                                                                  M.MAV_RESULT_ACCEPTED]
    assert "ServoRelayEvent: Channel 1 is already in use" in c.texts()
    rig.run(1.0)
    so = c.last("SERVO_OUTPUT_RAW")
    assert so.servo5_raw == 1234 and so.servo1_raw == 1500


# ---------------------------------------------------------------------------- GUIDED targets


def test_position_target_reached_boat_loiters(rig):
    c = rig.connect()
    arm_guided(rig, c)
    lat, lon = rig.sim.home.to_global(0.0, 30.0)
    c.mav.set_position_target_global_int_send(0, 1, 1, M.MAV_FRAME_GLOBAL_INT, 0xFF8,
                                              int(lat * 1e7), int(lon * 1e7), 0, 0, 0, 0,
                                              0, 0, 0, 0, 0)
    assert rig.until(lambda: c.of("MISSION_ITEM_REACHED"), 60.0, 0.1)
    assert not c.acks(M.MAV_CMD_DO_SET_SERVO)
    assert math.hypot(rig.sim.truth.x, rig.sim.truth.y - 30.0) < 4.0
    assert rig.sim.autopilot.guided.sub == GuidedSubMode.LOITER
    rig.run(20.0, 0.1)  # no target timeout for a position target, and it stays close
    assert not any("target not received" in t for t in c.texts())
    assert math.hypot(rig.sim.truth.x, rig.sim.truth.y - 30.0) < 5.0


def test_position_target_local_ned_rover_stops():
    r = Rig(model="mavhelm-rover")
    try:
        c = r.connect()
        arm_guided(r, c)
        c.mav.set_position_target_local_ned_send(0, 1, 1, M.MAV_FRAME_LOCAL_NED, 0xFF8,
                                                 20.0, 10.0, 0, 0, 0, 0, 0, 0, 0, 0, 0)
        assert r.until(lambda: c.of("MISSION_ITEM_REACHED"), 60.0, 0.1)
        r.run(5.0, 0.1)
        assert abs(r.sim.truth.surge) < 0.1
        assert math.hypot(r.sim.truth.x - 10.0, r.sim.truth.y - 20.0) < 4.0
        assert r.sim.autopilot.guided.sub == GuidedSubMode.STOP
    finally:
        r.close()


def test_velocity_target_then_timeout_and_acceleration_rejected(rig):
    c = rig.connect()
    arm_guided(rig, c)
    for _ in range(80):  # 1.5 m/s due east
        c.mav.set_position_target_local_ned_send(0, 1, 1, M.MAV_FRAME_LOCAL_NED, 0xDC7,
                                                 0, 0, 0, 0.0, 1.5, 0, 0, 0, 0, 0, 0)
        rig.step(0.1)
    t = rig.sim.truth
    assert t.heading == pytest.approx(90.0, abs=6.0)
    assert t.vx == pytest.approx(1.5, abs=0.3)
    rig.run(3.5, 0.1)
    assert any("target not received last 3secs" in x for x in c.texts())
    n = len(c.texts())
    c.mav.set_position_target_local_ned_send(0, 1, 1, M.MAV_FRAME_LOCAL_NED, 0x007,
                                             0, 0, 0, 1.0, 0, 0, 0.5, 0, 0, 0, 0)
    rig.step()
    # Rover's text, in two 50-byte MAVLink 2 chunks
    assert c.texts()[n:] == ["Ignoring SET_POSITION_TARGET_LOCAL_NED; set ACC_IG", "NORE in mask"]
    chunks = c.of("STATUSTEXT")[-2:]
    assert chunks[0].id == chunks[1].id != 0 and [m.chunk_seq for m in chunks] == [0, 1]


def test_armed_guided_refused_until_ekf_has_position():
    r = Rig(fast_start=False, ports=(0,))
    try:
        c = r.connect()
        r.run(24.0, 0.2)
        command(c, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        command(c, M.MAV_CMD_DO_SET_MODE, 1, 15)
        r.step(0.2)
        assert [a.result for a in c.acks()] == [0, M.MAV_RESULT_FAILED]
        assert "Flight mode change failed" in c.texts()
    finally:
        r.close()


def test_arming_in_guided_needs_a_position():
    r = Rig(fast_start=False, ports=(0,))
    try:
        c = r.connect()
        r.run(24.0, 0.2)
        command(c, M.MAV_CMD_DO_SET_MODE, 1, 15)
        command(c, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        command(c, M.MAV_CMD_DO_SET_MODE, 0, 4)
        r.step(0.2)
        assert [a.result for a in c.acks()] == [0, M.MAV_RESULT_FAILED, M.MAV_RESULT_DENIED]
        assert "Arm: Need Position Estimate" in c.texts() and not r.sim.armed
    finally:
        r.close()


def test_disarmed_switch_to_guided_is_allowed_any_time():
    r = Rig(fast_start=False, ports=(0,))
    try:
        c = r.connect()
        r.run(2.0, 0.2)
        command(c, M.MAV_CMD_DO_SET_MODE, 1, 15)
        r.step(0.2)
        assert c.acks()[-1].result == 0 and r.sim.mode == "GUIDED"
    finally:
        r.close()


# ---------------------------------------------------------------------------- streams


def test_request_data_stream_all_sets_every_rate(rig):
    c = rig.connect()
    rig.run(1.0)
    c.mav.request_data_stream_send(1, 1, M.MAV_DATA_STREAM_ALL, 4, 1)
    rig.step()
    c.msgs.clear()
    rig.run(5.0)
    for kind in ("ATTITUDE", "GPS_RAW_INT", "GLOBAL_POSITION_INT", "VFR_HUD", "SYS_STATUS"):
        assert len(c.of(kind)) == pytest.approx(20, abs=1), kind
    assert len(c.of("HEARTBEAT")) == 5  # the heartbeat is not a stream
    c.mav.request_data_stream_send(1, 1, M.MAV_DATA_STREAM_ALL, 0, 0)
    rig.step()
    c.msgs.clear()
    rig.run(3.0)
    assert not c.of("ATTITUDE") and len(c.of("HEARTBEAT")) == 3


def test_request_message_simstate_is_ground_truth(rig):
    c = rig.connect()
    rig.run(3.0)
    command(c, M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_SIMSTATE)
    command(c, M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    rig.step()
    assert [a.result for a in c.acks(M.MAV_CMD_REQUEST_MESSAGE)] == [0, 0]
    s = c.last("SIMSTATE")
    lat, lon = rig.sim.home.to_global(rig.sim.truth.x, rig.sim.truth.y)
    assert s.lat == pytest.approx(lat * 1e7, abs=2) and s.lng == pytest.approx(lon * 1e7, abs=2)
    assert c.last("AUTOPILOT_VERSION") is not None
    command(c, M.MAV_CMD_GET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE)
    rig.step()
    assert c.last("MESSAGE_INTERVAL").interval_us == 1_000_000
    command(c, M.MAV_CMD_REQUEST_MESSAGE, 12345)
    command(c, M.MAV_CMD_SET_MESSAGE_INTERVAL, 12345, 100_000)
    rig.step()
    assert [a.result for a in c.acks()[-2:]] == [M.MAV_RESULT_FAILED] * 2
    assert "No ap_message for mavlink id (12345)" in c.texts()
    command(c, M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_ATTITUDE, -1)
    rig.step()
    c.msgs.clear()
    rig.run(2.0)
    assert not c.of("ATTITUDE") and c.of("GLOBAL_POSITION_INT")


def test_boat_reports_depth_rover_reports_wheels():
    r = Rig(params={"SIM_DEPTH": 7.5}, ports=(0,))
    try:
        c = r.connect()
        r.run(2.0)
        d = c.last("DISTANCE_SENSOR")
        assert d.current_distance == 750 and d.orientation == M.MAV_SENSOR_ROTATION_PITCH_270
        assert not c.of("WHEEL_DISTANCE")
    finally:
        r.close()
    r = Rig(model="mavhelm-rover", ports=(0,))
    try:
        c = r.connect()
        r.run(2.0)
        assert c.last("WHEEL_DISTANCE").count == 2 and not c.of("DISTANCE_SENSOR")
    finally:
        r.close()


# ---------------------------------------------------------------------------- links


def test_clients_see_each_others_heartbeats_and_commands_from_any_link_obeyed(rig):
    a = rig.connect(0, sysid=1, compid=191)
    b = rig.connect(2, sysid=255, compid=190)
    rig.run(1.0)
    a.mav.heartbeat_send(M.MAV_TYPE_ONBOARD_CONTROLLER, M.MAV_AUTOPILOT_INVALID, 0, 0, 4)
    b.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 4)
    rig.step()
    rig.step()
    assert any(m.get_srcComponent() == 190 for m in a.of("HEARTBEAT"))
    assert any(m.get_srcComponent() == 191 for m in b.of("HEARTBEAT"))
    command(b, M.MAV_CMD_DO_SET_MODE, 1, 4)
    rig.step()
    assert rig.sim.mode == "HOLD"
    assert b.acks() and not a.acks()  # the ACK goes to the asker only
    assert a.last("HEARTBEAT").custom_mode == 4


def test_udp_out_link():
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(1.0)
    r = Rig(ports=(), udp_out=[("127.0.0.1", rx.getsockname()[1])])
    try:
        r.sim.step(r.clock.advance(0.05))
        data = rx.recv(65536)
        assert data[0] == 0xFD  # MAVLink 2
        link = r.sim.links[0]
        assert link.peer == ("127.0.0.1", rx.getsockname()[1])
        assert link.bytes_sent >= len(data)
        # the ground station answers from its port: commands over UDP are obeyed and ACKed
        gcs = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
        msg = gcs.command_long_encode(1, 1, M.MAV_CMD_DO_SET_MODE, 0, 1, 4, 0, 0, 0, 0, 0)
        rx.sendto(msg.pack(gcs), link.sock.getsockname())
        for _ in range(20):
            r.sim.step(r.clock.advance(0.05))
            if r.sim.mode == "HOLD":
                break
        assert r.sim.mode == "HOLD"
        parser = mavlink.MAVLink(None)
        parser.robust_parsing = True
        acks = []
        while len(acks) == 0:
            for m in parser.parse_buffer(rx.recv(65536)) or []:
                if m.get_type() == "COMMAND_ACK":
                    acks.append(m)
        assert acks[0].result == 0
    finally:
        r.close()
        rx.close()


def test_gcs_failsafe_holds_when_enabled():
    r = Rig(params={"FS_GCS_ENABLE": 1})
    try:
        g = r.connect(1, sysid=255)
        r.run(3.0)
        command(g, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        command(g, M.MAV_CMD_DO_SET_MODE, 1, 15)
        for _ in range(4):
            g.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 4)
            r.run(1.0)
        assert r.sim.mode == "GUIDED"
        r.run(5.0)  # FS_GCS_TIMEOUT 5 s …
        assert r.sim.mode == "GUIDED"
        r.run(2.0)  # … then FS_TIMEOUT 1.5 s → FS_ACTION 2 (Hold)
        # named after the radio check, which runs first (FS_THR_ENABLE 1), as on Rover 4.8
        assert r.sim.mode == "HOLD" and "Radio Failsafe" in g.texts()
        for _ in range(3):
            g.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 4)
            r.run(0.5)
        assert "GCS Failsafe Cleared" in g.texts()
    finally:
        r.close()


def test_gcs_failsafe_named_gcs_without_the_radio_check():
    r = Rig(params={"FS_GCS_ENABLE": 1, "FS_THR_ENABLE": 0})
    try:
        g = r.connect(1, sysid=255)
        r.run(3.0)
        command(g, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        command(g, M.MAV_CMD_DO_SET_MODE, 1, 15)
        g.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 4)
        r.run(8.0)
        assert r.sim.mode == "HOLD" and "GCS Failsafe" in g.texts()
    finally:
        r.close()


def test_gcs_failsafe_off_by_default(rig):
    g = rig.connect(1)
    rig.run(3.0)
    g.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0, 4)
    command(g, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    rig.run(20.0, 0.2)
    assert rig.sim.mode == "MANUAL" and rig.sim.armed


# ---------------------------------------------------------------------------- faults


def _gps_positions(c, rig):
    out = []
    for g in c.of("GPS_RAW_INT"):
        if g.fix_type >= 3:
            out.append(rig.sim.home.to_local(g.lat / 1e7, g.lon / 1e7))
    return out


def test_gps_jump_offsets_reported_position():
    sc = FakeScenario([FakeFault("gps_jump", 5.0, 8.0, {"dx": 25.0, "dy": -10.0})])
    r = Rig(scenario=sc, ports=(0,))
    try:
        c = r.connect()
        r.run(4.5)
        x0, y0 = _gps_positions(c, r)[-1]
        r.run(2.0)
        x1, y1 = _gps_positions(c, r)[-1]
        assert x1 - x0 == pytest.approx(25.0, abs=1.5) and y1 - y0 == pytest.approx(-10, abs=1.5)
        assert c.last("EKF_STATUS_REPORT").flags & M.EKF_GPS_GLITCHING
    finally:
        r.close()


def test_gps_outlier_and_compass_bias():
    sc = FakeScenario([FakeFault("gps_outlier", 3.0, 60.0, {"prob": 0.5, "sigma": 30.0}),
                       FakeFault("compass_bias", 3.0, 60.0, {"deg": 20.0})])
    r = Rig(scenario=sc, ports=(0,))
    try:
        c = r.connect()
        command(c, M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_GPS_RAW_INT, 200_000)
        r.run(20.0)
        pos = _gps_positions(c, r)[20:]
        far = [p for p in pos if math.hypot(*p) > 5.0]
        assert 0.2 < len(far) / len(pos) < 0.8
        att = c.last("ATTITUDE")
        assert math.degrees(att.yaw) == pytest.approx(20.0, abs=0.5)
        assert r.sim.truth.heading == pytest.approx(0.0, abs=0.5)
    finally:
        r.close()


def test_gps_sensor_latency_delays_fixes():
    sc = FakeScenario([FakeFault("sensor_latency", 0.0, 100.0, {"sensor": "gps", "delay": 1.0})])
    r = Rig(scenario=sc, ports=(0,))
    try:
        c = r.connect()
        arm_guided(r, c)
        command(c, M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_GPS_RAW_INT, 100_000)
        for _ in range(100):
            c.mav.set_attitude_target_send(0, 1, 1, 0x07, [1, 0, 0, 0], 0, 0, 0, 1.0)
            r.step(0.1)
        _, y = _gps_positions(c, r)[-1]
        lag = r.sim.truth.y - y
        speed = r.sim.truth.surge
        assert speed > 2.0
        assert lag == pytest.approx(speed * 1.0, abs=0.8)  # speed × 1 s
    finally:
        r.close()


def test_link_stall_holds_then_releases():
    sc = FakeScenario([FakeFault("link_stall", 2.0, 4.0, {"link": 0})])
    r = Rig(scenario=sc, ports=(0,))
    try:
        c = r.connect()
        r.run(2.0)
        n = len(c.msgs)
        r.run(1.9)
        assert len(c.msgs) == n
        r.run(0.3)
        assert len(c.of("HEARTBEAT")) >= 4  # the held heartbeats arrive after the stall
    finally:
        r.close()


@pytest.mark.parametrize("kind", ["link_garbage", "link_duplicate", "link_reorder"])
def test_link_corruption_faults_keep_stream_parsable(kind):
    sc = FakeScenario([FakeFault(kind, 0.0, 100.0, {"prob": 0.3})])
    r = Rig(scenario=sc, ports=(0,))
    try:
        c = r.connect()
        r.run(5.0)
        assert c.link.bytes_sent == c.mav.total_bytes_received
        hb = c.of("HEARTBEAT")
        assert len(hb) >= 4
        seqs = [m.get_seq() for m in c.msgs]
        if kind == "link_duplicate":
            assert len(seqs) > len(set(seqs))
        if kind == "link_reorder":
            assert any((b - a) % 256 == 255 for a, b in zip(seqs, seqs[1:], strict=False))
        if kind == "link_garbage":
            assert c.mav.total_receive_errors > 0 or c.link.bytes_sent > sum(
                len(m.get_msgbuf()) for m in c.msgs)
    finally:
        r.close()


# ---------------------------------------------------------------------------- modes that navigate


def test_current_drifts_a_holding_boat_but_loiter_holds_station():
    r = Rig(params={"SIM_CURRENT_SPD": 0.3, "SIM_CURRENT_DIR": 90.0}, ports=(0,))
    try:
        c = r.connect()
        r.run(3.0)
        command(c, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        command(c, M.MAV_CMD_DO_SET_MODE, 1, 4)  # HOLD: motors off, the current carries it
        r.run(20.0, 0.1)
        x0 = r.sim.truth.x
        assert x0 > 5.0
        command(c, M.MAV_CMD_DO_SET_MODE, 1, 5)  # LOITER where it is now
        r.run(60.0, 0.1)
        assert math.hypot(r.sim.truth.x - x0, r.sim.truth.y) < 4.0
    finally:
        r.close()


def test_rtl_brings_the_rover_home():
    r = Rig(model="mavhelm-rover", ports=(0,))
    try:
        c = r.connect()
        arm_guided(r, c)
        c.mav.set_position_target_local_ned_send(0, 1, 1, M.MAV_FRAME_LOCAL_NED, 0xFF8,
                                                 30.0, 0.0, 0, 0, 0, 0, 0, 0, 0, 0, 0)
        assert r.until(lambda: c.of("MISSION_ITEM_REACHED"), 60.0, 0.1)
        command(c, M.MAV_CMD_NAV_RETURN_TO_LAUNCH)
        r.step()
        assert c.acks()[-1].result == 0 and r.sim.mode == "RTL"
        assert r.until(lambda: "Reached destination" in c.texts(), 60.0, 0.1)
        r.run(3.0, 0.1)
        assert math.hypot(r.sim.truth.x, r.sim.truth.y) < 4.0 and abs(r.sim.truth.surge) < 0.1
    finally:
        r.close()


def test_long_gps_outage_in_guided_trips_the_ekf_failsafe():
    sc = FakeScenario([FakeFault("gps_outage", 10.0, 40.0, {})])
    r = Rig(scenario=sc, ports=(0,))
    try:
        c = r.connect()
        arm_guided(r, c)
        r.run(16.0, 0.1)  # 6 s into the outage: still dead reckoning
        assert r.sim.mode == "GUIDED"
        r.run(6.0, 0.1)  # 10 s of dead reckoning + ~1 s of ekf_check
        assert r.sim.mode == "HOLD" and "EKF failsafe" in c.texts()
        command(c, M.MAV_CMD_DO_SET_MODE, 1, 15)
        r.step()
        assert c.acks()[-1].result == M.MAV_RESULT_FAILED
        r.run(20.0, 0.1)
        assert "EKF failsafe cleared" in c.texts()
        command(c, M.MAV_CMD_DO_SET_MODE, 1, 15)
        r.step()
        assert c.acks()[-1].result == M.MAV_RESULT_ACCEPTED
    finally:
        r.close()


def test_a_real_scenario_file_with_every_mavlink_fault_kind():
    from mavhelm.sitl.faults import Scenario

    sc = Scenario.from_text("""seed = 5
gps_outage from 5 to 8
gps_jump at 10 dx=20 dy=5
gps_outlier from 12 to 20 prob=0.2 sigma=10
compass_bias from 3 to 30 deg=5
sensor_latency from 0 sensor=gps delay=0.3 jitter=0.1
link_stall from 2 to 3 link=1
link_garbage from 4 to 6 prob=0.1
link_duplicate from 6 to 8 prob=0.1
link_reorder from 8 to 10 prob=0.2 link=0
link_drop from 11 to 12
""")
    r = Rig(scenario=sc)
    try:
        a, b = r.connect(0), r.connect(1)
        r.run(25.0)
        for c in (a, b):
            assert c.link.bytes_sent == c.mav.total_bytes_received
            assert len(c.of("HEARTBEAT")) >= 22
    finally:
        r.close()


def test_manual_control_drives_manual_like_an_override_and_timesync_answers(rig):
    g = rig.connect()
    rig.run(3.0)
    command(g, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    rig.step()
    for _ in range(30):
        g.mav.manual_control_send(1, 0, 0, 1000, 0, 0)  # x, y (steer), z (throttle), r
        rig.step(0.1)
    assert g.last("RC_CHANNELS").chan3_raw == 1900
    assert rig.sim.truth.surge > 2.0
    g.mav.timesync_send(0, 123456789)
    rig.step()
    ts = g.last("TIMESYNC")
    assert ts.ts1 == 123456789 and ts.tc1 > 0


# ---------------------------------------------------------------------------- what real clients ask
# Gaps found by running MAVSDK and MAVProxy against the simulator.

GEOFENCE = M.MAV_SYS_STATUS_GEOFENCE


def test_sys_status_geofence_bits_follow_ac_fence(rig):
    """AC_Fence: present = a circle/altitude fence configured in FENCE_TYPE (Rover default 6),
    enabled = present + FENCE_ENABLE + an action, healthy unless breached — so a stock Rover
    reports the fence healthy and MAVProxy does not say "fence breach"."""
    c = rig.connect()
    rig.run(1.0)
    s = c.last("SYS_STATUS")
    assert s.onboard_control_sensors_present & GEOFENCE
    assert not s.onboard_control_sensors_enabled & GEOFENCE
    assert s.onboard_control_sensors_health & GEOFENCE
    for name, value in (("FENCE_ENABLE", 1), ("FENCE_ACTION", 1)):
        c.mav.param_set_send(1, 1, name.encode(), value, M.MAV_PARAM_TYPE_INT8)
    rig.run(1.0)
    s = c.last("SYS_STATUS")
    assert s.onboard_control_sensors_enabled & GEOFENCE
    assert s.onboard_control_sensors_health & GEOFENCE
    c.mav.param_set_send(1, 1, b"FENCE_ACTION", 0, M.MAV_PARAM_TYPE_INT8)  # report only
    rig.run(1.0)
    assert not c.last("SYS_STATUS").onboard_control_sensors_enabled & GEOFENCE
    c.mav.param_set_send(1, 1, b"FENCE_TYPE", 4, M.MAV_PARAM_TYPE_INT8)  # polygon, none loaded
    rig.run(1.0)
    s = c.last("SYS_STATUS")
    assert not s.onboard_control_sensors_present & GEOFENCE
    assert s.onboard_control_sensors_health & GEOFENCE


def test_get_home_position_fails_until_home_is_set_then_sends_home_and_origin(rig):
    c = rig.connect()
    rig.run(0.5)  # fast start: home and the EKF origin come at 1.0 s
    command(c, M.MAV_CMD_GET_HOME_POSITION)
    rig.step()
    assert [a.result for a in c.acks(M.MAV_CMD_GET_HOME_POSITION)] == [M.MAV_RESULT_FAILED]
    assert c.last("HOME_POSITION") is None
    rig.run(1.5)
    c.msgs.clear()
    command(c, M.MAV_CMD_GET_HOME_POSITION)
    rig.step()
    assert [a.result for a in c.acks(M.MAV_CMD_GET_HOME_POSITION)] == [M.MAV_RESULT_ACCEPTED]
    kinds = [m.get_type() for m in c.msgs]
    assert kinds.index("COMMAND_ACK") < kinds.index("HOME_POSITION")
    assert kinds.count("HOME_POSITION") == 1 and kinds.count("GPS_GLOBAL_ORIGIN") == 1
    home = c.last("HOME_POSITION")
    lat, lon = rig.sim.home.to_global(*rig.sim.autopilot.home)
    assert home.latitude == pytest.approx(lat * 1e7, abs=2)
    assert home.longitude == pytest.approx(lon * 1e7, abs=2)
    assert abs(home.latitude - rig.sim.home.lat * 1e7) < 200  # within ~2 m of the start
    # the same message through REQUEST_MESSAGE and as a stream
    c.msgs.clear()
    command(c, M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_HOME_POSITION)
    rig.step()
    assert c.acks()[-1].result == M.MAV_RESULT_ACCEPTED and len(c.of("HOME_POSITION")) == 1
    command(c, M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_HOME_POSITION, 500_000)
    rig.step()
    assert c.acks()[-1].result == M.MAV_RESULT_ACCEPTED
    c.msgs.clear()
    rig.run(3.0)
    assert len(c.of("HOME_POSITION")) == 6


def test_extended_sys_state_on_request_and_as_a_stream(rig):
    """MAVSDK asks for EXTENDED_SYS_STATE (245); Rover knows it (vtol/landed state UNDEFINED)
    but streams it only when asked."""
    c = rig.connect()
    rig.run(1.0)
    assert not c.of("EXTENDED_SYS_STATE")
    command(c, M.MAV_CMD_REQUEST_MESSAGE, M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE)
    rig.step()
    assert c.acks()[-1].result == M.MAV_RESULT_ACCEPTED
    e = c.last("EXTENDED_SYS_STATE")
    assert (e.vtol_state, e.landed_state) == (M.MAV_VTOL_STATE_UNDEFINED,
                                              M.MAV_LANDED_STATE_UNDEFINED)
    command(c, M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, 200_000)
    rig.step()
    assert c.acks()[-1].result == M.MAV_RESULT_ACCEPTED
    assert not any("No ap_message" in t for t in c.texts())
    c.msgs.clear()
    rig.run(2.0)
    assert len(c.of("EXTENDED_SYS_STATE")) == 10


def _ftp_request(c, seq: int, opcode: int, name: bytes = b"", target: int = 1) -> None:
    from pymavlink.mavftp_op import FTP_OP

    op = FTP_OP(seq, 3, opcode, len(name), 0, 0, 0, bytearray(name) if name else None)
    payload = op.pack()
    c.mav.file_transfer_protocol_send(0, target, 1, list(payload.ljust(251, b"\0")))


def _ftp_replies(c) -> list[tuple]:
    """(target sys, target comp, seq, session, opcode, size, req_opcode, data) per reply."""
    out = []
    for m in c.of("FILE_TRANSFER_PROTOCOL"):
        p = bytes(m.payload)
        seq = p[0] | p[1] << 8
        out.append((m.target_system, m.target_component, seq, p[2], p[3], p[4], p[5],
                    tuple(p[12:12 + p[4]])))
    return out


def test_mavftp_requests_are_answered_at_once_with_nak(rig):
    """No file system: a MAVFTP client (MAVProxy fetching @PARAM/param.pck) gets a NAK at once
    instead of timing out, in ArduPilot's reply layout (seq + 1, same session, req_opcode)."""
    c = rig.connect()
    rig.run(0.5)
    _ftp_request(c, 7, 4, b"@PARAM/param.pck?withdefaults=1")  # OpenFileRO
    _ftp_request(c, 8, 2)  # ResetSessions
    _ftp_request(c, 9, 15)  # BurstReadFile, nothing open
    _ftp_request(c, 10, 99)  # no such opcode
    _ftp_request(c, 11, 4, b"@PARAM/param.pck", target=42)  # for another system
    rig.step()
    assert _ftp_replies(c) == [
        (255, 190, 8, 3, 129, 2, 4, (2, 2)),  # NAK FailErrno, ENOENT
        (255, 190, 9, 3, 128, 0, 2, ()),  # ACK
        (255, 190, 10, 3, 129, 1, 15, (10,)),  # NAK FileNotFound
        (255, 190, 11, 3, 129, 1, 99, (7,)),  # NAK UnknownCommand
    ]


@pytest.mark.slow
def test_mavproxy_falls_back_from_mavftp_to_param_list_at_once(tmp_path):
    """MAVProxy first tries MAVFTP for the parameters; with the NAK it falls back to
    PARAM_REQUEST_LIST at once (measured: ~2 s; it took ~12 s to time out before). Without
    the NAK, "FTP: request timed out" is printed ~10 s in, well inside the 15 s wait."""
    from tests.support.interop_helpers import MavproxyProcess, SimProcess

    with SimProcess("--fast-start") as sim, \
            MavproxyProcess(f"tcp:127.0.0.1:{sim.ports[1]}", tmp_path) as mavproxy:
        mavproxy.wait_for(r"Detected vehicle", 15)
        mavproxy.wait_for(r"Received \d+ parameters", 15)
        text = mavproxy.output.text()
        assert "FTP: request timed out" not in text
        assert "fence breach" not in text
