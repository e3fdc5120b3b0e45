import math

import pytest

from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock
from mavhelm.core.mission import MissionError, parse_mission
from mavhelm.nav.navigator import Navigator

PNAV = """\
ProcessConfig = pNav
{
   X     = GPS @ 2.0 , EKF @ 2.5 ,LSQ @ 5.0 ,
   Y     = GPS @ 2.0 , AP @ 2.0
   Depth = DEPTH @ 1.0
   Yaw   = INS @ 1.0, AP @ 2
   Speed = GPS, AP
}
"""


class Harness:
    """The navigator and a listener on a bus driven by a simulated clock."""

    def __init__(self, text: str = PNAV) -> None:
        self.clock = SimClock(100.0)
        self.bus = Bus(self.clock)
        self.nav = Navigator.from_mission(self.bus, parse_mission(text, "t.moos"))
        self.bus.subscribe(self.nav.name, self.nav.subscriptions())
        self.bus.subscribe("listener", ["*"])

    def sensor(self, name: str, value: float | str, time: float | None = None) -> None:
        self.bus.notify(name, value, "iMAVLink", time)

    def tick(self, dt: float = 0.1) -> list[Message]:
        """Advance, run one navigator cycle, and return what it posted."""
        self.clock.advance(dt)
        now = self.clock.now()
        self.nav.on_mail(self.bus.fetch(self.nav.name), now)
        self.nav.iterate(now)
        return [m for m in self.bus.fetch("listener") if m.source == "pNav"]


def posted(msgs: list[Message], name: str) -> list[float | str]:
    return [m.value for m in msgs if m.name == name]


def test_subscribes_to_source_key_variables() -> None:
    h = Harness()
    subs = h.nav.subscriptions()
    assert {"GPS_X", "EKF_X", "LSQ_X", "GPS_Y", "AP_Y", "INS_YAW", "AP_YAW"} <= subs
    assert {"DEPTH_DEPTH", "DEPTH", "GPS_SPEED", "AP_SPEED"} <= subs
    assert "NAV_X" not in subs


def test_forwards_fresh_values_once_with_the_sensor_time_stamp() -> None:
    h = Harness()
    h.tick()
    h.sensor("GPS_X", 5.0, time=100.05)
    out = h.tick()
    nav_x = [m for m in out if m.name == "NAV_X"]
    assert [(m.value, m.time) for m in nav_x] == [(5.0, 100.05)]
    assert posted(h.tick(), "NAV_X") == []
    h.sensor("GPS_X", 6.0)
    assert posted(h.tick(), "NAV_X") == [6.0]


def test_lower_source_is_ignored_while_the_better_one_is_fresh() -> None:
    h = Harness()
    h.sensor("GPS_X", 1.0)
    h.sensor("EKF_X", 99.0)
    out = h.tick()
    assert posted(out, "NAV_X") == [1.0]
    assert posted(out, "NAV_X_SOURCE") == ["GPS"]


def test_falls_back_then_pops_back_and_announces_the_source() -> None:
    h = Harness()
    h.sensor("GPS_X", 1.0)
    h.tick()
    for _ in range(25):
        h.sensor("EKF_X", 2.0)
        out = h.tick()
        if "EKF" in posted(out, "NAV_X_SOURCE"):
            break
    assert posted(out, "NAV_X_SOURCE") == ["EKF"]
    assert h.clock.now() - 100.0 > 2.0
    h.sensor("EKF_X", 3.0)
    assert posted(h.tick(), "NAV_X") == [3.0]
    h.sensor("GPS_X", 4.0)
    h.sensor("EKF_X", 3.5)
    out = h.tick()
    assert posted(out, "NAV_X") == [4.0]
    assert posted(out, "NAV_X_SOURCE") == ["GPS"]


