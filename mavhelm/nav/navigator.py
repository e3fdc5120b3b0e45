"""pNav on the bus: sensors through the filters, and priority queues into ``NAV_*`` (spec 2).

For queue key ``K`` and source ``S`` the input is the variable ``S_K`` (``GPS_X``, ``INS_YAW``,
``AP_SPEED``); when the source is named after the key (``Depth = DEPTH @ 1``) the plain ``DEPTH``
is accepted as well as ``DEPTH_DEPTH``. The output is ``NAV_K`` stamped with the sensor's time.

The filters (spec 2.2) run when the block declares sensors (``SENSOR_*``, see
:mod:`mavhelm.nav.sensors`): each tick the readings go through :class:`~mavhelm.nav.fusion.Fusion`
and its estimate is offered to the queues as the sources ``EKF`` and ``LSQ`` (``EKF_X``,
``EKF_YAW``, ``EKF_SPEED``, ``LSQ_X`` …, also posted on the bus), exactly as if a sensor had
posted them: ``X = GPS @ 2, EKF @ 2.5, LSQ @ 5`` falls back and pops back as spec 2.1 says.

Only fresh values are forwarded, once each: when every source of a key is stale, ``NAV_K`` goes
quiet instead of repeating the last value, so the helm's tasks starve and stop the vehicle
rather than steering on a position that is no longer true.

A navigation failure (spec 2.2.11: the EKF's uncertainty limit, or no LSQ fix within
``LSQ_TIMEOUT``) takes the filters off-line and posts ``NAVIGATION_FAILURE`` (why) and
``EndMission``, which starts every EndMission task of the helm. Filter warnings (rate resets,
boots, re-initialisations) are posted as ``NAV_WARNING``. The .olog/.xlog lines go to an
injected ``NavLogSink`` (the companion writes files; a replay may keep them in memory).
"""

from __future__ import annotations

import math
from typing import Final, Protocol

from mavhelm.core.app import App
from mavhelm.core.bus import Bus, Message
from mavhelm.core.geodesy import heading_to_yaw, yaw_to_heading
from mavhelm.core.mission import Block, Entry, Mission, MissionError
from mavhelm.core.names import END_MISSION, NAVIGATION_FAILURE, NO_SOURCE
from mavhelm.core.params import Boolean, Number, Param, Schema, Seconds, Text, Word
from mavhelm.nav.ekf import EKFConfig, Estimate
from mavhelm.nav.fusion import Fusion, FusionConfig, Start
from mavhelm.nav.priority_queue import PriorityQueue, QueueSpec
from mavhelm.nav.sensor_channel import RejectionLine
from mavhelm.nav.sensors import (
    SENSOR_TYPES,
    SOUND_SPEED,
    BeaconLine,
    FixedLine,
    SensorLine,
    SensorReader,
    SensorSpec,
)

QUEUE_KEYS: Final = (
    "X",
    "Y",
    "Z",
    "DEPTH",
    "YAW",
    "PITCH",
    "ROLL",
    "SPEED",
    "ALTITUDE",
    "HEADING",
    "X_VEL",
    "Y_VEL",
    "Z_VEL",
    "YAW_VEL",
)
"""Keys of a pNav block that are priority queues. YAW is radians (yaw = −heading), HEADING
degrees clockwise from north; configure one of the two, the navigator posts both. Velocities
are in earth coordinates (spec 2)."""

_DYNAMICS = Number(0.0, 10.0)
_SIGMA = Number(0.0, 1e5, lo_open=True)

