"""The MAVLink bridge on ArduSub, with encoded frames through a stand-in transport: the mode
table chosen from the HEARTBEAT type, depth from GLOBAL_POSITION_INT and VFR_HUD, the SubGuided
profile's SET_POSITION_TARGET_LOCAL_NED, and HandBack = SURFACE. (The real binary: see
test_ardusub_figure1.py.)"""

from __future__ import annotations

import math
from collections import deque

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.actuation import BODY_VELOCITY_AND_YAW_RATE, Guided, SubGuided
from mavhelm.companion.bridge import BridgeConfig, MavlinkBridge
from mavhelm.companion.link import AutopilotLink
from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock
from mavhelm.core.geodesy import Origin

ARMED = mavlink.MAV_MODE_FLAG_SAFETY_ARMED | mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
SUB = mavlink.MAV_TYPE_SUBMARINE
BOAT = mavlink.MAV_TYPE_SURFACE_BOAT


class Pipe:
    """Bytes in from ``incoming``, bytes out into ``written``."""

    def __init__(self) -> None:
        self.written = bytearray()
        self.incoming: deque[bytes] = deque()

    def open(self) -> None: ...

    def ready(self) -> bool:
        return True

    def write(self, data: bytes) -> int:
        self.written += data
        return len(data)

    def read_into(self, buffer: memoryview) -> int:
        if not self.incoming:
            return 0
        chunk = self.incoming.popleft()
        buffer[:len(chunk)] = chunk
        return len(chunk)

    def close(self) -> None: ...

    def fileno(self) -> int | None:
        return None


class Rig:
    def __init__(self, **settings: object) -> None:
        self.clock = SimClock(100.0)
        self.bus = Bus(self.clock)
        self.bus.subscribe("test", ["*"])
        self.pipe = Pipe()
        config = BridgeConfig(max_rudder=20.0, max_elevator=30.0, **settings)
        link = AutopilotLink("tcp:127.0.0.1:9", transport=self.pipe)  # type: ignore[arg-type]
        self.bridge = MavlinkBridge(self.bus, config, Origin(56.412, -5.476), link=link)
        self.autopilot = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)

    def tick(self, *msgs: mavlink.MAVLink_message) -> dict[str, list[float | str]]:
        for msg in msgs:
            self.pipe.incoming.append(msg.pack(self.autopilot))
        now = self.clock.advance(0.1)
        self.bridge.receive(now)
        posted: dict[str, list[float | str]] = {}
        for m in self.bus.fetch("test"):
            posted.setdefault(m.name, []).append(m.value)
        return posted

    def heartbeat(self, mav_type: int, mode: int) -> mavlink.MAVLink_message:
        return mavlink.MAVLink_heartbeat_message(mav_type, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                                 ARMED, mode, mavlink.MAV_STATE_ACTIVE, 3)

    def sent(self) -> list[mavlink.MAVLink_message]:
        parser = mavlink.MAVLink(None)
        out = parser.parse_buffer(bytes(self.pipe.written)) or []
        self.pipe.written.clear()
        return out


def test_ardusub_modes_and_profile_follow_the_heartbeat_type() -> None:
    rig = Rig()
    posted = rig.tick(rig.heartbeat(SUB, 4))
    assert posted["AP_MODE"] == ["GUIDED"] and posted["HELM_ONLINE"] == [1.0]
    assert isinstance(rig.bridge.actuation, SubGuided)
    assert rig.tick(rig.heartbeat(SUB, 9))["AP_MODE"] == ["SURFACE"]
    assert rig.tick(rig.heartbeat(SUB, 2))["AP_MODE"] == ["ALT_HOLD"]
    boat = Rig()
    assert boat.tick(boat.heartbeat(BOAT, 4))["AP_MODE"] == ["HOLD"]
    assert isinstance(boat.bridge.actuation, Guided)


def test_depth_from_global_position_int_and_vfr_hud_on_ardusub_only() -> None:
    rig = Rig()
    rig.tick(rig.heartbeat(SUB, 19))
    gpi = mavlink.MAVLink_global_position_int_message(1000, 564120000, -54760000, -8100,
                                                      -8000, 0, 0, 0, 9000)
    vfr = mavlink.MAVLink_vfr_hud_message(0.0, 0.0, 90, 0, -7.9, 0.0)
    posted = rig.tick(gpi, vfr)
    assert posted["AP_DEPTH"] == [pytest.approx(8.0)] and posted["AP_Z"] == [pytest.approx(-8.0)]
    assert posted["VFR_DEPTH"] == [pytest.approx(7.9)]
    boat = Rig()
    boat.tick(boat.heartbeat(BOAT, 4))
    assert "AP_DEPTH" not in boat.tick(gpi, vfr)
    bad = mavlink.MAVLink_vfr_hud_message(0.0, 0.0, 90, 0, float("nan"), 0.0)
    assert "VFR_DEPTH" not in rig.tick(bad) and rig.bridge.bad_packets == 1