def test_all_sources_stale_stops_nav_and_says_none() -> None:
    h = Harness()
    h.sensor("GPS_X", 1.0)
    h.sensor("GPS_Y", 2.0)
    out = h.tick()
    assert posted(out, "NAV_X") == [1.0] and posted(out, "NAV_Y") == [2.0]
    later: list[Message] = []
    for _ in range(100):
        later += h.tick()
    assert posted(later, "NAV_X") == [] and posted(later, "NAV_Y") == []
    assert posted(later, "NAV_X_SOURCE") == ["NONE"]
    assert posted(later, "NAV_Y_SOURCE") == ["NONE"]


def test_a_value_that_arrives_already_stale_is_not_forwarded() -> None:
    h = Harness()
    h.tick(10.0)
    h.sensor("GPS_X", 1.0, time=h.clock.now() - 2.5)
    h.sensor("LSQ_X", 7.0, time=h.clock.now() - 1.0)
    out = h.tick()
    assert posted(out, "NAV_X") == [7.0]
    assert posted(out, "NAV_X_SOURCE") == ["LSQ"]


def test_nav_heading_follows_ins_yaw() -> None:
    h = Harness()
    h.sensor("INS_YAW", -math.pi / 2)
    out = h.tick()
    assert posted(out, "NAV_YAW") == [pytest.approx(-math.pi / 2)]
    assert posted(out, "NAV_HEADING") == [pytest.approx(90.0)]
    h.sensor("INS_YAW", math.radians(30))
    assert posted(h.tick(), "NAV_HEADING") == [pytest.approx(330.0)]


def test_heading_queue_posts_yaw_too() -> None:
    h = Harness("ProcessConfig = pNav\n{\n  Heading = INS @ 1, GPS @ 2\n}\n")
    h.sensor("INS_HEADING", 450.0)
    out = h.tick()
    assert posted(out, "NAV_HEADING") == [pytest.approx(90.0)]
    assert posted(out, "NAV_YAW") == [pytest.approx(-math.pi / 2)]
    assert posted(out, "NAV_HEADING_SOURCE") == ["INS"]


def test_source_named_after_the_key_accepts_the_plain_variable() -> None:
    h = Harness()
    h.sensor("DEPTH", 4.5)
    assert posted(h.tick(), "NAV_DEPTH") == [4.5]
    h.sensor("DEPTH_DEPTH", 4.6)
    assert posted(h.tick(), "NAV_DEPTH") == [4.6]


def test_strings_and_non_finite_values_are_not_navigation() -> None:
    h = Harness()
    h.sensor("GPS_X", "12")
    h.sensor("GPS_Y", math.nan)
    out = h.tick()
    assert posted(out, "NAV_X") == [] and posted(out, "NAV_Y") == []


def test_first_iterate_announces_none() -> None:
    out = Harness().tick()
    assert {m.name: m.value for m in out if m.name.endswith("_SOURCE")} == {
        "NAV_X_SOURCE": "NONE",
        "NAV_Y_SOURCE": "NONE",
        "NAV_DEPTH_SOURCE": "NONE",
        "NAV_YAW_SOURCE": "NONE",
        "NAV_SPEED_SOURCE": "NONE",
    }


def nav_error(body: str) -> MissionError:
    text = "LatOrigin = 1\nProcessConfig = pNav\n{\n" + body + "\n}\n"
    with pytest.raises(MissionError) as info:
        Navigator.from_mission(Bus(SimClock()), parse_mission(text, "n.moos"))
    return info.value


