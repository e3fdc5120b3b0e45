"""Late data: the bridge posts ``GPS_AGE`` from GPS_RAW_INT's time_usec against the
autopilot's clock, and pNav moves an XY fix on by its ``S_AGE`` along the filter's velocity,
so a boat's estimate no longer trails it by the age times its speed (on the real SITL
GPS_RAW_INT's fix was 0.06-0.18 s old, the same all run long); a heading stamped late in a
turn is trusted the less the faster it turns."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.bridge.readings import MAX_FIX_AGE, fix_age
from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock
from mavhelm.core.mission import parse_mission
from mavhelm.nav.ekf import I_VH, EKFConfig, Yaw
from mavhelm.nav.fusion import Fusion, FusionConfig, Start
from mavhelm.nav.navigator import Navigator
from mavhelm.nav.sensors import SensorReader, SensorSpec
from tests.support.bridge_rig import ORIGIN, BridgeRig


def test_fix_age_is_the_autopilot_clock_less_time_usec_when_that_is_its_clock() -> None:
    assert fix_age(100.0, 99_824_000) == pytest.approx(0.176)
    assert fix_age(100.0, 100_100_000) == 0.0  # sent before the next time_boot_ms
    assert fix_age(None, 99_824_000) is None           # no autopilot clock heard yet
    assert fix_age(100.0, 0) is None                   # no time given
    assert fix_age(100.0, 1_796_168_523_000_000) is None  # UNIX time, not the boot clock
    assert fix_age(100.0, int((100.0 - MAX_FIX_AGE - 0.5) * 1e6)) is None


def test_the_bridge_posts_gps_age_with_the_fix() -> None:
    rig = BridgeRig()
    lat, lon = int(ORIGIN.lat * 1e7), int(ORIGIN.lon * 1e7)

    def gps(time_usec: int) -> dict[str, float | str]:
        rig.hear(mavlink.MAVLink_gps_raw_int_message(
            time_usec, mavlink.GPS_FIX_TYPE_3D_FIX, lat, lon, 0, 100, 100, 300, 9000, 10))
        return {m.name: m.value for m in rig.posted() if m.name.startswith("GPS_")}

    rig.boat_heartbeat()
    assert "GPS_AGE" not in gps(50_000_000)  # the autopilot's clock not heard yet
    rig.hear(mavlink.MAVLink_attitude_message(60_000, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0))
    posted = gps(59_820_000)
    assert posted["GPS_AGE"] == pytest.approx(0.18)
    assert {"GPS_X", "GPS_Y"} <= set(posted)
    assert "GPS_AGE" not in gps(1_796_168_523_000_000)  # time_usec on another clock
    assert gps(60_050_000)["GPS_AGE"] == 0.0  # before the next message with the clock


def test_a_repeated_fix_is_not_posted_again() -> None:
    """ArduPilot's GPS_RAW_INT stream is not in step with the receiver and now and then sends
    the same fix (the same time_usec) twice. Posted again it would read as a vehicle that
    stopped (the real SITL rover-skid's speed measured dipped 20 % and a U-turn was planned as
    two corners) and a filter would count it twice; a fix with no time cannot be told from a
    repeat, and is posted."""
    rig = BridgeRig()
    lat, lon = int(ORIGIN.lat * 1e7), int(ORIGIN.lon * 1e7)

    def gps(time_usec: int, north: int = 0) -> set[str]:
        rig.hear(mavlink.MAVLink_gps_raw_int_message(
            time_usec, mavlink.GPS_FIX_TYPE_3D_FIX, lat + north, lon, 0, 100, 100, 300, 9000,
            10))
        return {m.name for m in rig.posted()}

    rig.boat_heartbeat()
    assert {"GPS_FIX", "GPS_X", "GPS_Y", "GPS_SPEED"} <= gps(59_800_000)
    rig.clock.advance(0.18)
    repeat = gps(59_800_000)
    assert "GPS_FIX" in repeat and not repeat & {"GPS_X", "GPS_Y", "GPS_SPEED", "GPS_HEADING"}
    assert rig.bridge.state.gps_repeats == 1
    assert {"GPS_X", "GPS_Y"} <= gps(60_000_000, north=10)
    assert {"GPS_X", "GPS_Y"} <= gps(0) and {"GPS_X", "GPS_Y"} <= gps(0)
    assert rig.bridge.state.gps_repeats == 1


def test_a_fix_read_late_in_a_batch_is_aged_on_the_lined_up_clock() -> None:
    """A link that delivers in batches: the ATTITUDE at 60.0 s was heard at once, the next
    batch (an ATTITUDE at 60.1 s, a fix taken at 59.98 s) 0.07 s after 60.1 s. The newest clock
    read says the fix is 0.12 s old; the clocks lined up on the least late message say 0.19."""
    rig = BridgeRig()
    rig.boat_heartbeat()
    rig.hear(mavlink.MAVLink_attitude_message(60_000, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0))
    rig.clock.advance(0.17)
    rig.hear(mavlink.MAVLink_attitude_message(60_100, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0))
    rig.hear(mavlink.MAVLink_gps_raw_int_message(
        59_980_000, mavlink.GPS_FIX_TYPE_3D_FIX, int(ORIGIN.lat * 1e7), int(ORIGIN.lon * 1e7),
        0, 100, 100, 300, 9000, 10))
    posted = {m.name: m.value for m in rig.posted()}
    assert posted["INS_AGE"] == pytest.approx(0.07)
    assert posted["GPS_AGE"] == pytest.approx(0.19)


def test_the_reader_joins_an_age_to_its_fix_and_refuses_one_out_of_range() -> None:
    reader = SensorReader([SensorSpec("XY", "GPS", "gps", noise=(2.0,))], [])

    def age(*extra: Message) -> float:
        readings, _ = reader.read([Message("GPS_X", 1.0, 5.0, "b"),
                                   Message("GPS_Y", 2.0, 5.0, "b"), *extra])
        assert len(readings) == 1
        return readings[0].age

    assert age() == 0.0
    assert age(Message("GPS_AGE", 0.15, 5.0, "b")) == 0.15
    assert age(Message("GPS_AGE", -0.3, 5.0, "b")) == 0.0
    assert age(Message("GPS_AGE", 30.0, 5.0, "b")) == 0.0
    readings, _ = reader.read([Message("GPS_AGE", 0.1, 6.0, "b")])
    assert readings == [] and reader.incomplete == 1  # an age alone is no fix


MISSION = """\
ProcessConfig = pNav
{
    X = EKF @ 2
    Y = EKF @ 2
    SENSOR_XY = GPS -> gps ~ 0.3
    EKF_XY_DYNAMICS = 3
}
"""


def _trail(age: float | None, speed: float = 3.0, seconds: float = 60.0) -> float:
    """Mean along-track error (m, + ahead) of a navigator fed fixes ``age`` old (posted with
    GPS_AGE when ``age`` is not None) of a vehicle going north at ``speed``."""
    clock = SimClock(0.0)
    bus = Bus(clock)
    nav = Navigator.from_block(bus, parse_mission(MISSION, "m.moos").process("pNav"))
    bus.subscribe(nav.name, nav.subscriptions())
    true_age = 0.18 if age is None else age
    errors = []
    for k in range(int(seconds / 0.2)):
        t = 0.2 * k
        clock.set(t)
        bus.notify("GPS_X", 0.0, t)
        bus.notify("GPS_Y", speed * (t - true_age), t)
        if age is not None:
            bus.notify("GPS_AGE", age, t)
        nav.on_mail(bus.fetch(nav.name), t)
        nav.iterate(t)
        estimate = nav.fusion.ekf.estimate() if nav.fusion and nav.fusion.ekf else None
        if estimate is not None and t > 20.0:
            errors.append(estimate.y - speed * estimate.t)
    return sum(errors) / len(errors)


def test_a_fix_moved_on_by_its_age_leaves_the_estimate_on_the_vehicle() -> None:
    trailing = _trail(None)             # the 0.18 s old fixes taken as stamped
    moved = _trail(0.18)
    assert trailing == pytest.approx(-0.54, abs=0.05)  # 0.18 s at 3 m/s behind
    assert math.isclose(moved, 0.0, abs_tol=0.05)


def test_a_heading_in_a_turn_is_widened_by_the_lateness_times_the_turn_rate() -> None:
    fusion = Fusion(FusionConfig(ekf=EKFConfig(time_sigma=0.1), lsq_timeout=None,
                                 start=Start(0.0, 0.0, 0.0, 2.0, math.radians(5.0))))
    fusion.step(0.0)
    assert fusion.ekf is not None
    compass = Yaw(0.0, 0.0, math.radians(0.5))
    assert fusion._weighted(compass, "compass").sigma == compass.sigma  # not turning
    fusion.ekf.x[I_VH, 0] = math.radians(15.0)  # 15 deg/s, stamped 0.1 s late: 1.5 deg off
    widened = fusion._weighted(compass, "compass").sigma
    assert math.degrees(widened) == pytest.approx(math.hypot(0.5, 1.5))


HEADING_MISSION = """\
ProcessConfig = pNav
{
    X = EKF @ 2
    Y = EKF @ 2
    Heading = EKF @ 2
    SENSOR_XY = GPS -> gps ~ 0.3
    SENSOR_ORIENTATION = INS -> compass ~ 0.5
    EKF_XY_DYNAMICS = 3
}
"""


def _heading_lag(age: float | None, late: float = 0.15, seconds: float = 60.0) -> float:
    """Mean heading error (deg, + ahead of the truth) of a navigator on a vehicle circling at
    3 m/s, 12 deg/s, its compass heard ``late`` s after it read (INS_AGE posted when ``age`` is
    not None)."""
    clock = SimClock(0.0)
    bus = Bus(clock)
    nav = Navigator.from_block(bus, parse_mission(HEADING_MISSION, "m.moos").process("pNav"))
    bus.subscribe(nav.name, nav.subscriptions())
    rate = math.radians(12.0)
    radius = 3.0 / rate

    def pose(t: float) -> tuple[float, float, float]:
        a = rate * t   # clockwise from north
        return radius * (1 - math.cos(a)), radius * math.sin(a), math.degrees(a)

    errors = []
    for k in range(int(seconds / 0.1)):
        t = 0.1 * k
        clock.set(t)
        x, y, heading = pose(t - late)
        bus.notify("INS_YAW", -math.radians(heading), t)
        if age is not None:
            bus.notify("INS_AGE", age, t)
        if k % 2 == 0:
            fx, fy, _ = pose(t)
            bus.notify("GPS_X", fx, t)
            bus.notify("GPS_Y", fy, t)
        nav.on_mail(bus.fetch(nav.name), t)
        nav.iterate(t)
        estimate = nav.fusion.ekf.estimate() if nav.fusion and nav.fusion.ekf else None
        if estimate is not None and t > 20.0:
            errors.append((estimate.heading - pose(estimate.t)[2] + 180.0) % 360.0 - 180.0)
    return sum(errors) / len(errors)


def test_a_heading_heard_late_in_a_turn_is_moved_on_by_its_age() -> None:
    trailing = _heading_lag(None)
    moved = _heading_lag(0.15)
    print(f"\n[heading] stamped as heard: {trailing:+.2f} deg; moved on by INS_AGE: {moved:+.2f}")
    assert trailing < -1.0                # 0.15 s at 12 deg/s: 1.8 deg behind, less the GPS's pull
    assert abs(moved) < 0.3