NAV_SCHEMA = Schema(
    "pNav",
    (*(Param(key.title(), QueueSpec(), None, doc=f"priority queue feeding NAV_{key}",
             attr=key.lower()) for key in QUEUE_KEYS),
     *(Param(f"SENSOR_{kind}", SensorLine(kind), [], repeat=True,
             attr=f"sensor_{kind.lower()}",
             doc=f"a {kind} sensor for the filters (spec 2.2.1)") for kind in SENSOR_TYPES),
     Param("BEACON", BeaconLine(), [], repeat=True, attr="beacons",
           doc="a range or LBL beacon (TAT: its turn-around time)"),
     Param("FIXEDDEPTH", FixedLine(Number(-1e4, 1e4), "m"), None, attr="fixed_depth",
           doc="an artificial depth observation every tick (a surface craft: 0 @ 0.1)"),
     Param("FIXEDHEADING", FixedLine(Number(-360.0, 360.0), "deg"), None,
           attr="fixed_heading", doc="an artificial heading observation every tick"),
     Param("FIXEDTIDE", FixedLine(Number(-1e3, 1e3), "m"), None, attr="fixed_tide",
           doc="an artificial tide observation every tick (pins Z = 0 to the surface)"),
     Param("FIXEDSIDESLIP", FixedLine(Number(-5.0, 5.0), "m/s"), None,
           attr="fixed_sideslip", doc="an artificial starboard-speed observation every tick: "
           "the hull moves along its bow (0 @ 0.3 for a boat in little current); the EKF "
           "then also turns its velocity with the yaw rate"),
     Param("EKF_X", Number(-1e5, 1e5), None, "m", "EKF start X (with EKF_Y; else the LSQ or "
           "the first XY fix starts it)", attr="ekf_x"),
     Param("EKF_Y", Number(-1e5, 1e5), None, "m", "EKF start Y", attr="ekf_y"),
     Param("EKF_Z", Number(-1e4, 1e4), 0.0, "m", "EKF start Z (up)", attr="ekf_z"),
     Param("EKF_HEADING", Number(-360.0, 360.0), None, "deg",
           "EKF start heading (default: the first orientation reading, else unknown)",
           attr="ekf_heading"),
     Param("EKF_SIGMA_XY", _SIGMA, 30.0, "m", "1-σ of the start position", attr="ekf_sigma_xy"),
     Param("EKF_SIGMA_HEADING", Number(0.0, 360.0, lo_open=True), 90.0, "deg",
           "1-σ of the start heading", attr="ekf_sigma_heading"),
     Param("EKF_SIGMA_Z", _SIGMA, 10.0, "m", "1-σ of the start Z", attr="ekf_sigma_z"),
     Param("EKF_XY_DYNAMICS", _DYNAMICS, 5.0, "", "0 (never changes) to 10 (very mobile)",
           attr="ekf_xy_dynamics"),
     Param("EKF_YAW_DYNAMICS", _DYNAMICS, 5.0, "", "0 to 10, as above, for yaw",
           attr="ekf_yaw_dynamics"),
     Param("EKF_Z_DYNAMICS", _DYNAMICS, 5.0, "", "0 to 10, as above, for Z",
           attr="ekf_z_dynamics"),
     Param("EKF_MOBILE", Boolean(), True, "", "false: a static vehicle (no rate states)",
           attr="ekf_mobile"),
     Param("EKF_LAG", Number(0.0, 4.0), 0.0, "s", "run the EKF this far behind time "
           "(spec 2.2.7; the LBL listen window)", attr="ekf_lag"),
     Param("EKF_YAW_BIAS", Boolean(), False, "", "estimate the orientation sensors' heading "
           "bias (needs a BODY_VEL and a position sensor, spec 2.2.10)", attr="ekf_yaw_bias"),
     Param("EKF_TIDE", Boolean(), False, "", "estimate the tide (needs depth and beacon "
           "ranges, or FIXEDTIDE)", attr="ekf_tide"),
     Param("EKF_RANGE_SCALE", Boolean(), True, "", "learn a range scale error shared by "
           "every beacon (sound speed, clock rate)", attr="ekf_range_scale"),
     Param("EKF_BEACON_OFFSETS", Boolean(), True, "", "learn each beacon's range offset "
           "(false: offsets held at zero)", attr="ekf_beacon_offsets"),
     Param("EKF_GATE", Number(0.9, 0.999999), 0.999, "", "χ² acceptance probability of the "
           "data rejection", attr="ekf_gate"),
     Param("EKF_MAX_SIGMA_XY", Number(1.0, 1e5), 100.0, "m", "position 1-σ beyond this is a "
           "navigation failure", attr="ekf_max_sigma_xy"),
     Param("EKF_MAX_SPEED", Number(0.1, 100.0), 10.0, "m/s", "speed states beyond this are "
           "reset", attr="ekf_max_speed"),
     Param("LSQ", Boolean(), True, "", "run the LSQ on beacon ranges (boots and watches the "
           "EKF)", attr="lsq"),
     Param("LSQ_WINDOW", Number(0.5, 60.0), 5.0, "s", "ranges older than this are not "
           "combined into a fix", attr="lsq_window"),
     Param("LSQ_TIMEOUT", Seconds(3600.0), 30.0, "s", "no LSQ fix for this long is a "
           "navigation failure (NEVER: never)", attr="lsq_timeout"),
     Param("LSQ_OFFSET", Boolean(), False, "", "solve a common range offset too (needs a "
           "fourth beacon)", attr="lsq_offset"),
     Param("LSQ_REJECTION", RejectionLine(), [], repeat=True, attr="lsq_rejection",
           doc="consensus outlier rejection on a ranging sensor's channels (spec 2.2.6)"),
     Param("LSQ_DIVERGENCE", Number(1.0, 1e4), 20.0, "m", "an LSQ fix this far from the EKF "
           "is a disagreement; 6 in a row re-initialise the EKF", attr="lsq_divergence"),
     Param("LBL_SOUND_SPEED", Number(1300.0, 1700.0), SOUND_SPEED, "m/s",
           "speed of sound for LBL travel times", attr="sound_speed"),
     Param("NAV_LOG", Boolean(), True, "", "write the .olog and .xlog when filters run",
           attr="nav_log"),
     Param("NAV_LOG_PATH", Text(), None, "", "folder of the nav logs (default: the alog's)",
           attr="nav_log_path"),
     Param("NAV_LOG_STEM", Word(), "pNav", "", "file name stem of the nav logs",
           attr="nav_log_stem"),
     Param("NAV_LOG_TIMESTAMP", Boolean(), True, "", "put the creation time in the file "
           "names", attr="nav_log_timestamp"),
     ),
)
"""A pNav block: its priority queues, its sensors, and the filters' settings."""