def test_sub_guided_sends_body_velocity_and_yaw_rate() -> None:
    rig = Rig(max_speed=2.0, max_depth_rate=0.5, max_turn_rate=40.0)
    rig.tick(rig.heartbeat(SUB, 4))
    rig.sent()
    now = rig.clock.now()
    mail = [Message("DESIRED_RUDDER", 10.0, now, "pHelm"),
            Message("DESIRED_THRUST", 50.0, now, "pHelm"),
            Message("DESIRED_ELEVATOR", -15.0, now, "pHelm")]
    rig.bridge.send(mail, now)
    targets = [m for m in rig.sent() if m.get_type() == "SET_POSITION_TARGET_LOCAL_NED"]
    assert len(targets) == 1
    t = targets[0]
    assert t.coordinate_frame == mavlink.MAV_FRAME_BODY_NED
    assert t.type_mask == BODY_VELOCITY_AND_YAW_RATE
    assert (t.vx, t.vy, t.vz) == (pytest.approx(1.0), 0.0, pytest.approx(-0.25))
    assert t.yaw_rate == pytest.approx(math.radians(20.0))
    # nothing out of range reaches the autopilot: a wild elevator goes as 0, and is said
    rig.bridge.send([Message("DESIRED_THRUST", 0.0, now, "pHelm"),
                     Message("DESIRED_ELEVATOR", 1e9, now, "pHelm")], now)
    t = next(m for m in rig.sent() if m.get_type() == "SET_POSITION_TARGET_LOCAL_NED")
    assert t.vz == 0.0 and rig.bridge.refused_outputs == 1


def test_handback_surface_on_ardusub_and_refused_on_rover() -> None:
    rig = Rig()
    rig.tick(rig.heartbeat(SUB, 4))
    now = rig.clock.now()
    rig.bridge.send([Message("HELM_HANDBACK", "SURFACE", now, "pHelm")], now)
    commands = [m for m in rig.sent() if m.get_type() == "COMMAND_LONG"
                and m.command == mavlink.MAV_CMD_DO_SET_MODE]
    assert commands and commands[0].param2 == 9
    assert rig.tick(rig.heartbeat(SUB, 9)).get("HELM_HANDBACK_DONE") == ["SURFACE"]
    boat = Rig()
    boat.tick(boat.heartbeat(BOAT, 15))
    now = boat.clock.now()
    boat.bridge.send([Message("HELM_HANDBACK", "SURFACE", now, "pHelm")], now)
    errors = [m.value for m in boat.bus.fetch("test") if m.name == "HELM_HANDBACK_ERROR"]
    assert errors and "not a mode of this vehicle" in str(errors[0])


def test_depth_from_the_pressure_sensor_once_its_parameters_are_known() -> None:
    rig = Rig()
    rig.tick(rig.heartbeat(SUB, 19))
    pressure = mavlink.MAVLink_scaled_pressure_message(1000, 1013.25 + 98.0665 * 1.024 * 5,
                                                       0.0, 1500)
    assert "BARO_DEPTH" not in rig.tick(pressure), "no surface pressure known yet"
    rig.tick(mavlink.MAVLink_param_value_message(b"BARO1_GND_PRESS", 101325.0, 9, 1, 0),
             mavlink.MAVLink_param_value_message(b"BARO_SPEC_GRAV", 1.024, 9, 1, 1))
    posted = rig.tick(pressure)
    assert posted["BARO_DEPTH"] == [pytest.approx(5.0, abs=0.01)]


def test_a_surface_vehicles_link_skims_the_depth_messages_a_subs_decodes() -> None:
    """Decoding is pymavlink's costliest step: ArduSub's depth messages are decoded only on a
    submarine (or before the autopilot's type is known)."""
    vfr = mavlink.MAVLink_vfr_hud_message(0.0, 0.0, 90, 0, -7.9, 0.0)
    for vehicle, skimmed in ((SUB, 0), (BOAT, 1)):
        rig = Rig()
        rig.tick(vfr)
        assert rig.bridge.link.stats.skimmed == 0, "type unknown: decoded"
        rig.tick(rig.heartbeat(vehicle, 4))
        rig.tick(vfr)
        assert rig.bridge.link.stats.skimmed == skimmed
