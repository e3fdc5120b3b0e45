"""Conformance of the simulator's MAVLink side with ArduPilot Rover, through real sockets.

Each test drives a Simulator with a SimClock and talks to it with pymavlink, as a companion or
a ground station would. ``Rig`` delivers bytes exactly (byte counters + FIONREAD), so the tests
are deterministic and need no sleeps.
"""

from __future__ import annotations

import select
import time
from dataclasses import dataclass, field

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.core.clock import SimClock
from mavhelm.sitl.lockstep import pending_bytes
from mavhelm.sitl.simulator import Simulator

M = mavlink


@dataclass
class Client:
    conn: mavutil.mavfile
    link: object
    msgs: list = field(default_factory=list)

    @property
    def mav(self):
        return self.conn.mav

    def of(self, kind: str) -> list:
        return [m for m in self.msgs if m.get_type() == kind]

    def texts(self) -> list[str]:
        return [m.text for m in self.of("STATUSTEXT")]

    def acks(self, command: int | None = None) -> list:
        return [m for m in self.of("COMMAND_ACK") if command is None or m.command == command]

    def last(self, kind: str):
        got = self.of(kind)
        return got[-1] if got else None


class Rig:
    """A simulator, a simulated clock and pymavlink clients, delivered in lockstep."""

    def __init__(self, **kw) -> None:
        kw.setdefault("ports", (0, 0, 0))
        kw.setdefault("fast_start", True)
        self.clock = SimClock(0.0)
        self.sim = Simulator(self.clock, **kw)
        self.clients: list[Client] = []

    def connect(self, port_index: int = 0, sysid: int = 255, compid: int = 190) -> Client:
        conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{self.sim.ports[port_index]}",
                                          source_system=sysid, source_component=compid,
                                          dialect="ardupilotmega")
        local = conn.port.getsockname()
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline:
            self.sim.service(self.clock.now())
            for link in self.sim.links:
                if tuple(link.peer[:2]) == tuple(local[:2]):
                    c = Client(conn, link)
                    self.clients.append(c)
                    return c
            select.select([], [], [], 0.001)
        raise AssertionError("simulator did not accept")

    def _wait(self, done, sock) -> None:
        deadline = time.monotonic() + 5
        while not done():
            assert time.monotonic() < deadline, "lockstep stalled"
            select.select([sock], [], [], 0.001)

    def deliver(self) -> None:
        """Make sure the simulator's socket holds everything the clients sent."""
        for c in self.clients:
            if c.link.closed:
                continue
            self._wait(lambda c=c: c.link.bytes_received + pending_bytes(c.link.sock)
                       >= c.mav.total_bytes_sent, c.link.sock)

    def step(self, dt: float = 0.05, n: int = 1) -> None:
        for _ in range(n):
            self.deliver()
            self.sim.step(self.clock.advance(dt))
            for c in self.clients:
                self._wait(lambda c=c: c.mav.total_bytes_received + pending_bytes(c.conn.port)
                           >= c.link.bytes_sent, c.conn.port)
                while (m := c.conn.recv_msg()) is not None:
                    if m.get_type() != "BAD_DATA":
                        c.msgs.append(m)

    def run(self, seconds: float, dt: float = 0.05) -> None:
        self.step(dt, int(round(seconds / dt)))

    def until(self, pred, max_time: float, dt: float = 0.05) -> bool:
        end = self.clock.now() + max_time
        while self.clock.now() < end:
            self.step(dt)
            if pred():
                return True
        return False

    def close(self) -> None:
        for c in self.clients:
            c.conn.close()
        self.sim.close()


@pytest.fixture
def rig():
    r = Rig()
    yield r
    r.close()


def command(c: Client, cmd: int, *params: float) -> None:
    p = list(params) + [0.0] * (7 - len(params))
    c.mav.command_long_send(1, 1, cmd, 0, *p)


def arm_guided(r: Rig, c: Client) -> None:
    r.run(3.0)
    command(c, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    r.step()
    command(c, M.MAV_CMD_DO_SET_MODE, 1, 15)
    r.step()
    assert r.sim.armed and r.sim.mode == "GUIDED"


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
    r = Rig(vehicle="rover")
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
    r = Rig(fast_start=False, ports=(0,))
    try:
        c = r.connect()
        dt = 0.2
        r.run(1.2, dt)
        assert r.sim.mode == "INITIALISING"
        r.run(0.4, dt)
        assert r.sim.mode == "MANUAL"
        r.run(6.0, dt)  # 7.6 s
        assert c.last("GPS_RAW_INT").fix_type < 3
        r.run(2.0, dt)  # 9.6 s
        assert c.last("GPS_RAW_INT").fix_type == 3
        command(c, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        r.step(dt)
        assert c.acks()[-1].result == M.MAV_RESULT_FAILED
        assert "Arm: Accels inconsistent" in c.texts()
        r.run(14.0, dt)  # 23.6 s
        command(c, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        r.step(dt)
        assert c.acks()[-1].result == M.MAV_RESULT_ACCEPTED and r.sim.armed
        command(c, M.MAV_CMD_DO_SET_MODE, 1, 15)
        r.step(dt)
        assert c.acks()[-1].result == M.MAV_RESULT_FAILED  # EKF not using GPS yet
        assert r.sim.mode == "MANUAL"
        r.run(20.0, dt)  # 43.8 s
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
    assert t.surge == pytest.approx(1.0, abs=0.25)  # thrust 0.5 × WP_SPEED 2 m/s
    assert (t.heading - h0) % 360 > 40
    assert len(c.acks()) == 2  # arm + mode only: attitude targets are never ACKed
    rig.run(3.5, 0.1)
    assert "target not received last 3.0 secs, stopping" in c.texts()


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
        assert c.last("GPS_RAW_INT").fix_type == 3
        r.run(1.0)
        g = c.last("GPS_RAW_INT")
        assert g.fix_type == M.GPS_FIX_TYPE_NO_FIX and g.satellites_visible == 0
        assert c.last("GLOBAL_POSITION_INT").lat != 0  # the EKF carries on dead reckoning
        r.run(11.0)  # > 10 s without GPS: position lost
        flags = c.last("EKF_STATUS_REPORT").flags
        assert flags & M.EKF_CONST_POS_MODE and not flags & M.EKF_POS_HORIZ_ABS
        r.run(2.0)
        assert c.last("GPS_RAW_INT").fix_type == 3
        assert c.last("EKF_STATUS_REPORT").flags & M.EKF_POS_HORIZ_ABS
    finally:
        r.close()


@dataclass
class FakeFault:
    kind: str
    start: float
    end: float
    params: dict


class FakeScenario:
    """The faults.Scenario protocol: active(kind, t) and rng(name)."""

    def __init__(self, faults: list[FakeFault]) -> None:
        self.faults = faults

    def active(self, kind: str, t: float) -> list[FakeFault]:
        return [f for f in self.faults if f.kind == kind and f.start <= t < f.end]

    def rng(self, name: str):
        import zlib

        import numpy as np
        return np.random.default_rng(zlib.crc32(name.encode()))