class NavLogSink(Protocol):
    """Where the .olog and .xlog lines go (spec 2.2.5)."""

    def olog(self, lines: list[str]) -> None: ...

    def xlog(self, lines: list[str]) -> None: ...


def _entry(block: Block, *keys: str) -> Entry:
    """The last entry of the block with one of ``keys`` (where a cross-check points)."""
    wanted = {k.lower() for k in keys}
    found = [e for e in block.entries if e.key.lower() in wanted]
    return found[-1] if found else Entry(keys[0], "", block.file, block.line)


def fusion_from_settings(settings: dict, block: Block) -> tuple[list[SensorSpec], Fusion] | None:
    """The filters a pNav block asks for, or None when it declares no sensor."""
    sensor_keys = [f"SENSOR_{kind}" for kind in SENSOR_TYPES]
    sensors = [spec for kind in SENSOR_TYPES for spec in settings[f"sensor_{kind.lower()}"]]
    if not sensors:
        for key in ("BEACON", "LSQ_REJECTION"):
            if settings[key.lower() if key != "BEACON" else "beacons"]:
                raise _entry(block, key).error(f"{key} without any SENSOR_* line: declare "
                                               "the sensors the filters read")
        return None
    names = [s.name for s in sensors]
    seen: set[str] = set()
    for entry in block.entries:
        if entry.key.upper() in sensor_keys:
            name = entry.value.replace("→", "->").partition("->")[2].split("@")[0]
            name = name.split("~")[0].strip()
            if name in seen:
                raise entry.error(f"sensor name {name!r} is declared twice; name each sensor "
                                  "once")
            seen.add(name)
    beacons = settings["beacons"]
    ids: set[str] = set()
    for entry, beacon in zip([e for e in block.entries if e.key.upper() == "BEACON"], beacons,
                             strict=True):
        if beacon.name in ids:
            raise entry.error(f"BEACON {beacon.name} is declared twice")
        ids.add(beacon.name)
    ranging = [s for s in sensors if s.type in ("LBL", "RANGE")]
    if ranging and not beacons:
        raise _entry(block, f"SENSOR_{ranging[0].type}").error(
            f"SENSOR_{ranging[0].type} {ranging[0].name} needs BEACON lines (id @ x,y,z)")
    for rule in settings["lsq_rejection"]:
        if rule.sensor not in {s.name for s in ranging}:
            raise _entry(block, "LSQ_REJECTION").error(
                f"LSQ_REJECTION names {rule.sensor!r}, which is not a declared LBL or RANGE "
                f"sensor (sensors: {', '.join(names)})")
    if (settings["ekf_x"] is None) != (settings["ekf_y"] is None):
        raise _entry(block, "EKF_X", "EKF_Y").error(
            "give both EKF_X and EKF_Y (the EKF's start) or neither")
    has_depth = any(s.type == "DEPTH" for s in sensors) or settings["fixed_depth"] is not None
    if settings["ekf_tide"] and not has_depth:
        raise _entry(block, "EKF_TIDE").error(
            "EKF_TIDE needs a DEPTH sensor or FIXEDDEPTH (depth = tide − Z)")
    if settings["fixed_tide"] is not None and not settings["ekf_tide"]:
        raise _entry(block, "FIXEDTIDE").error("FIXEDTIDE needs EKF_TIDE = true")
    ekf = EKFConfig(
        xy_dynamics=settings["ekf_xy_dynamics"], yaw_dynamics=settings["ekf_yaw_dynamics"],
        z_dynamics=settings["ekf_z_dynamics"], sigma_xy=settings["ekf_sigma_xy"],
        sigma_yaw=math.radians(settings["ekf_sigma_heading"]),
        estimate_yaw_bias=settings["ekf_yaw_bias"],
        estimate_range_scale=settings["ekf_range_scale"],
        beacon_offset_noise=1e-3 if settings["ekf_beacon_offsets"] else 0.0,
        sigma_beacon_offset=5.0 if settings["ekf_beacon_offsets"] else 1e-6,
        gate_probability=settings["ekf_gate"],
        max_speed=settings["ekf_max_speed"], max_position_sigma=settings["ekf_max_sigma_xy"],
        mobile=settings["ekf_mobile"], estimate_z=has_depth,
        sigma_z=settings["ekf_sigma_z"], estimate_tide=settings["ekf_tide"],
        velocity_follows_heading=settings["fixed_sideslip"] is not None)
    start = None
    if settings["ekf_x"] is not None:
        heading = settings["ekf_heading"]
        start = Start(settings["ekf_x"], settings["ekf_y"],
                      0.0 if heading is None else heading_to_yaw(heading),
                      settings["ekf_sigma_xy"],
                      math.pi if heading is None else math.radians(
                          settings["ekf_sigma_heading"]), z=settings["ekf_z"])
    config = FusionConfig(
        ekf=ekf, beacons=tuple(beacons), lag=settings["ekf_lag"], start=start,
        lsq=settings["lsq"], lsq_window=settings["lsq_window"],
        lsq_timeout=settings["lsq_timeout"], lsq_offset=settings["lsq_offset"],
        divergence_distance=settings["lsq_divergence"],
        fixed_depth=settings["fixed_depth"], fixed_heading=settings["fixed_heading"],
        fixed_tide=settings["fixed_tide"], fixed_sideslip=settings["fixed_sideslip"],
        rejection=tuple(settings["lsq_rejection"]))
    return sensors, Fusion(config)


