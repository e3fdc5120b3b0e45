"""pNav's sensor declarations (spec 2.2.1) and how bus variables become observations.

A mission declares each sensor once, in the pNav block::

    SENSOR_XY          = GPS  -> gps       @ 0,1.5,2        ~ 2.0
    SENSOR_ORIENTATION = INS  -> compass   @ 0,0,0, 3.0     ~ 2.0
    SENSOR_BODY_VEL    = DVL  -> dvl       @ 0,2,-0.5       ~ 0.02, 0.02
    SENSOR_RANGE       = RNG  -> uwb       @ 0,0,1          ~ 0.3
    SENSOR_LBL         = LBL  -> lbl       @ 0,0,-0.5       ~ 0.0005
    SENSOR_DEPTH       = DEPTH -> pressure @ 0,0,0          ~ 0.05

Read it as: a sensor of that type, whose data arrive as ``<source>_*`` bus variables, named
``name`` (in logs), mounted at ``x,y,z`` in body coordinates (MOOS: x starboard, y forward,
z up; metres) and turned by ``twist`` degrees clockwise about the body z axis, with 1-σ noise.

What each type reads (``S`` is the source) and the unit of its noise:

============  ==========================================================  ================
XY            ``S_X``, ``S_Y`` posted with the same time stamp (m); with     m
              them ``S_AGE`` (s), if posted: how old the fix was on arrival
ORIENTATION   ``S_YAW`` (rad, yaw = −heading), else ``S_HEADING`` (deg); with    deg
              them ``S_AGE`` (s), if posted: how old the heading was on arrival
DEPTH         ``S_DEPTH`` (m below the surface)                              m
ALTITUDE      ``S_ALTITUDE`` (m above the bottom; not fused: no seabed       m
              model, passed on as ``EKF_ALTITUDE`` of the vehicle's origin)
BODY_VEL      ``S_VX_BODY`` forward, ``S_VY_BODY`` starboard (m/s),          m/s, m/s, deg/s
              ``S_YAW_VEL`` (rad/s); any of them, same time stamp
LBL           ``S_TWTT_<beacon>``: two-way travel time (s, turn-around       s
              included) stamped with the ping time
RANGE         ``S_RANGE_<beacon>`` (m)                                       m
============  ==========================================================  ================

The serial instruments (``iSerial_*``) and the MAVLink bridge (``GPS_*``, ``INS_*``, ``AP_*``,
``WHEEL_*``) already post these names. Beacons are declared in the same block
(``BEACON = id @ x,y,z [TAT=s]``, the turn-around time of an acoustic transponder) and fixed
observations (spec 2.2.8) as ``FIXEDDEPTH``/``FIXEDHEADING``/``FIXEDTIDE = value @ sigma``,
and ``FIXEDSIDESLIP = 0 @ sigma`` (m/s) for a hull that moves along its bow.

An acoustic two-way travel time is explained as a range at the middle of its flight: the mean
of the outbound and return slant ranges (c·(twtt − turn-around)/2) equals, for a vehicle moving
straight and steadily, the range from its position half-way through the flight, so it is
stamped ``ping time + twtt/2``. That is why it arrives seconds old and needs ``EKF_LAG``.

Pure logic: :class:`SensorReader` turns one tick's mail into observations; no clock, no I/O.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, ClassVar, Final

from mavhelm.core.bus import Message
from mavhelm.core.geodesy import heading_to_yaw
from mavhelm.core.mission import Entry
from mavhelm.core.params import Alias, Kind, Number, Param
from mavhelm.nav.ekf import (
    Beacon,
    BodyVelocity,
    Depth,
    Lever,
    Observation,
    Position,
    Range,
    Tide,
    Yaw,
)

MAX_FIX_AGE: Final = 1.0
"""s: an XY fix's or a heading's ``S_AGE`` beyond this (or below 0) is not believed; the
reading is taken as stamped. Moving it on by more than a second of dead reckoning would add
its error, and a GPS_RAW_INT older than this is a time_usec on another clock (the bridge
posts no age)."""

SENSOR_TYPES: Final = ("XY", "ORIENTATION", "DEPTH", "ALTITUDE", "BODY_VEL", "LBL", "RANGE")

NOISE_UNITS: Final = {"XY": ("m",), "ORIENTATION": ("deg",), "DEPTH": ("m",),
                      "ALTITUDE": ("m",), "BODY_VEL": ("m/s", "m/s", "deg/s"),
                      "LBL": ("s",), "RANGE": ("m",)}
"""Unit of each noise a sensor line may give (BODY_VEL: forward, starboard, yaw rate)."""

DEFAULT_NOISE: Final = {"XY": (3.0,), "ORIENTATION": (2.0,), "DEPTH": (0.1,),
                        "ALTITUDE": (0.1,), "BODY_VEL": (0.05, 0.1, 1.0),
                        "LBL": (0.001,), "RANGE": (1.0,)}
"""1-σ noise of a sensor line that gives none, in the units above. BODY_VEL's starboard
default is wider than its forward one: for wheel odometry the "does not crab" constraint."""

NOISE_MIN: Final = {"XY": (0.01,), "ORIENTATION": (0.01,), "DEPTH": (0.001,),
                    "ALTITUDE": (0.001,), "BODY_VEL": (0.001, 0.001, 0.01),
                    "LBL": (1e-6,), "RANGE": (0.001,)}
"""The least 1-σ a sensor line may claim, in the units above: finer than any such sensor
measures (1 cm GPS RTK, 0.01° a gyrocompass, 1 µs an LBL clock = 0.75 mm), and far enough
above zero that the filter's covariance stays positive in double precision."""

