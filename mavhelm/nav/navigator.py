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

A navigation failure (spec 2.2.11: the EKF's uncertainty limit with no LSQ to boot it
again, no LSQ fix within ``LSQTimeOut``, an LSQ all over the shop) takes the filters off-line
and posts ``NAVIGATION_FAILURE`` (why) and ``EndMission``, which starts every EndMission task
of the helm. What the navigator decides (:mod:`mavhelm.nav.filter_safety`: boots,
re-initialisations to the LSQ, an EKF lost, the failure) is posted as ``NAV_STATUS``
(``kind: why``) and, with the filter's other warnings (rate resets), as ``NAV_WARNING``, the
console's line. ``NAV_X_STD``/``NAV_Y_STD`` go with each ``NAV_X``/``NAV_Y``: the 1-σ of the
source it came from (the EKF's or LSQ's own, a sensor's declared noise). The .olog/.xlog
lines go to an injected ``NavLogSink`` (the companion writes files; a replay may keep them
in memory).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Final, Protocol

from mavhelm.core.app import App
from mavhelm.core.bus import Bus, Message
from mavhelm.core.geodesy import heading_to_yaw, yaw_to_heading
from mavhelm.core.mission import Block, Entry, Mission, MissionError
from mavhelm.core.moos import APP_PARAMS, source_of
from mavhelm.core.names import END_MISSION, HELM_ONLINE, NAVIGATION_FAILURE, NO_SOURCE
from mavhelm.core.params import Boolean, FileStem, Param, PathName, Schema
from mavhelm.nav.acoustics import BLOCK, acoustic_beacons
from mavhelm.nav.ekf import EKFConfig, Estimate
from mavhelm.nav.fusion import Fusion, FusionConfig, Start
from mavhelm.nav.original import ALWAYS_READ, ORIGINAL_ONLY
from mavhelm.nav.priority_queue import PriorityQueue, QueueSpec
from mavhelm.nav.sensor_channel import LSQ_REJECTION
from mavhelm.nav.sensor_watch import SENSOR_SILENCE, SensorWatch
from mavhelm.nav.sensors import (
    BEACON,
    FIXEDDEPTH,
    FIXEDHEADING,
    FIXEDSIDESLIP,
    FIXEDTIDE,
    LBL_SOUND_SPEED,
    POSITION_TYPES,
    SENSOR_TYPES,
    SOUND_SPEED,
    SensorLine,
    SensorReader,
    SensorSpec,
    integrated_sources,
    noise_range,
)
from mavhelm.nav.settings import (
    EKF_BEACON_OFFSETS,
    EKF_GATE,
    EKF_HEADING,
    EKF_LAG,
    EKF_MAX_SPEED,
    EKF_MOBILE,
    EKF_RANGE_SCALE,
    EKF_SIGMA_HEADING,
    EKF_SIGMA_XY,
    EKF_SIGMA_Z,
    EKF_SPEED_SCALE,
    EKF_START,
    EKF_TIDE,
    EKF_TIME_SIGMA,
    EKF_X,
    EKF_XY_DYNAMICS,
    EKF_Y,
    EKF_YAW_BIAS,
    EKF_YAW_DRIFT,
    EKF_YAW_DYNAMICS,
    EKF_YAW_SCALE,
    EKF_Z,
    EKF_Z_DYNAMICS,
    LSQ,
    LSQ_OFFSET,
    LSQ_TIMEOUT,
    LSQ_WINDOW,
    MAX_EKF_POSITION_UNCERTAINTY,
    MAX_LSQ_EKF_DEVIATION,
    MAX_MEDIAN_LSQ_SHIFT,
    config_from,
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

NAV_LOG = Param("NAV_LOG", Boolean(), True, "", "write the .olog and .xlog when filters run "
                "(the original's default is false)", attr="nav_log")
NAV_LOG_PATH = Param("NAV_LOG_PATH", PathName(folder=True), None, "", "folder of the nav "
                     "logs (default: the alog's)", attr="nav_log_path")
NAV_LOG_STEM = Param("NAV_LOG_STEM", FileStem(), "pNav", "", "file name stem of the nav logs",
                     attr="nav_log_stem")
NAV_LOG_TIMESTAMP = Param("NAV_LOG_TIMESTAMP", Boolean(), True, "", "put the creation time in "
                          "the file names (the original's default is false)",
                          attr="nav_log_timestamp")
NAV_LOG_SETTINGS: Final = (NAV_LOG, NAV_LOG_PATH, NAV_LOG_STEM, NAV_LOG_TIMESTAMP)

NAV_SCHEMA = Schema(
    "pNav",
    (*(Param(key.title(), QueueSpec(), None, doc=f"priority queue feeding NAV_{key}",
             attr=key.lower()) for key in QUEUE_KEYS),
     *(Param(f"SENSOR_{kind}", SensorLine(kind), [], repeat=True,
             attr=f"sensor_{kind.lower()}",
             doc=f"a {kind} sensor for the filters (spec 2.2.1); noise {noise_range(kind)}")
       for kind in SENSOR_TYPES),
     BEACON, FIXEDDEPTH, FIXEDHEADING, FIXEDTIDE, FIXEDSIDESLIP,
     *EKF_START, EKF_SIGMA_XY, EKF_SIGMA_HEADING, EKF_SIGMA_Z, EKF_XY_DYNAMICS,
     EKF_YAW_DYNAMICS, EKF_Z_DYNAMICS, EKF_MOBILE, EKF_LAG, EKF_TIME_SIGMA, EKF_YAW_BIAS,
     EKF_YAW_DRIFT, EKF_YAW_SCALE, EKF_SPEED_SCALE, EKF_TIDE, EKF_RANGE_SCALE,
     EKF_BEACON_OFFSETS, EKF_GATE, MAX_EKF_POSITION_UNCERTAINTY, EKF_MAX_SPEED,
     LSQ, LSQ_WINDOW, LSQ_TIMEOUT, LSQ_OFFSET, LSQ_REJECTION, MAX_LSQ_EKF_DEVIATION,
     MAX_MEDIAN_LSQ_SHIFT, LBL_SOUND_SPEED,
     *NAV_LOG_SETTINGS, SENSOR_SILENCE, ALWAYS_READ, *ORIGINAL_ONLY),
    moos=APP_PARAMS,
)
"""A pNav block: its priority queues, its sensors, and the filters' settings."""


def _add_acoustics(settings: dict, mission: Mission | None) -> None:
    """The original's Acoustics block's beacons join the pNav block's BEACONs."""
    block = mission.process(BLOCK) if mission is not None else None
    if block is None:
        return
    extra = acoustic_beacons(block)
    clash = {b.name for b in settings[BEACON.attribute]} & {b.name for b in extra}
    if clash:
        raise block.error(f"beacon {sorted(clash)[0]} is declared both in pNav (BEACON) and in "
                          "the Acoustics block; declare it once")
    settings[BEACON.attribute] = [*settings[BEACON.attribute], *extra]


class NavLogSink(Protocol):
    """Where the .olog and .xlog lines go (spec 2.2.5)."""

    def olog(self, lines: list[str]) -> None: ...

    def xlog(self, lines: list[str]) -> None: ...

    def flush(self) -> None:
        """Make what was written durable (called after each tick, in its idle time)."""


def _entry(block: Block, *keys: str) -> Entry:
    """The last entry of the block with one of ``keys`` (where a cross-check points)."""
    wanted = {k.lower() for k in keys}
    found = [e for e in block.entries if e.key.lower() in wanted]
    return found[-1] if found else Entry(keys[0], "", block.file, block.line)


def fusion_from_settings(settings: dict, block: Block) -> tuple[list[SensorSpec], Fusion] | None:
    """The filters a pNav block asks for, or None when it declares no sensor."""
    sensors = [spec for kind in SENSOR_TYPES for spec in settings[f"sensor_{kind.lower()}"]]
    if not sensors:
        for param in (BEACON, LSQ_REJECTION):
            if settings[param.attribute]:
                raise _entry(block, param.name).error(
                    f"{param.name} without any SENSOR_* line: declare the sensors the filters "
                    "read")
        return None
    _check_names(block)
    _check_ranging(settings, sensors, block)
    has_depth = _check_filters(settings, sensors, block)
    integrated = bool(integrated_sources(sensors))
    follows, unless_speed = _velocity_follows_heading(settings, sensors)
    heading_sensed = (any(s.type == "ORIENTATION" for s in sensors)
                      or settings[FIXEDHEADING.attribute] is not None)
    # a heading bias is an orientation sensor's: without one nothing reads it, and a doubt
    # raised on it would leave the heading itself as sure as before
    ekf = config_from(EKFConfig, settings, estimate_z=has_depth,
                      velocity_follows_heading=follows,
                      estimate_yaw_scale=integrated and settings[EKF_YAW_SCALE.attribute],
                      estimate_yaw_bias=heading_sensed and settings[EKF_YAW_BIAS.attribute])
    positions = any(s.type in POSITION_TYPES for s in sensors)
    config = config_from(FusionConfig, settings, ekf=ekf, start=_start(settings),
                         speed_scale=settings[EKF_SPEED_SCALE.attribute] and positions,
                         follow_unless_speed=unless_speed, heading_sensed=heading_sensed)
    return sensors, Fusion(config)


def _velocity_follows_heading(settings: dict, sensors: list[SensorSpec]) -> tuple[bool, bool]:
    """Whether the EKF turns the velocity with the yaw rate and lets the speed change only
    gently once under way (:data:`mavhelm.nav.ekf.ALONG_TRACK`): a hull that moves along its
    bow (``FIXEDSIDESLIP``), or a vehicle whose heading is sensed and whose speed no sensor
    measures (no ``SENSOR_BODY_VEL``). There the speed comes from position fixes alone, and
    the same acceleration noise in every direction, which a turn needs across the track,
    left 1 Hz GPS (2 m) and a compass a NAV_SPEED of 0.49 m/s RMS on legs at 2 m/s; turned
    with the heading, 0.20 m/s, and 0.24-0.32 m/s in a current of 0.5-1 m/s across
    the legs, where the velocity does not follow the bow (no worse, 0.56 m/s, for a vehicle
    moving sideways). Not with a body-velocity sensor, which measures the speed itself: on
    Plaza1's odometry it doubled the error (0.36 → 0.72 m RMS). Whether one gives a speed
    (a gyro gives only the yaw rate) is known only once it is heard: the fusion decides
    (``FusionConfig.follow_unless_speed``). Not where nothing senses the heading or the
    turn (``FIXEDSIDESLIP`` on a GPS alone): the velocity turned with a yaw rate no sensor
    holds, which wandered, and the dead reckoning between fixes with it (the real SITL's
    GPS-noise run without its compass, 5 Hz fixes of 2.7 m: 21.96 m RMS; not turned, 1.55
    m). Returns (from the start, unless a speed is heard)."""
    types = {s.type for s in sensors}
    if settings[FIXEDSIDESLIP.attribute] is not None:
        return bool(types & {"ORIENTATION", "BODY_VEL"}), False
    sensed = "ORIENTATION" in types
    return sensed and "BODY_VEL" not in types, sensed and "BODY_VEL" in types


def _check_names(block: Block) -> None:
    """Each sensor and each beacon is named once."""
    sensor_keys = {f"SENSOR_{kind}" for kind in SENSOR_TYPES}
    seen: dict[str, set[str]] = {"sensor": set(), "BEACON": set()}
    for entry in block.entries:
        key = entry.key.upper()
        if key in sensor_keys:
            what, name = "sensor", SensorLine(key[len("SENSOR_"):]).parse(entry).name
        elif key == BEACON.name:
            what, name = "BEACON", BEACON.kind.parse(entry).name
        else:
            continue
        if name in seen[what]:
            raise entry.error(f"sensor name {name!r} is declared twice; name each sensor once"
                              if what == "sensor" else f"BEACON {name} is declared twice")
        seen[what].add(name)


def _check_ranging(settings: dict, sensors: list[SensorSpec], block: Block) -> None:
    """Ranging sensors need beacons; rejection rules name ranging sensors."""
    ranging = [s for s in sensors if s.type in ("LBL", "RANGE")]
    if ranging and not settings[BEACON.attribute]:
        raise _entry(block, f"SENSOR_{ranging[0].type}").error(
            f"SENSOR_{ranging[0].type} {ranging[0].name} needs BEACON lines (id @ x,y,z)")
    for rule in settings[LSQ_REJECTION.attribute]:
        if rule.sensor not in {s.name for s in ranging}:
            raise _entry(block, LSQ_REJECTION.name).error(
                f"LSQ_REJECTION names {rule.sensor!r}, which is not a declared LBL or RANGE "
                f"sensor (sensors: {', '.join(s.name for s in sensors)})")


def _check_filters(settings: dict, sensors: list[SensorSpec], block: Block) -> bool:
    """The filter settings that depend on each other; returns whether Z is estimated."""
    if (settings[EKF_X.attribute] is None) != (settings[EKF_Y.attribute] is None):
        raise _entry(block, EKF_X.name, EKF_Y.name).error(
            "give both EKF_X and EKF_Y (the EKF's start) or neither")
    has_depth = (any(s.type == "DEPTH" for s in sensors)
                 or settings[FIXEDDEPTH.attribute] is not None)
    if settings[EKF_TIDE.attribute] and not has_depth:
        raise _entry(block, EKF_TIDE.name).error(
            "EKF_TIDE needs a DEPTH sensor or FIXEDDEPTH (depth = tide − Z)")
    if settings[FIXEDTIDE.attribute] is not None and not settings[EKF_TIDE.attribute]:
        raise _entry(block, FIXEDTIDE.name).error("FIXEDTIDE needs EKF_TIDE = true")
    return has_depth


def _start(settings: dict) -> Start | None:
    """The EKF's start pose when EKF_X and EKF_Y give one (heading unknown without
    EKF_HEADING: yaw 0 with a σ of π)."""
    if settings[EKF_X.attribute] is None:
        return None
    heading = settings[EKF_HEADING.attribute]
    sigma_heading = settings[EKF_SIGMA_HEADING.attribute]
    return Start(settings[EKF_X.attribute], settings[EKF_Y.attribute],
                 0.0 if heading is None else heading_to_yaw(heading),
                 settings[EKF_SIGMA_XY.attribute],
                 math.pi if heading is None else math.radians(sigma_heading),
                 z=settings[EKF_Z.attribute])


_UNSET: Final = object()


_STD_AXIS = {"X": 0, "Y": 1}
"""The NAV variables with a published 1-σ (NAV_X_STD, NAV_Y_STD): their axis in a source's σ."""


class Navigator(App):
    """Forwards the best live source of each NAV key; says which source that is; runs the
    filters when sensors are declared."""

    name = "pNav"

    def __init__(self, bus: Bus, queues: list[PriorityQueue], *,
                 sensors: list[SensorSpec] | None = None, fusion: Fusion | None = None,
                 sound_speed: float = SOUND_SPEED, log: NavLogSink | None = None,
                 log_settings: dict | None = None, watch: SensorWatch | None = None,
                 always_read: tuple[str, ...] = ()) -> None:
        super().__init__(bus)
        self.watch = watch
        self.always_read = frozenset(always_read)
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
        self._std: dict[str, tuple[float, float]] = {
            spec.source: (spec.sigma(), spec.sigma()) for spec in sensors or []
            if spec.type == "XY"}
        """Per position source, its 1-σ in X and Y (m): declared for a sensor, the filters'
        own for EKF and LSQ; posted as NAV_X_STD/NAV_Y_STD beside the value it goes with."""

    @classmethod
    def from_block(cls, bus: Bus, block: Block, log: NavLogSink | None = None,
                   mission: Mission | None = None) -> Navigator:
        """Build from a ``ProcessConfig = pNav`` block; every refusal is a located error.
        ``mission``: where a SENSOR line's MOOS process name (``iSerial_gps``) is looked up."""
        settings = NAV_SCHEMA.read(block)
        if settings["yaw"] is not None and settings["heading"] is not None:
            later = max(block.require("Yaw"), block.require("Heading"), key=lambda e: e.line)
            raise later.error("configure a Yaw queue or a Heading queue, not both")
        queues = [settings[key.lower()] for key in QUEUE_KEYS if settings[key.lower()]]
        if not queues:
            raise block.error("pNav needs at least one priority queue, e.g. X = GPS @ 2.0")
        _add_acoustics(settings, mission)
        filters = fusion_from_settings(settings, block)
        sensors, fusion = filters if filters is not None else (None, None)
        origins: dict[str, str] = {}
        for i, spec in enumerate(sensors or []):
            source, how = source_of(spec.source, mission)
            origins[spec.name] = how
            sensors[i] = dataclasses.replace(spec, source=source)  # type: ignore[index]
        watch = SensorWatch(sensors, settings[SENSOR_SILENCE.attribute], origins) \
            if sensors else None
        log_settings = {p.attribute: settings[p.attribute] for p in NAV_LOG_SETTINGS}
        return cls(bus, queues, sensors=sensors, fusion=fusion,
                   sound_speed=settings[LBL_SOUND_SPEED.attribute], log=log,
                   log_settings=log_settings, watch=watch,
                   always_read=tuple(settings[ALWAYS_READ.attribute]))

    @classmethod
    def from_mission(cls, bus: Bus, mission: Mission, log: NavLogSink | None = None
                     ) -> Navigator:
        """Build from the mission's ``ProcessConfig = pNav`` block, which must exist."""
        block = mission.process("pNav")
        if block is None:
            raise MissionError(mission.path, 0, "the mission has no ProcessConfig = pNav block")
        return cls.from_block(bus, block, log, mission)

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
            if self.watch is not None:
                subs.add(HELM_ONLINE)
            self._subscriptions = frozenset(subs | self.always_read)
        return self._subscriptions

    def on_mail(self, mail: list[Message], now: float) -> None:
        mail = [m for m in mail if m.source != self.name]  # own EKF_*/LSQ_* already routed
        if self.watch is not None:
            self.watch.heard(((m.name, m.value) for m in mail), now)
        for msg in mail:
            self._route(msg.name, msg.value, msg.time, now)
        if self.reader is not None and self.fusion is not None:
            readings, altitudes = self.reader.read(mail)
            for reading in readings:
                self.fusion.add(reading, now)
            for t, altitude in altitudes:
                if self.fusion.online:
                    self._offer("EKF_ALTITUDE", altitude, t, now)

    def _route(self, name: str, value: float | str, t: float, now: float) -> None:
        routes = self._inputs.get(name)
        if not routes or isinstance(value, str) or not math.isfinite(value):
            return
        for queue, source in routes:
            if now - t > queue.timeout(source):
                continue
            if queue.offer(source, value, t):
                self._announce(queue.key, source)
                self._post(queue.key, value, t)
                self._post_std(queue.key, source, t)

    def _offer(self, name: str, value: float, t: float, now: float) -> None:
        """Post a filter output and offer it to the queues, as a sensor's value would be."""
        if not math.isfinite(value):
            return
        self.notify(name, value, t)
        if name in self._inputs:
            self._route(name, value, t, now)

    def iterate(self, now: float) -> None:
        if self.fusion is not None:
            self._run_filters(now)
        for queue in self.queues:
            self._announce(queue.key, queue.current_source(now))
        if self.watch is not None:
            for warning in self.watch.warnings(now):
                self.notify("NAV_WARNING", warning)

    def idle(self) -> None:
        """The .olog/.xlog lines of the tick formatted, written and flushed: work that can
        wait until the commands are out."""
        self.write_logs()
        if self.log is not None:
            self.log.flush()

    def write_logs(self) -> None:
        """The .olog/.xlog lines kept since the last call, formatted and handed to the log
        (a replay calls it each tick, without flushing)."""
        fusion = self.fusion
        if self.log is None or fusion is None:
            return
        olog, xlog = fusion.take_olog(), fusion.take_xlog()
        if olog:
            self.log.olog(olog)
        if xlog:
            self.log.xlog(xlog)

    def close(self) -> None:
        self.write_logs()

    def _run_filters(self, now: float) -> None:
        fusion = self.fusion
        assert fusion is not None
        estimate = fusion.step(now)
        for fix in fusion.new_fixes:
            self._std["LSQ"] = (fix.sigma, fix.sigma)
            self._offer("LSQ_X", fix.x, fix.t, now)
            self._offer("LSQ_Y", fix.y, fix.t, now)
            if fix.yaw is not None:
                self._offer("LSQ_YAW", fix.yaw, fix.t, now)
                self._offer("LSQ_HEADING", yaw_to_heading(fix.yaw), fix.t, now)
            if fix.depth is not None and fix.z is not None:
                self._offer("LSQ_DEPTH", fix.depth, fix.t, now)
                self._offer("LSQ_Z", fix.z, fix.t, now)
        if estimate is not None:
            self._publish(estimate, now)
        for decision in fusion.new_decisions:
            self.notify("NAV_STATUS", str(decision))
        for warning in fusion.warnings:
            self.notify("NAV_WARNING", warning)
        fusion.warnings.clear()
        if fusion.failure is not None and not self.failure_posted:
            self.failure_posted = True
            self.notify(NAVIGATION_FAILURE, fusion.failure)
            self.notify(END_MISSION, f"navigation failure: {fusion.failure}")

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
        self._std["EKF"] = (e.sigma_x, e.sigma_y)
        # _offer for each, posted on the bus directly: a dozen values every tick
        post, inputs, t = self.bus.notify, self._inputs, e.t
        for name, value in values.items():
            if math.isfinite(value):
                post(name, value, self.name, t)
                if name in inputs:
                    self._route(name, value, t, now)

    def _announce(self, key: str, source: str | None) -> None:
        name = NO_SOURCE if source is None else source
        if self._announced[key] != name:
            self._announced[key] = name
            self.notify(f"NAV_{key}_SOURCE", name)

    def _post_std(self, key: str, source: str, time: float) -> None:
        """NAV_X_STD/NAV_Y_STD: the 1-σ of the position just posted, from its source."""
        axis = _STD_AXIS.get(key)
        std = self._std.get(source)
        if axis is not None and std is not None and math.isfinite(std[axis]):
            self.notify(f"NAV_{key}_STD", std[axis], time)

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