_UNSET: Final = object()


class Navigator(App):
    """Forwards the best live source of each NAV key; says which source that is; runs the
    filters when sensors are declared."""

    name = "pNav"

    def __init__(self, bus: Bus, queues: list[PriorityQueue], *,
                 sensors: list[SensorSpec] | None = None, fusion: Fusion | None = None,
                 sound_speed: float = SOUND_SPEED, log: NavLogSink | None = None,
                 log_settings: dict | None = None) -> None:
        super().__init__(bus)
        keys = [q.key for q in queues]
        if len(set(keys)) != len(keys):
            raise ValueError(f"duplicate priority queue keys in {keys}")
        if "YAW" in keys and "HEADING" in keys:
            raise ValueError("configure a Yaw queue or a Heading queue, not both")
        self.queues = list(queues)
        self._inputs: dict[str, list[tuple[PriorityQueue, str]]] = {}
        for queue in self.queues:
            for source in queue.sources:
                names = {f"{source.name}_{queue.key}"}
                if source.name == queue.key:
                    names.add(source.name)
                for name in names:
                    self._inputs.setdefault(name, []).append((queue, source.name))
        self._announced: dict[str, object] = {q.key: _UNSET for q in self.queues}
        self._subscriptions: frozenset[str] | None = None
        self.fusion = fusion
        self.reader = (SensorReader(sensors or [], fusion.config.beacons, sound_speed)
                       if fusion is not None else None)
        self._log: NavLogSink | None = None
        self.log = log
        self.log_settings = log_settings or {}
        self.failure_posted = False

    @classmethod
    def from_block(cls, bus: Bus, block: Block, log: NavLogSink | None = None) -> Navigator:
        """Build from a ``ProcessConfig = pNav`` block; every refusal is a located error."""
        settings = NAV_SCHEMA.read(block)
        if settings["yaw"] is not None and settings["heading"] is not None:
            later = max(block.require("Yaw"), block.require("Heading"), key=lambda e: e.line)
            raise later.error("configure a Yaw queue or a Heading queue, not both")
        queues = [settings[key.lower()] for key in QUEUE_KEYS if settings[key.lower()]]
        if not queues:
            raise block.error("pNav needs at least one priority queue, e.g. X = GPS @ 2.0")
        filters = fusion_from_settings(settings, block)
        sensors, fusion = filters if filters is not None else (None, None)
        log_settings = {k: settings[k] for k in ("nav_log", "nav_log_path", "nav_log_stem",
                                                 "nav_log_timestamp")}
        return cls(bus, queues, sensors=sensors, fusion=fusion,
                   sound_speed=settings["sound_speed"], log=log, log_settings=log_settings)

    @classmethod
    def from_mission(cls, bus: Bus, mission: Mission, log: NavLogSink | None = None
                     ) -> Navigator:
        """Build from the mission's ``ProcessConfig = pNav`` block, which must exist."""
        block = mission.process("pNav")
        if block is None:
            raise MissionError(mission.path, 0, "the mission has no ProcessConfig = pNav block")
        return cls.from_block(bus, block, log)

    @property
    def log(self) -> NavLogSink | None:
        """Where the .olog/.xlog lines go; None: they are not even formatted."""
        return self._log

    @log.setter
    def log(self, sink: NavLogSink | None) -> None:
        self._log = sink
        if self.fusion is not None:
            self.fusion.logging = sink is not None

    @property
    def wants_log(self) -> bool:
        return self.fusion is not None and bool(self.log_settings.get("nav_log", False))

    def subscriptions(self) -> frozenset[str]:
        if self._subscriptions is None:  # the queues and sensors are fixed once built
            subs = set(self._inputs)
            if self.reader is not None:
                subs |= self.reader.subscriptions()
            self._subscriptions = frozenset(subs)
        return self._subscriptions

    def on_mail(self, mail: list[Message], now: float) -> None:
        mail = [m for m in mail if m.source != self.name]  # own EKF_*/LSQ_* already routed
        for msg in mail:
            self._route(msg.name, msg, now)
        if self.reader is not None and self.fusion is not None:
            readings, altitudes = self.reader.read(mail)
            for reading in readings:
                self.fusion.add(reading, now)
            for t, altitude in altitudes:
                if self.fusion.online:
                    self._offer("EKF_ALTITUDE", altitude, t, now)

    def _route(self, name: str, msg: Message, now: float) -> None:
        routes = self._inputs.get(name)
        if not routes or not msg.is_double or not math.isfinite(msg.double):
            return
        for queue, source in routes:
            if now - msg.time > queue.timeout(source):
                continue
            if queue.offer(source, msg.double, msg.time):
                self._announce(queue.key, source)
                self._post(queue.key, msg.double, msg.time)

    def _offer(self, name: str, value: float, t: float, now: float) -> None:
        """Post a filter output and offer it to the queues, as a sensor's value would be."""
        if not math.isfinite(value):
            return
        self.notify(name, value, t)
        if name in self._inputs:
            self._route(name, Message(name, value, t, self.name), now)

    def iterate(self, now: float) -> None:
        if self.fusion is not None:
            self._run_filters(now)
        for queue in self.queues:
            self._announce(queue.key, queue.current_source(now))

    def _run_filters(self, now: float) -> None:
        fusion = self.fusion
        assert fusion is not None
        estimate = fusion.step(now)
        for fix in fusion.new_fixes:
            self._offer("LSQ_X", fix.x, fix.t, now)
            self._offer("LSQ_Y", fix.y, fix.t, now)
        if estimate is not None:
            self._publish(estimate, now)
        for warning in fusion.warnings:
            self.notify("NAV_WARNING", warning)
        fusion.warnings.clear()
        if fusion.failure is not None and not self.failure_posted:
            self.failure_posted = True
            self.notify(NAVIGATION_FAILURE, fusion.failure)
            self.notify(END_MISSION, f"navigation failure: {fusion.failure}")
        if self.log is not None:
            if fusion.olog:
                self.log.olog(fusion.olog)
            if fusion.xlog:
                self.log.xlog(fusion.xlog)
        fusion.olog.clear()
        fusion.xlog.clear()

    def _publish(self, e: Estimate, now: float) -> None:
        values = {"EKF_X": e.x, "EKF_Y": e.y, "EKF_YAW": e.yaw, "EKF_SPEED": e.speed,
                  "EKF_X_VEL": e.x_vel, "EKF_Y_VEL": e.y_vel, "EKF_YAW_VEL": e.yaw_vel,
                  "EKF_HEADING": e.heading, "EKF_SIGMA_X": e.sigma_x,
                  "EKF_SIGMA_Y": e.sigma_y}
        ekf = self.fusion.ekf if self.fusion is not None else None
        if ekf is not None and ekf.i_z is not None:
            values.update({"EKF_Z": e.z, "EKF_Z_VEL": e.z_vel, "EKF_DEPTH": e.depth})
        if ekf is not None and ekf.i_tide is not None:
            values["EKF_TIDE"] = e.tide
        if ekf is not None and ekf.i_bias is not None:
            values["EKF_YAW_BIAS"] = e.yaw_bias
        for name, value in values.items():
            self._offer(name, value, e.t, now)

    def _announce(self, key: str, source: str | None) -> None:
        name = NO_SOURCE if source is None else source
        if self._announced[key] != name:
            self._announced[key] = name
            self.notify(f"NAV_{key}_SOURCE", name)

    def _post(self, key: str, value: float, time: float) -> None:
        if key == "YAW":
            self.notify("NAV_YAW", value, time)
            self.notify("NAV_HEADING", yaw_to_heading(value), time)
        elif key == "HEADING":
            heading = value % 360.0
            self.notify("NAV_HEADING", heading, time)
            self.notify("NAV_YAW", heading_to_yaw(heading), time)
        else:
            self.notify(f"NAV_{key}", value, time)