NOISE_MAX: Final = 1e4
"""The largest 1-σ a noise or fixed observation may give, in its unit."""


def noise_range(kind: str) -> str:
    """The accepted noises of a sensor type, for its line in the parameter reference."""
    return ", ".join(f"{lo:g}" for lo in NOISE_MIN[kind]) + f" to {NOISE_MAX:g} " + \
        ", ".join(NOISE_UNITS[kind])


def _sigma_kind(lo: float) -> Number:
    return Number(lo, NOISE_MAX)


LEVER_LIMIT: Final = 100.0
"""m: a lever arm longer than this is a typo, not a vessel."""

_SOURCE = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
_NAME = re.compile(r"[A-Za-z0-9_.\-]+")


@dataclass(frozen=True)
class SensorSpec:
    """One ``SENSOR_*`` line: type, source prefix, name, lever arm, twist (deg), noise."""

    type: str
    source: str
    name: str
    lever: Lever = (0.0, 0.0, 0.0)
    twist: float = 0.0
    noise: tuple[float, ...] = ()

    def sigma(self, k: int = 0) -> float:
        """The k-th noise in the declared unit, defaults filling what the line left out."""
        given = self.noise or DEFAULT_NOISE[self.type]
        return given[k] if k < len(given) else DEFAULT_NOISE[self.type][k]


def _numbers(text: str, entry: Entry, what: str, kind: Number) -> list[float]:
    return [kind.parse_text(part, entry, f"{entry.key} {what}") for part in text.split(",")]


@dataclass(frozen=True)
class SensorLine(Kind):
    """``SOURCE -> name @ x,y,z[,twist] [~ noise[,noise…]]`` for one sensor type."""

    type: str
    label: ClassVar[str] = "SOURCE -> name @ x,y,z[,twist] ~ noise"

    def describe(self) -> str:
        units = ", ".join(NOISE_UNITS[self.type])
        return f"SOURCE -> name @ x,y,z[,twist deg] ~ noise ({units})"

    def check_value(self, value: Any) -> bool:
        return isinstance(value, SensorSpec)

    def parse(self, entry: Entry) -> SensorSpec:
        text = entry.value.replace("→", "->")
        head, arrow, rest = text.partition("->")
        source = head.strip()
        if not arrow or not _SOURCE.fullmatch(source):
            raise entry.error(f"{entry.key} expects {self.describe()}, got {entry.value!r}")
        rest, tilde, noise_text = rest.partition("~")
        name, at, geometry = (part.strip() for part in rest.partition("@"))
        if not _NAME.fullmatch(name):
            raise entry.error(f"{entry.key}: the sensor needs a one-word name after '->', "
                              f"got {name!r}")
        lever: Lever = (0.0, 0.0, 0.0)
        twist = 0.0
        if at:
            texts = geometry.split(",")
            if len(texts) not in (3, 4):
                raise entry.error(f"{entry.key}: expected x,y,z[,twist] after '@', "
                                  f"got {geometry!r}")
            values = _numbers(",".join(texts[:3]), entry, "lever arm",
                              Number(-LEVER_LIMIT, LEVER_LIMIT))
            lever = (values[0], values[1], values[2])
            if len(texts) == 4:
                twist = Number(-180.0, 360.0).parse_text(texts[3], entry,
                                                         f"{entry.key} twist (deg)")
        noise: tuple[float, ...] = ()
        if tilde:
            units = NOISE_UNITS[self.type]
            texts = noise_text.split(",")
            if len(texts) > len(units):
                raise entry.error(f"{entry.key}: at most {len(units)} noise value(s) "
                                  f"({', '.join(units)}), got {len(texts)}")
            noise = tuple(_sigma_kind(lo).parse_text(text, entry, f"{entry.key} noise")
                          for text, lo in zip(texts, NOISE_MIN[self.type], strict=False))
        return SensorSpec(self.type, source.upper(), name, lever, twist, noise)


