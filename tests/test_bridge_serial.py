"""The MAVLink bridge over a real serial line (a pseudo-terminal, opened by pymavlink/pyserial
exactly as ``/dev/ttyAMA0`` would be), with an autopilot written byte by byte on the other end.

Pins down the conversions (origin, units, yaw sign), the online rule, and that garbage bytes and
corrupted packets are counted and skipped without losing the good packets around them.
"""

from __future__ import annotations

import math
import os
import select
import time
import tty

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.bridge import BridgeConfig, MavlinkBridge
from mavhelm.core.bus import Bus
from mavhelm.core.clock import SimClock
from mavhelm.core.geodesy import Origin
from tests.support.waiting import wait_for

ORIGIN = Origin(56.4120, -5.4760)


_AUTOPILOT: dict[int, FakeAutopilot] = {}
"""The fake autopilot of each bridge under test, so ``tick`` can wait for its bytes."""


class FakeAutopilot:
    """Writes ArduPilot-shaped packets into the master side of a pty."""

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self.written = 0
        self.mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        self.parser = mavlink.MAVLink(None)

    def send(self, msg) -> bytes:
        data = msg.pack(self.mav)
        self.write(data)
        return data

    def write(self, data: bytes) -> None:
        self.written += os.write(self.fd, data)

    def heartbeat(self, custom_mode: int, armed: bool) -> None:
        base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (
            mavlink.MAV_MODE_FLAG_SAFETY_ARMED if armed else 0)
        self.send(mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_SURFACE_BOAT, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, base,
            custom_mode, mavlink.MAV_STATE_ACTIVE, 3))

    def read(self) -> list:
        try:
            data = os.read(self.fd, 65536)
        except BlockingIOError:
            return []
        return [m for m in self.parser.parse_buffer(data) or [] if m.get_type() != "BAD_DATA"]


@pytest.fixture
def serial_link():
    master, slave = os.openpty()
    tty.setraw(slave)
    os.set_blocking(master, False)
    path = os.ttyname(slave)
    clock = SimClock(100.0)
    bus = Bus(clock)
    bridge = MavlinkBridge(bus, BridgeConfig(connect=path, baud=115200), ORIGIN)
    assert bridge.link.connect(clock.now()), "pyserial opens the pty (and flushes its input)"
    bus.subscribe("test", ["*"])
    ap = FakeAutopilot(master)
    _AUTOPILOT[id(bridge)] = ap
    yield ap, bridge, bus, clock
    del _AUTOPILOT[id(bridge)]
    bridge.close()
    os.close(master)
    os.close(slave)


def tick(bridge: MavlinkBridge, bus: Bus, clock: SimClock, dt: float = 0.1) -> dict:
    """One bridge cycle. A pty hands bytes to the reader asynchronously: first wait until all
    the fake autopilot wrote has become readable (or, without one, briefly)."""
    fd = bridge.link.fileno()
    ap = _AUTOPILOT.get(id(bridge))
    if fd is not None and ap is not None:
        for _ in range(400):  # select returns at once while part is readable: sleep
            if bridge.link.bytes_received() + bridge.link.transport.port.in_waiting \
                    >= ap.written:
                break
            time.sleep(0.005)
    elif fd is not None:
        select.select([fd], [], [], 0.05)
    now = clock.advance(dt)
    bridge.receive(now)
    bridge.send([], now)
    return {m.name: m.value for m in bus.fetch("test")}


