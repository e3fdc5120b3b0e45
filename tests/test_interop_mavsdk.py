"""MAVSDK, a real ground-station library nobody here wrote, against the simulator.

``mavsdk`` >= 4 on PyPI is the native binding (ctypes over libcmavsdk, no mavsdk_server, a
synchronous API). The calls used are the ones a user would make against ArduPilot Rover SITL:
``Mavsdk(Configuration.create_with_component_type(GROUND_STATION))``,
``add_any_connection("tcpout://HOST:PORT")``, ``first_autopilot(timeout)``, the Telemetry
plugin for position/flight mode/armed, Action for arm/hold/disarm/goto_location and, since
MAVSDK has no "set flight mode" for ArduPilot's Rover modes, a COMMAND_LONG
MAV_CMD_DO_SET_MODE through MavlinkDirect for GUIDED.

MAVSDK names ArduPilot Rover modes with its own (PX4-flavoured) FlightMode enum, as measured
here: MANUAL → MANUAL, ACRO → ACRO, HOLD → HOLD, FOLLOW → FOLLOW_ME, RTL → RETURN_TO_LAUNCH,
GUIDED → OFFBOARD; STEERING, LOITER, SIMPLE and SMART_RTL → UNKNOWN.

Most tests run the simulator in this process on the wall clock (a stepping thread), so each step
can be checked against its truth: the position MAVSDK reports against the vehicle's true
position, arming and modes against ``sim.armed`` / ``sim.mode``. One runs the real
``mavhelm sim`` command and checks through a companion link instead.
"""

from __future__ import annotations

import json
import math
import time

import pytest
from pymavlink import mavutil

from mavhelm.core.geodesy import Origin
from tests.support.interop_helpers import Companion, RealtimeSim, SimProcess, armed
from tests.support.waiting import wait_for

pytestmark = pytest.mark.slow

# Somewhere the simulator's default home (56, -3) is not, so a position from anywhere else fails.
HOME = Origin(47.397742, 8.545594)
MAV_CMD_DO_SET_MODE = 176
MAV_MODE_FLAG_CUSTOM_MODE_ENABLED = 1
MAV_RESULT_ACCEPTED = 0
GUIDED = 15


def _import_mavsdk():
    """The mavsdk modules, or a test failure that says why the native library is unusable."""
    try:
        import mavsdk
        from mavsdk import ComponentType, Configuration, Mavsdk
        from mavsdk.autopilot import Autopilot
        from mavsdk.plugins.action import Action
        from mavsdk.plugins.mavlink_direct import MavlinkDirect, MavlinkMessage
        from mavsdk.plugins.telemetry import FlightMode, Telemetry
        from mavsdk.vehicle import Vehicle
    except Exception as exc:  # noqa: BLE001 - any load failure must fail loudly, not skip
        pytest.fail(f"MAVSDK (PyPI `mavsdk` >= 4, native libcmavsdk) cannot be loaded here: "
                    f"{exc!r}. Install the test extras: pip install -e '.[test]'")
    major = int(mavsdk.__version__.split(".")[0]) if mavsdk.__version__[0].isdigit() else 0
    assert major >= 4, f"these tests need the native mavsdk >= 4, found {mavsdk.__version__}"
    return (mavsdk, Mavsdk, Configuration, ComponentType, Autopilot, Vehicle, Telemetry,
            FlightMode, Action, MavlinkDirect, MavlinkMessage)


class _Client:
    """One MAVSDK ground station connected to the simulator, with its log captured."""

    def __init__(self, port: int) -> None:
        (self.mavsdk, Mavsdk, Configuration, ComponentType, self.Autopilot, self.Vehicle,
         Telemetry, self.FlightMode, Action, MavlinkDirect, self.MavlinkMessage) = _import_mavsdk()
        self.log: list[str] = []

        def on_log(level, message, file, line):  # keep MAVSDK's chatter out of the test output
            self.log.append(f"{level.name}: {message}")
            return True

        self.mavsdk.log_subscribe(on_log)
        self.mav = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
        try:
            result = self.mav.add_any_connection(f"tcpout://127.0.0.1:{port}")
            assert result == 0, f"add_any_connection failed: {result!r}"  # ConnectionResult.SUCCESS
            t0 = time.monotonic()
            self.system = self.mav.first_autopilot(10.0)
            self.discovery_s = time.monotonic() - t0
            assert self.system is not None, self.fail_text("first_autopilot(10.0) found nothing")
            self.telemetry = Telemetry(self.system)
            self.action = Action(self.system)
            self.direct = MavlinkDirect(self.system)
        except BaseException:
            self.close()
            raise

    def fail_text(self, what: str) -> str:
        return what + "; MAVSDK log:\n" + "\n".join(self.log[-30:])

    def set_custom_mode(self, custom_mode: int) -> dict:
        """MAV_CMD_DO_SET_MODE (custom mode) via MavlinkDirect; returns the COMMAND_ACK fields."""
        sysid = self.system.get_system_id()
        fields = {"target_system": sysid, "target_component": 1, "command": MAV_CMD_DO_SET_MODE,
                  "confirmation": 0, "param1": MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                  "param2": custom_mode, "param3": 0, "param4": 0, "param5": 0, "param6": 0,
                  "param7": 0}
        cmd = self.MavlinkMessage(message_name="COMMAND_LONG", target_system_id=sysid,
                                  target_component_id=1, fields_json=json.dumps(fields))
        ack = self.direct.send_command(cmd)
        assert ack.message_name == "COMMAND_ACK", ack
        return json.loads(ack.fields_json)

    def close(self) -> None:
        self.mav.destroy()
        self.mavsdk.log_unsubscribe()