@dataclass(frozen=True)
class BeaconLine(Kind):
    """``id @ x,y,z [TAT=seconds]``: a range or LBL beacon at a surveyed position."""

    label: ClassVar[str] = "id @ x,y,z [TAT=s]"

    def describe(self) -> str:
        return "id @ x,y,z in metres (z up: seabed beacons negative) [TAT=turn-around s]"

    def check_value(self, value: Any) -> bool:
        return isinstance(value, Beacon)

    def parse(self, entry: Entry) -> Beacon:
        ident, at, rest = (part.strip() for part in entry.value.partition("@"))
        if not at or not _NAME.fullmatch(ident):
            raise entry.error(f"{entry.key} expects {self.describe()}, got {entry.value!r}")
        cut = rest.upper().find("TAT")
        rest, tat_text = (rest, "") if cut < 0 else (rest[:cut], rest[cut + 3:])
        values = _numbers(rest.rstrip().rstrip(","), entry, "position",
                          Number(-1e5, 1e5))
        if len(values) not in (2, 3):
            raise entry.error(f"{entry.key} expects x,y or x,y,z after '@', got {rest!r}")
        tat = 0.0
        if tat_text:
            tat_text = tat_text.strip()
            if not tat_text.startswith("="):
                raise entry.error(f"{entry.key}: write the turn-around as TAT=seconds")
            tat = Number(0.0, 10.0).parse_text(tat_text[1:], entry, f"{entry.key} TAT")
        return Beacon(ident, values[0], values[1], values[2] if len(values) == 3 else 0.0,
                      turnaround=tat)


@dataclass(frozen=True)
class FixedValue:
    """A fixed observation (spec 2.2.8): ``value @ sigma``."""

    value: float
    sigma: float


@dataclass(frozen=True)
class FixedLine(Kind):
    """``value @ sigma`` within the given range, sigma at least ``sigma_min`` (the unit's
    physical floor, as for a sensor's noise)."""

    value_kind: Number
    unit: str
    sigma_min: float

    def describe(self) -> str:
        return (f"value @ sigma ({self.unit}), value {self.value_kind.describe()}, "
                f"sigma {_sigma_kind(self.sigma_min).describe()}")

    def check_value(self, value: Any) -> bool:
        return value is None or isinstance(value, FixedValue)

    def parse(self, entry: Entry) -> FixedValue:
        value_text, at, sigma_text = entry.value.partition("@")
        if not at:
            raise entry.error(f"{entry.key} expects value @ sigma ({self.unit}), "
                              f"got {entry.value!r}")
        value = self.value_kind.parse_text(value_text, entry, entry.key)
        sigma = _sigma_kind(self.sigma_min).parse_text(sigma_text, entry, f"{entry.key} sigma")
        return FixedValue(value, sigma)


BEACON = Param("BEACON", BeaconLine(), [], repeat=True, attr="beacons",
               doc="a range or LBL beacon (TAT: its turn-around time)")
FIXEDDEPTH = Param("FIXEDDEPTH", FixedLine(Number(-1e4, 1e4), "m", 0.001), None,
                   attr="fixed_depth",
                   doc="an artificial depth observation every tick (a surface craft: 0 @ 0.1)")
FIXEDHEADING = Param("FIXEDHEADING", FixedLine(Number(-360.0, 360.0), "deg", 0.01), None,
                     attr="fixed_heading", doc="an artificial heading observation every tick")
FIXEDTIDE = Param("FIXEDTIDE", FixedLine(Number(-1e3, 1e3), "m", 0.001), None,
                  attr="fixed_tide", doc="an artificial tide observation every tick (pins "
                  "Z = 0 to the surface)")