def test_serial_autopilot_becomes_variables(serial_link):
    ap, bridge, bus, clock = serial_link
    ap.heartbeat(15, armed=True)
    lat, lon = ORIGIN.to_global(30.0, -40.0)
    ap.send(mavlink.MAVLink_gps_raw_int_message(
        0, mavlink.GPS_FIX_TYPE_3D_FIX, int(lat * 1e7), int(lon * 1e7), 0, 80, 65535, 150,
        27000, 12))
    ap.send(mavlink.MAVLink_attitude_message(0, 0.01, -0.02, math.radians(270.0), 0, 0, 0.1))
    got = tick(bridge, bus, clock)
    assert got["GPS_X"] == pytest.approx(30.0, abs=0.02)
    assert got["GPS_Y"] == pytest.approx(-40.0, abs=0.02)
    assert got["GPS_SPEED"] == pytest.approx(1.5)
    assert got["GPS_HEADING"] == pytest.approx(270.0)
    assert got["INS_HEADING"] == pytest.approx(270.0)
    assert got["INS_YAW"] == pytest.approx(-math.radians(270.0)), "MOOS yaw = -heading"
    assert got["INS_YAW_VEL"] == pytest.approx(-0.1)
    assert got["AP_MODE"] == "GUIDED" and got["HELM_ONLINE"] == 1.0
    # the bridge introduced itself and asked for its streams over the same line
    sent: list = []

    def streams_asked() -> bool:  # the kernel hands a pty's bytes over on its own time
        sent.extend(ap.read())
        return {mavlink.MAVLINK_MSG_ID_GPS_RAW_INT, mavlink.MAVLINK_MSG_ID_ATTITUDE} <= {
            int(m.param1) for m in sent if m.get_type() == "COMMAND_LONG"} and any(
            m.get_type() == "HEARTBEAT" for m in sent)
    wait_for(streams_asked, 5.0, "the bridge's HEARTBEAT and stream requests on the pty")
    heartbeats = [m for m in sent if m.get_type() == "HEARTBEAT"]
    assert heartbeats and heartbeats[0].get_srcComponent() == 191
    assert heartbeats[0].autopilot == mavlink.MAV_AUTOPILOT_INVALID
    intervals = {int(m.param1): m.param2 for m in sent if m.get_type() == "COMMAND_LONG"
                 and m.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL}
    assert intervals[mavlink.MAVLINK_MSG_ID_GPS_RAW_INT] == 200000
    assert intervals[mavlink.MAVLINK_MSG_ID_ATTITUDE] == 100000


def test_no_fix_means_no_position(serial_link):
    ap, bridge, bus, clock = serial_link
    ap.send(mavlink.MAVLink_gps_raw_int_message(0, mavlink.GPS_FIX_TYPE_NO_FIX, 0, 0, 0, 65535,
                                                65535, 65535, 65535, 0))
    got = tick(bridge, bus, clock)
    assert got["GPS_FIX"] == 1.0
    assert "GPS_X" not in got


def test_garbage_and_corrupt_packets_are_counted_and_skipped(serial_link):
    ap, bridge, bus, clock = serial_link
    ap.heartbeat(15, armed=True)
    tick(bridge, bus, clock)
    ap.write(b"\x00garbage\xff\xfe NMEA? $GPGGA,,,*00\r\n")
    good = mavlink.MAVLink_attitude_message(0, 0, 0, math.radians(45.0), 0, 0, 0)
    data = bytearray(good.pack(ap.mav))
    data[12] ^= 0xFF  # corrupt the payload: the CRC no longer matches
    ap.write(bytes(data))
    ap.send(mavlink.MAVLink_attitude_message(0, 0, 0, math.radians(90.0), 0, 0, 0))
    got = tick(bridge, bus, clock)
    assert got["MAVLINK_BAD_PACKETS"] >= 1
    assert got["INS_HEADING"] == pytest.approx(90.0), "the good packet after the bad ones"
    assert bridge.packets >= 2


def test_offline_modes_and_disarmed_send_no_actuation(serial_link):
    ap, bridge, bus, clock = serial_link
    for mode, armed in ((0, True), (15, False), (4, True)):
        ap.heartbeat(mode, armed)
        tick(bridge, bus, clock)
        assert not bridge.online
        bridge.send([bus.notify("DESIRED_RUDDER", 10.0, "pHelm"),
                     bus.notify("DESIRED_THRUST", 50.0, "pHelm")], clock.now())
        assert not [m for m in ap.read() if m.get_type() == "SET_ATTITUDE_TARGET"]
    ap.heartbeat(15, True)
    tick(bridge, bus, clock)
    assert bridge.online
    bridge.send([bus.notify("DESIRED_RUDDER", 10.0, "pHelm"),
                 bus.notify("DESIRED_THRUST", 50.0, "pHelm")], clock.now())
    targets = [m for m in ap.read() if m.get_type() == "SET_ATTITUDE_TARGET"]
    assert len(targets) == 1
    assert targets[0].type_mask == 0x03
    assert targets[0].thrust == pytest.approx(0.5)
    turn = bridge.config.max_turn_rate  # deg/s at full rudder (20 deg by default)
    assert targets[0].body_yaw_rate == pytest.approx(math.radians(10.0 / 20.0 * turn))


def test_heartbeat_silence_takes_the_link_down(serial_link):
    ap, bridge, bus, clock = serial_link
    ap.heartbeat(15, True)
    tick(bridge, bus, clock)
    assert bridge.online
    for _ in range(40):
        got = tick(bridge, bus, clock)
        if "AP_LINK" in got:
            break
    assert got["AP_LINK"] == 0.0 and got["HELM_ONLINE"] == 0.0
    assert clock.now() - bridge.last_heartbeat == pytest.approx(3.1, abs=0.06)