@pytest.mark.parametrize(
    ("body", "line", "words"),
    [
        ("  X = GPS\n  Frobnicate = 3", 5, "unknown setting 'Frobnicate' for pNav (known: X, Y,"),
        ("  X = GPS\n  SENSOR_GPS = GPS->GPS_X @ 0,0,0 ~ 3", 5,
         "unknown setting 'SENSOR_GPS' for pNav (known: X"),
        ("  X = GPS\n  EKF_LAG = 5", 5, "EKF_LAG must be a number in [0, 4], got 5"),
        ("  X = GPS\n  SENSOR_RANGE = RNG -> uwb", 5, "needs BEACON lines"),
        ("  X = GPS\n  BEACON = 1 @ 0,0,0", 5, "BEACON without any SENSOR_* line"),
        ("  X = GPS\n  SENSOR_XY = GPS -> a\n  SENSOR_RANGE = R -> a\n  BEACON = 1 @ 0,0", 6,
         "sensor name 'a' is declared twice"),
        ("  X = GPS\n  SENSOR_XY = GPS -> a\n  EKF_X = 4", 6, "give both EKF_X and EKF_Y"),
        ("  X = GPS\n  SENSOR_XY = GPS -> a\n  EKF_TIDE = true", 6, "EKF_TIDE needs a DEPTH"),
        ("  X = GPS\n  SENSOR_RANGE = R -> r\n  BEACON = 1 @ 0,0\n  BEACON = 1 @ 5,0", 7,
         "BEACON 1 is declared twice"),
        ("  X = GPS\n  SENSOR_XY = GPS -> a\n  LSQ_REJECTION = a @ 8, 2", 6,
         "LSQ_REJECTION names 'a', which is not a declared LBL or RANGE sensor"),
        ("  X = GPS\n  SENSOR_LBL = L -> l ~ 0.001, 0.002", 5, "at most 1 noise value(s) (s)"),
        ("  X = GPS\n  SENSOR_XY = G -> g @ 0,0,0,400", 5,
         "SENSOR_XY twist (deg) must be a number in [-180, 360], got 400"),
        ("  X = GPS\n  BEACON = 1 @ 0,0,0 TAT 0.2", 5, "write the turn-around as TAT=seconds"),
        ("  X = GPS\n  AppTicks = 10", 5, "unknown setting 'AppTicks' for pNav"),
        ("  X = GPS @ later", 4, "timeout of GPS"),
        ("  X = GPS\n  x = EKF", 5, "x is already set at line 4; give each setting once"),
        ("  X = GPS @ nan", 4, "the timeout of GPS must be seconds in (0, 3600], got 'nan'"),
        ("  X = GPS @ 1e9", 4, "the timeout of GPS must be seconds in (0, 3600], got '1e9'"),
        ("  Yaw = INS\n  Heading = GPS", 5, "not both"),
        ("  // no queue", 2, "at least one priority queue"),
    ],
)
def test_configuration_errors_are_located(body: str, line: int, words: str) -> None:
    err = nav_error(body)
    assert (err.file, err.line) == ("n.moos", line)
    assert words in err.reason


def test_mission_without_pnav_is_an_error() -> None:
    with pytest.raises(MissionError) as info:
        Navigator.from_mission(Bus(SimClock()), parse_mission("A = 1\n", "z.moos"))
    assert "pNav" in str(info.value) and info.value.file == "z.moos"


@pytest.mark.parametrize("lines, scaled", [
    ("SENSOR_ORIENTATION = ODOM -> heading ~ 2\n   SENSOR_BODY_VEL = ODOM -> odometry ~ 0.05, "
     "0.1, 1", True),  # the odometer's own heading: its yaw rate integrated
    ("SENSOR_ORIENTATION = ODOM -> heading ~ 2\n   SENSOR_BODY_VEL = ODOM -> odometry ~ 0.05, "
     "0.1, 1\n   EKF_YAW_SCALE = false", False),
    ("SENSOR_ORIENTATION = HDG -> compass ~ 2\n   SENSOR_BODY_VEL = INS -> gyro ~ 0.5", False),
])
def test_the_yaw_scale_state_where_the_heading_is_a_body_velocity_sensors_own(
        lines: str, scaled: bool) -> None:
    text = ("ProcessConfig = pNav\n{\n   X = EKF @ 2\n   SENSOR_XY = GPS -> gps ~ 2\n   "
            + lines + "\n   EKF_YAW_BIAS = true\n}\n")
    fusion = Harness(text).nav.fusion
    assert fusion is not None and fusion.config.ekf.estimate_yaw_scale is scaled