FIXEDSIDESLIP = Param("FIXEDSIDESLIP", FixedLine(Number(-5.0, 5.0), "m/s", 0.001), None,
                      attr="fixed_sideslip", doc="an artificial starboard-speed observation "
                      "every tick: the hull moves along its bow (0 @ 0.3 for a boat in little "
                      "current); the EKF then also turns its velocity with the yaw rate (as "
                      "it does unasked with a heading sensor and no sensor giving a speed)")
LBL_SOUND_SPEED = Param("LBL_SOUND_SPEED", Number(1300.0, 1700.0), 1500.0, "m/s",
                        "speed of sound for LBL travel times", attr="sound_speed",
                        aliases=(Alias("SV"),))
SOUND_SPEED: Final = LBL_SOUND_SPEED.default
"""m/s: speed of sound in sea water, for LBL travel times."""


def fixed_observations(t: float, depth: FixedValue | None, heading: FixedValue | None,
                       tide: FixedValue | None, sideslip: FixedValue | None = None
                       ) -> list[Observation]:
    """The fixed observations declared, as observations at ``t``. ``sideslip`` (m/s) is the
    hull's "does not crab" constraint: the spec's model leaves velocity and heading uncoupled
    (2.2.3), which on ranges alone lets the velocity lag seconds behind a turn; a boat's or a
    wheeled robot's velocity points along its bow to within its leeway, and saying so couples
    the compass into the track."""
    out: list[Observation] = []
    if sideslip is not None:
        out.append(BodyVelocity(t, None, sideslip.value, None, sigma_starboard=sideslip.sigma))
    if depth is not None:
        out.append(Depth(t, depth.value, depth.sigma))
    if heading is not None:
        out.append(Yaw(t, heading_to_yaw(heading.value), math.radians(heading.sigma)))
    if tide is not None:
        out.append(Tide(t, tide.value, tide.sigma))
    return out


@dataclass(frozen=True)
class Reading:
    """An observation and the sensor it came from (for logs and per-channel rejection);
    ``channel`` is the beacon for LBL and RANGE sensors."""

    sensor: SensorSpec
    obs: Observation
    channel: str = ""
    raw: float = math.nan
    age: float = 0.0
    """How old an XY fix or a heading already was when stamped (s, ``S_AGE``: the bridge's
    GPS_AGE, INS_AGE): the filter moves it on by this along its velocity or turn rate
    (:meth:`Fusion._brought_forward`)."""


POSITION_TYPES: Final = frozenset({"XY", "LBL", "RANGE"})
"""Sensor types whose data fix the position: against them a body velocity's scale shows."""


def integrated_sources(sensors: Iterable[SensorSpec]) -> set[str]:
    """Sources that give a heading and a body velocity both: that heading is the body
    velocity's yaw rate integrated (an odometer, a gyro), and shares its scale error."""
    sensors = list(sensors)
    headings = {s.source for s in sensors if s.type == "ORIENTATION"}
    return {s.source for s in sensors if s.type == "BODY_VEL" and s.source in headings}