def test_configured_stream_rates_are_what_is_requested():
    master, slave = os.openpty()
    tty.setraw(slave)
    os.set_blocking(master, False)
    clock = SimClock(0.0)
    bus = Bus(clock)
    config = BridgeConfig(connect=os.ttyname(slave))
    config.streams["VFR_HUD"] = 2.0
    bridge = MavlinkBridge(bus, config, ORIGIN)
    try:
        assert bridge.link.connect(clock.now())
        ap = FakeAutopilot(master)
        ap.heartbeat(0, armed=False)
        tick(bridge, bus, clock)
        intervals: dict[int, float] = {}

        def requested() -> bool:  # the kernel hands a pty's bytes over on its own time
            intervals.update({int(m.param1): m.param2 for m in ap.read()
                              if m.get_type() == "COMMAND_LONG"})
            return mavlink.MAVLINK_MSG_ID_VFR_HUD in intervals
        wait_for(requested, 5.0, "the stream requests on the pty")
        assert intervals[mavlink.MAVLINK_MSG_ID_VFR_HUD] == 500000
    finally:
        bridge.close()
        os.close(master)
        os.close(slave)


def test_a_vehicle_far_from_the_mission_origin_is_warned_about_once(serial_link):
    ap, bridge, bus, clock = serial_link
    lat, lon = ORIGIN.to_global(0.0, 152_842.0)  # the demo mission on mavhelm sim's default home

    def fix():
        ap.send(mavlink.MAVLink_gps_raw_int_message(
            0, mavlink.GPS_FIX_TYPE_3D_FIX, int(lat * 1e7), int(lon * 1e7), 0, 80, 65535, 0,
            0, 12))

    fix()
    got = tick(bridge, bus, clock)
    assert got["MAVLINK_WARNING"] == ("the vehicle is 152.8 km from the mission's origin "
                                      "(LatOrigin/LongOrigin): wrong mission, or a wrong origin?")
    fix()
    assert "MAVLINK_WARNING" not in tick(bridge, bus, clock), "said once"


def test_a_refused_hand_back_is_retried_then_reported(serial_link):
    ap, bridge, bus, clock = serial_link
    ap.heartbeat(15, armed=True)
    tick(bridge, bus, clock)
    assert bridge.online
    bridge.send([bus.notify("HELM_HANDBACK", "HOLD", "pHelm")], clock.now())
    asked = 0
    errors = []
    for _ in range(45):
        for m in ap.read():
            if m.get_type() == "COMMAND_LONG" and m.command == mavlink.MAV_CMD_DO_SET_MODE:
                asked += 1
                assert m.param2 == 4, "HOLD"
                ap.send(mavlink.MAVLink_statustext_message(4, b"Flight mode change failed"))
                ap.send(mavlink.MAVLink_command_ack_message(mavlink.MAV_CMD_DO_SET_MODE,
                                                            mavlink.MAV_RESULT_FAILED))
        ap.heartbeat(15, armed=True)
        got = tick(bridge, bus, clock)
        bridge.send([], clock.now())
        if "HELM_HANDBACK_ERROR" in got:
            errors.append(got["HELM_HANDBACK_ERROR"])
    assert asked == 3
    assert errors == ["ArduPilot did not take the vehicle in HOLD (DO_SET_MODE refused, result "
                      "4; it said: Flight mode change failed): the helm keeps the end values"]


def test_the_helm_status_says_when_the_ekf_would_refuse_guided(serial_link):
    ap, bridge, bus, clock = serial_link
    ap.send(mavlink.MAVLink_ekf_status_report_message(0, 0.0, 0.0, 0.0, 0.0, 0.0))
    ap.heartbeat(0, armed=False)
    assert tick(bridge, bus, clock)["HELM_STATUS"] == (
        "offline: autopilot disarmed (arm it and select GUIDED to hand over); its EKF has no "
        "position yet, so ArduPilot will refuse GUIDED")
    ap.send(mavlink.MAVLink_ekf_status_report_message(mavlink.EKF_POS_HORIZ_ABS, 0.0, 0.0,
                                                      0.0, 0.0, 0.0))
    ap.heartbeat(0, armed=True)
    assert tick(bridge, bus, clock)["HELM_STATUS"] == (
        "offline: autopilot in MANUAL; select GUIDED to hand over")