@pytest.fixture
def client_on():
    clients: list[_Client] = []

    def make(port: int) -> _Client:
        clients.append(_Client(port))
        return clients[-1]

    yield make
    for c in clients:
        c.close()


def _metres_apart(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    x, y = HOME.to_local(lat1, lon1)
    x2, y2 = HOME.to_local(lat2, lon2)
    return math.hypot(x - x2, y - y2)


@pytest.mark.parametrize("vehicle", ["boat", "rover"])
def test_mavsdk_sees_the_vehicle_arms_it_and_changes_its_mode(vehicle, client_on):
    with RealtimeSim(model=f"mavhelm-{vehicle}", home=HOME, start_heading=30.0) as rs:
        c = client_on(rs.ports[1])  # the port a second ground station uses (5762 in SITL)
        FM = c.FlightMode
        sysm = c.system

        # The vehicle: one ArduPilot autopilot, system 1, of the right kind.
        assert c.discovery_s < 10.0
        assert sysm.is_connected() and sysm.has_autopilot()
        assert sysm.get_system_id() == 1
        assert sysm.autopilot_type() == c.Autopilot.ARDUPILOT
        # MAVSDK files MAV_TYPE_GROUND_ROVER under ROVER and a SURFACE_BOAT under GENERIC
        assert sysm.vehicle_type() == (c.Vehicle.ROVER if vehicle == "rover"
                                       else c.Vehicle.GENERIC)

        # Flight mode: MANUAL once the autopilot has initialised, as the simulator says.
        wait_for(lambda: c.telemetry.flight_mode() == FM.MANUAL, 10,
                 "MAVSDK flight_mode MANUAL", c.telemetry.flight_mode)
        assert rs.sim.mode == "MANUAL"

        # Position: once the EKF uses GPS, MAVSDK's position is the vehicle's (within GPS noise)
        # and what the autopilot believes (within one GLOBAL_POSITION_INT period).
        rs.wait(lambda s: s.autopilot.position_ok(), 10, "the EKF to use GPS")

        def fix():
            p = c.telemetry.position()
            return p if math.isfinite(p.latitude_deg) and p.latitude_deg != 0.0 else None

        wait_for(fix, 10, "a position from MAVSDK", c.telemetry.position)
        time.sleep(1.2)  # a fresh GLOBAL_POSITION_INT, sent after the EKF position is good
        pos = c.telemetry.position()
        with rs.lock:
            true_lat, true_lon = HOME.to_global(rs.sim.truth.x, rs.sim.truth.y)
            est_lat, est_lon = HOME.to_global(rs.sim.autopilot.est.x, rs.sim.autopilot.est.y)
        where = f"MAVSDK {pos}; truth {true_lat:.7f}, {true_lon:.7f}"
        assert abs(pos.latitude_deg - true_lat) < 2e-5, where  # ~2 m north
        assert abs(pos.longitude_deg - true_lon) < 3e-5, where  # ~2 m east at 47.4 deg
        assert _metres_apart(pos.latitude_deg, pos.longitude_deg, true_lat, true_lon) < 2.0, where
        assert _metres_apart(pos.latitude_deg, pos.longitude_deg, est_lat, est_lon) < 0.5, (
            f"MAVSDK {pos}; autopilot estimate {est_lat:.7f}, {est_lon:.7f}")
        heading = c.telemetry.heading().heading_deg
        assert abs((heading - 30.0 + 180.0) % 360.0 - 180.0) < 2.0, heading

        # Arm (Action plugin, MAV_CMD_COMPONENT_ARM_DISARM): the simulator is really armed.
        assert not rs.sim.armed and not c.telemetry.armed()
        c.action.arm()  # raises ActionError unless the COMMAND_ACK is ACCEPTED
        assert rs.sim.armed
        wait_for(c.telemetry.armed, 5, "MAVSDK to see the vehicle armed")

        # HOLD through Action.hold(), which MAVSDK maps to ArduPilot Rover mode 4.
        c.action.hold()
        assert rs.sim.mode == "HOLD"
        wait_for(lambda: c.telemetry.flight_mode() == FM.HOLD, 5,
                 "MAVSDK flight_mode HOLD", c.telemetry.flight_mode)

        # GUIDED (15): no Action call for it, so DO_SET_MODE through MavlinkDirect.
        ack = c.set_custom_mode(GUIDED)
        assert ack["command"] == MAV_CMD_DO_SET_MODE and ack["result"] == MAV_RESULT_ACCEPTED, ack
        assert rs.sim.mode == "GUIDED"
        wait_for(lambda: c.telemetry.flight_mode() == FM.OFFBOARD, 5,
                 "MAVSDK flight_mode OFFBOARD (its name for ArduPilot GUIDED)",
                 c.telemetry.flight_mode)

        # A mode Rover does not have is refused, and nothing changes.
        ack = c.set_custom_mode(2)
        assert ack["result"] != MAV_RESULT_ACCEPTED, ack
        assert rs.sim.mode == "GUIDED"

        c.action.disarm()
        assert not rs.sim.armed
        wait_for(lambda: not c.telemetry.armed(), 5, "MAVSDK to see the vehicle disarmed")
        rs.check()


def test_mavsdk_goto_location_drives_the_rover_and_its_position_follows(client_on):
    """Action.goto_location puts ArduPilot in GUIDED with a target; MAVSDK's position tracks the
    moving vehicle's truth."""
    with RealtimeSim(model="mavhelm-rover", home=HOME) as rs:
        c = client_on(rs.ports[1])
        rs.wait(lambda s: s.autopilot.position_ok(), 10, "the EKF to use GPS")
        wait_for(lambda: math.isfinite(c.telemetry.position().latitude_deg), 10,
                 "a position from MAVSDK", c.telemetry.position)
        time.sleep(1.2)
        c.action.arm()
        assert rs.sim.armed
        target = HOME.to_global(0.0, 12.0)  # 12 m north of home
        c.action.goto_location(target[0], target[1], 0.0, float("nan"))
        assert rs.sim.mode == "GUIDED"
        wait_for(lambda: c.telemetry.flight_mode() == c.FlightMode.OFFBOARD, 5,
                 "MAVSDK flight_mode OFFBOARD", c.telemetry.flight_mode)
        # Moving: compare MAVSDK's position with the truth a few times on the way.
        rs.wait(lambda s: s.truth.y > 3.0, 15, "the rover to drive 3 m north")
        worst = 0.0
        for _ in range(4):
            p = c.telemetry.position()
            with rs.lock:
                lat, lon = HOME.to_global(rs.sim.truth.x, rs.sim.truth.y)
            # GLOBAL_POSITION_INT comes at 1 Hz by default: allow a second of travel (~2 m/s)
            worst = max(worst, _metres_apart(p.latitude_deg, p.longitude_deg, lat, lon))
            time.sleep(0.5)
        assert worst < 4.0, f"MAVSDK position {worst:.1f} m from the truth while driving"
        rs.wait(lambda s: s.truth.y > 9.0, 20, "the rover to reach the target")
        wait_for(lambda: HOME.to_local(c.telemetry.position().latitude_deg,
                                         c.telemetry.position().longitude_deg)[1] > 8.0, 5,
                 "MAVSDK's position near the target", c.telemetry.position)
        c.action.hold()
        assert rs.sim.mode == "HOLD"
        rs.check()


def test_mavsdk_against_the_mavhelm_sim_command(client_on):
    """The same client against the real ``mavhelm sim`` command, checked by a companion link."""
    _import_mavsdk()
    with SimProcess("--fast-start", "--model", "mavhelm-rover", "--home",
                    f"{HOME.lat},{HOME.lon},0") as sim, Companion(sim.ports[0]) as companion:
        c = client_on(sim.ports[1])
        assert c.system.autopilot_type() == c.Autopilot.ARDUPILOT
        assert c.system.vehicle_type() == c.Vehicle.ROVER
        companion.wait_for("EKF_STATUS_REPORT",
                           lambda m: m.flags & mavutil.mavlink.EKF_POS_HORIZ_ABS, 10,
                           "the EKF to report an absolute horizontal position")
        wait_for(lambda: c.telemetry.flight_mode() == c.FlightMode.MANUAL, 5,
                 "MAVSDK flight_mode MANUAL", c.telemetry.flight_mode)
        time.sleep(1.2)
        pos = c.telemetry.position()
        gpi = companion.wait_for("GLOBAL_POSITION_INT", lambda m: m.lat != 0, 3,
                                 "a GLOBAL_POSITION_INT with a position")
        # the rover sits at --home; both links report it within GPS noise
        assert _metres_apart(pos.latitude_deg, pos.longitude_deg, HOME.lat, HOME.lon) < 2.0, pos
        assert _metres_apart(pos.latitude_deg, pos.longitude_deg, gpi.lat / 1e7,
                             gpi.lon / 1e7) < 0.5, (str(pos), gpi)

        c.action.arm()
        companion.wait_for("HEARTBEAT", armed, 5, "an armed HEARTBEAT")
        ack = c.set_custom_mode(GUIDED)
        assert ack["result"] == MAV_RESULT_ACCEPTED, ack
        hb = companion.wait_for("HEARTBEAT", lambda m: m.custom_mode == GUIDED, 5,
                                "HEARTBEAT custom_mode 15 (GUIDED)")
        assert armed(hb)
        wait_for(lambda: c.telemetry.flight_mode() == c.FlightMode.OFFBOARD, 5,
                 "MAVSDK flight_mode OFFBOARD", c.telemetry.flight_mode)