class SensorReader:
    """Turns a tick's mail into :class:`Reading`\\ s for the declared sensors.

    Components that belong together (an XY fix's X and Y, a body velocity's parts) are joined
    by time stamp within one tick's mail, which is how every reader posts them; a lone half
    is counted in ``incomplete`` and dropped. Non-finite values are counted in ``bad``.
    ALTITUDE readings are returned in ``altitudes`` (not fused).
    """

    def __init__(self, sensors: Iterable[SensorSpec], beacons: Iterable[Beacon],
                 sound_speed: float = SOUND_SPEED) -> None:
        self.sensors = list(sensors)
        self.beacons = {b.name: b for b in beacons}
        self.sound_speed = sound_speed
        self.incomplete = 0
        self.bad = 0
        self._routes: dict[str, list[tuple[SensorSpec, str, str]]] = {}
        self._by_id = {id(s): s for s in self.sensors}
        self._integrated = integrated_sources(self.sensors)
        for sensor in self.sensors:
            for variable, part, channel in self._variables(sensor):
                self._routes.setdefault(variable, []).append((sensor, part, channel))

    def _variables(self, sensor: SensorSpec) -> list[tuple[str, str, str]]:
        s = sensor.source
        if sensor.type == "XY":
            return [(f"{s}_X", "x", ""), (f"{s}_Y", "y", ""), (f"{s}_AGE", "age", "")]
        if sensor.type == "ORIENTATION":
            return [(f"{s}_YAW", "yaw", ""), (f"{s}_HEADING", "heading", ""),
                    (f"{s}_AGE", "age", "")]
        if sensor.type == "DEPTH":
            return [(f"{s}_DEPTH", "depth", "")]
        if sensor.type == "ALTITUDE":
            return [(f"{s}_ALTITUDE", "altitude", "")]
        if sensor.type == "BODY_VEL":
            return [(f"{s}_VX_BODY", "forward", ""), (f"{s}_VY_BODY", "starboard", ""),
                    (f"{s}_YAW_VEL", "yaw_rate", "")]
        suffix = "TWTT" if sensor.type == "LBL" else "RANGE"
        return [(f"{s}_{suffix}_{b}", suffix.lower(), b) for b in self.beacons]

    def subscriptions(self) -> set[str]:
        return set(self._routes)

    def read(self, mail: Iterable[Message]) -> tuple[list[Reading], list[tuple[float, float]]]:
        """Readings of this mail, and the altitudes heard as (time, altitude of the origin)."""
        parts: dict[tuple[int, float], dict[str, float]] = {}
        readings: list[Reading] = []
        altitudes: list[tuple[float, float]] = []
        for msg in mail:
            routes = self._routes.get(msg.name)
            value, t = msg.value, msg.time
            if not routes or isinstance(value, str):
                continue
            if not math.isfinite(value):
                self.bad += 1
                continue
            for sensor, part, channel in routes:
                if sensor.type in ("LBL", "RANGE"):
                    reading = self._ranging(sensor, channel, value, t)
                    if reading is not None:
                        readings.append(reading)
                elif sensor.type == "ALTITUDE":
                    altitudes.append((t, value - sensor.lever[2]))
                else:
                    parts.setdefault((id(sensor), t), {})[part] = value
        for (key, t), values in parts.items():
            reading = self._joined(self._by_id[key], t, values)
            if reading is not None:
                readings.append(reading)
        readings.sort(key=lambda r: r.obs.t)
        return readings, altitudes

    def _ranging(self, sensor: SensorSpec, beacon: str, value: float,
                 t: float) -> Reading | None:
        if value <= 0:
            self.bad += 1
            return None
        if sensor.type == "RANGE":
            return Reading(sensor, Range(t, beacon, value, sensor.sigma(), sensor.lever),
                           beacon, value)
        c = self.sound_speed
        flight = value - self.beacons[beacon].turnaround
        if flight <= 0:
            self.bad += 1
            return None
        obs = Range(t + value / 2.0, beacon, c * flight / 2.0, c * sensor.sigma() / 2.0,
                    sensor.lever)
        return Reading(sensor, obs, beacon, value)

    def _joined(self, sensor: SensorSpec, t: float, values: dict[str, float]) -> Reading | None:
        if sensor.type == "XY":
            if "x" not in values or "y" not in values:
                self.incomplete += 1
                return None
            age = values.get("age", 0.0)
            return Reading(sensor, Position(t, values["x"], values["y"], sensor.sigma(),
                                            sensor.lever),
                           age=age if 0.0 <= age <= MAX_FIX_AGE else 0.0)
        if sensor.type == "ORIENTATION":
            if "yaw" in values:
                yaw = values["yaw"]
            elif "heading" in values:
                yaw = heading_to_yaw(values["heading"])
            else:
                self.incomplete += 1  # an age without its heading
                return None
            yaw += math.radians(sensor.twist)  # the sensor reads the heading of its own axis
            age = values.get("age", 0.0)
            return Reading(sensor, Yaw(t, math.remainder(yaw, 2 * math.pi),
                                       math.radians(sensor.sigma())),
                           age=age if 0.0 <= age <= MAX_FIX_AGE else 0.0)
        if sensor.type == "DEPTH":
            return Reading(sensor, Depth(t, values["depth"], sensor.sigma(), sensor.lever))
        forward, starboard = values.get("forward"), values.get("starboard")
        if sensor.twist and forward is not None and starboard is not None:
            # the sensor's axes are turned by twist (clockwise) from the body's
            a = math.radians(sensor.twist)
            forward, starboard = (forward * math.cos(a) - starboard * math.sin(a),
                                  forward * math.sin(a) + starboard * math.cos(a))
        return Reading(sensor, BodyVelocity(
            t, forward, starboard, values.get("yaw_rate"), sensor.sigma(0), sensor.sigma(1),
            math.radians(sensor.sigma(2)), sensor.lever, sensor.source in self._integrated))

