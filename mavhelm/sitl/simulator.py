"""The simulator: a vehicle model, the ArduPilot Rover logic and MAVLink links, in lockstep.

``Simulator.step(now)`` is the whole world for one tick: read and obey every link, advance the
physics in fixed 20 ms sub-steps (the autopilot's control loop runs in each), emit the telemetry
streams that fell due, then feed the serial sensors. Nothing reads the wall clock and nothing
blocks; randomness comes from ``numpy.random.default_rng(seed)`` and the scenario's named
streams, so a run is repeatable from (seed, scenario, sequence of ``now``).

This module is the vehicle's plumbing: construction (the vehicle model by name, ``.parm``
defaults over the parameter table), physics sub-stepping through the model interface, links and
stream scheduling. What a message means is decided in ``gcs_mavlink.py`` (its dispatch tables)
and ``autopilot.py``; what the autopilot believes (GPS receiver, EKF) is in ``estimator.py``;
how each outgoing message is built is in ``telemetry.py``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.sitl import autopilot as ap
from mavhelm.sitl.boat import SimEnvironment
from mavhelm.sitl.estimator import Estimator
from mavhelm.sitl.flat_earth import Origin
from mavhelm.sitl.gcs_mavlink import BOAT_ONLY, ORDER_INDEX, ROVER_ONLY, STREAMS, GcsMavlink
from mavhelm.sitl.links import Link, LinkHub
from mavhelm.sitl.models import DEFAULT_MODEL, VehicleModel, get_model
from mavhelm.sitl.parameters import ParameterTable
from mavhelm.sitl.parm_file import ParmValues, read_defaults
from mavhelm.sitl.statustext import chunks
from mavhelm.sitl.telemetry import HEARTBEAT, Telemetry
from mavhelm.sitl.truth import Truth

DEFAULT_HOME = Origin(56.0, -3.0)
DT = 0.02  # physics and control-loop sub-step, s (ArduPilot Rover runs its controllers at 50 Hz)
EPOCH_BASE = 1_767_225_600.0  # 2026-01-01 UTC: Unix time of sim t=0 when the clock is relative

M = mavlink

# The simulation's own parameters. Wind, wave and tide names and defaults are ArduPilot SITL's
# (SIM_WIND_DIR: where the wind comes from); the SITL models (models.MODELS) feel them through
# boat.SimEnvironment, mavhelm's own hulls only the wind (as leeway) and the current. The rest
# are the simulator's: SIM_CURRENT_* (water current, flowing *to*), SIM_DEPTH, SIM_GPS_NOISE
# (receiver wander σ, m) and SIM_EKF_DR_TIME (s of dead reckoning before the estimate is lost).
SIM_PARAMS: dict[str, float] = {
    "SIM_WIND_SPD": 0.0, "SIM_WIND_DIR": 180.0, "SIM_WIND_T": 1.0,
    "SIM_WAVE_ENABLE": 0.0, "SIM_WAVE_AMP": 0.5, "SIM_WAVE_DIR": 0.0, "SIM_WAVE_LENGTH": 10.0,
    "SIM_WAVE_SPEED": 0.5, "SIM_TIDE_DIR": 0.0, "SIM_TIDE_SPEED": 0.0,
    "SIM_CURRENT_SPD": 0.0, "SIM_CURRENT_DIR": 0.0, "SIM_DEPTH": 20.0,
    "SIM_GPS_NOISE": 0.4, "SIM_EKF_DR_TIME": 10.0,
}

# SIM_PARAMS values that are not the firmware's own default (SIM_WIND_T: ArduPilot's is 0, the
# table has motorboat.parm's 1): what the SITL models (--model) start from, as the real SITL.
SIM_FIRMWARE_DEFAULTS: dict[str, float] = {"SIM_WIND_T": 0.0}

# AC_Fence parameters with Rover's defaults: FENCE_TYPE 6 = circle + polygon, not enabled.
FENCE_PARAMS = {"FENCE_ENABLE": 0.0, "FENCE_TYPE": 6.0, "FENCE_ACTION": 1.0,
                "FENCE_RADIUS": 300.0, "FENCE_MARGIN": 2.0}

class Simulator:
    """A stand-in for ArduPilot Rover SITL that serves MAVLink on TCP ports and UDP outputs."""

    def __init__(self, clock: Any, *, model: str | VehicleModel = DEFAULT_MODEL,
                 defaults: str | Sequence[str | Path] | ParmValues | None = None,
                 ports: Sequence[int] = (5760, 5762, 5763), host: str = "127.0.0.1",
                 udp_out: Sequence[tuple[str, int]] = (), home: Origin = DEFAULT_HOME,
                 start_heading: float = 0.0, fast_start: bool = False, scenario: Any = None,
                 params: dict[str, float] | None = None, seed: int = 0,
                 serial_sensors: Sequence[Any] = (), epoch: float | None = None,
                 wait_for_client: bool = False) -> None:
        """``model``: a name of the model registry (ArduPilot's SITL names ``motorboat``,
        ``motorboat-skid``, ``rover``, ``rover-skid``, or mavhelm's own hulls, ``mavhelm-boat``
        by default) or a VehicleModel. ``defaults``: ArduPilot ``.parm`` files (a
        comma-separated string or paths, or already read), read leniently as the firmware does
        and applied over the parameter table (names the table lacks are added: the real
        firmware has them); ``params`` are applied after them. The table a SITL model starts
        from holds ArduPilot's own defaults (autopilot.ARDUPILOT_DEFAULTS), as the real SITL's
        does; mavhelm's own hulls keep the gains and navigation values tuned to them."""
        self.model = get_model(model) if isinstance(model, str) else model
        self.vehicle = self.model.vehicle
        if defaults is None:
            loaded = ParmValues()
        elif isinstance(defaults, ParmValues):
            loaded = defaults
        else:
            loaded = read_defaults(defaults, strict=False)
        self.defaults_skipped = loaded.skipped  # lines a stock file has that ArduPilot ignores
        self.clock = clock
        self.home = home
        self.scenario = scenario
        self.seed = seed
        self.serial_sensors = list(serial_sensors)
        self.boot = float(clock.now())
        self._t = self.boot
        self._n = 0  # sub-steps done: time is boot + n*DT exactly, no drift
        self.epoch = (EPOCH_BASE if self.boot < 1e9 else 0.0) if epoch is None else epoch
        self._scenario_rngs: dict[str, np.random.Generator] = {}
        self._gps_rng = np.random.default_rng([seed, 1])
        on_water = self.vehicle == "boat"
        timeline = ap.Timeline.fast() if fast_start else ap.Timeline()
        merged = dict(SIM_PARAMS)
        merged["SIM_DEPTH"] = 20.0 if on_water else 0.0
        firmware = self.model.firmware_defaults
        if firmware:
            merged.update(SIM_FIRMWARE_DEFAULTS)
        merged.update(FENCE_PARAMS)
        merged.update(loaded.values)
        merged.update({k.upper(): v for k, v in (params or {}).items()})
        self.autopilot = ap.Autopilot(boat=on_water, skid=self.model.skid, boot_time=self.boot,
                                      timeline=timeline, params=merged, latlon=home.to_global,
                                      firmware_defaults=firmware)
        self.params = self.autopilot.params
        self.param_table = ParameterTable(self.params)
        self.sysid = int(self.params["MAV_SYSID"])
        self._state: Any = self.model.initial_state(math.radians(start_heading % 360.0))
        self.env = self._env_from_params()
        self.truth: Truth = self.model.truth(self._state, self._t, self.env)
        self._motion = self.model.motion(self._state, self.env)
        self._wheels = [0.0, 0.0]
        self._compass_bias = 0.0
        self.estimator = Estimator(self.boot,
                                   max(0.05, self.params.get("GPS1_RATE_MS", 200) / 1000.0),
                                   self._gps_rng, self.autopilot.timeline, faults=self._faults,
                                   named_rng=self._srng)
        self.telemetry = Telemetry(self.autopilot, self.estimator, home=home, boot=self.boot,
                                   epoch=self.epoch, mav_type=self.model.mav_type)
        self._origin_sent = False
        self._text_id = 0  # id of the last chunked STATUSTEXT
        # wait_for_client: like the real SITL, listen on the first port only and keep the clock
        # (boot) stopped until a client connects there; then open the other ports
        self.started = not wait_for_client
        ports = list(ports)
        self._later_ports = [] if self.started else ports[1:]
        self.hub = LinkHub(ports if self.started else ports[:1], host, udp_out,
                           srcSystem=self.sysid, srcComponent=1, scenario=scenario)
        # the sensors this vehicle lacks: a boat has no wheel encoders, a rover no echo sounder
        self.absent = ROVER_ONLY if on_water else BOAT_ONLY
        self.stream_defaults: dict[int, float] = {HEARTBEAT: 1.0}
        for msgs in STREAMS.values():
            for mid in msgs:
                if mid not in self.absent:
                    self.stream_defaults[mid] = 1.0
        self.gcs = GcsMavlink(self)
        self._init_new_links(self.boot)
        self.autopilot.est = ap.Estimate(heading=start_heading % 360.0)

    # ------------------------------------------------------------------ public API
    @property
    def ports(self) -> list[int]:
        return self.hub.ports

    @property
    def links(self) -> list[Link]:
        return self.hub.links

    @property
    def mode(self) -> str:
        return self.autopilot.mode_name

    @property
    def armed(self) -> bool:
        return self.autopilot.armed

    def service(self, now: float) -> None:
        """Accept clients, read and obey every link, send the immediate replies. Never blocks."""
        self.hub.accept()
        if not self.started:
            if not any(link.kind == "tcp" and link.index == 0 for link in self.hub.links):
                return
            self._start(now)
        self._init_new_links(now)
        for link in list(self.hub.links):
            link.update_faults(now)
            for msg in link.receive():
                self.gcs.handle(link, msg, now)
        self._drain_outbox(now)
        self._flush()

    def _start(self, now: float) -> None:
        """The first client on the first port: the clock starts now, the other ports open."""
        self.started = True
        self.boot = self._t = float(now)
        self._n = 0
        self.autopilot.boot_time = self.boot
        self.estimator.boot = self.estimator.next_gps = self.boot
        self.telemetry.boot = self.boot
        for port in self._later_ports:
            self.hub.listen(port)
        self._later_ports = []

    def step(self, now: float) -> None:
        """service(now), physics up to now, due telemetry, then the serial sensors."""
        self.service(now)
        if not self.started:
            return
        # compass bias is looked up once per step (a fault window is never shorter than a tick)
        self._compass_bias = sum(float(f.params.get("deg", 0.0))
                                 for f in self._faults("compass_bias", now))
        while self.boot + (self._n + 1) * DT <= now + 1e-9:
            self._n += 1
            self._substep(self.boot + self._n * DT)
        self.truth = self.model.truth(self._state, self._t, self.env)
        self._drain_outbox(now)
        self._emit_streams(now)
        self._flush()
        for s in self.serial_sensors:
            s.update(self.truth, now)

    def close(self) -> None:
        self.hub.close()

    def __enter__(self) -> Simulator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ physics
    def _env_from_params(self) -> SimEnvironment:
        return SimEnvironment.from_params(self.params, armed=self.autopilot.armed)

    def _substep(self, t: float) -> None:
        a = self.autopilot
        e = self.estimator
        p = self.params
        m = self._motion
        if e.update_gps(t, self.truth, p.get("SIM_GPS_NOISE", 0.4)):
            a.gps_has_fix = e.has_fix
        e.update(a.est, t, DT, heading=m.heading, yaw_rate=m.yaw_rate, surge=m.surge,
                 sway=m.sway, compass_bias=self._compass_bias,
                 have_origin=a.ekf_origin is not None, dr_time=p.get("SIM_EKF_DR_TIME", 10.0),
                 vx=m.vx, vy=m.vy)
        a.update(t, DT)
        if self.env.armed != a.armed:  # the SITL's tide and waves act only while armed
            self.env = replace(self.env, armed=a.armed)
        model = self.model
        inputs = model.inputs_from_outputs(a.servo_outputs(), a.servo_map())
        self._state = model.step(self._state, inputs, self.env, DT)
        self._t = t
        self._motion = m = model.motion(self._state, self.env)
        e.record(t, self._state.x, self._state.y, m.vx, m.vy)
        if m.sway is None:  # on wheels: the encoders count
            half = 0.2 * m.yaw_rate  # wheel track 0.4 m
            self._wheels[0] += (m.surge + half) * DT
            self._wheels[1] += (m.surge - half) * DT

    # ------------------------------------------------------------------ scenario
    def _srng(self, name: str) -> np.random.Generator:
        """The scenario's named random stream, drawn once and kept (scenario.rng is fresh)."""
        g = self._scenario_rngs.get(name)
        if g is None:
            g = self._scenario_rngs[name] = self.scenario.rng(name)
        return g

    def _faults(self, kind: str, t: float) -> list[Any]:
        if self.scenario is None:
            return []
        return list(self.scenario.active(kind, t))

    # ------------------------------------------------------------------ links and streams
    def _init_new_links(self, now: float) -> None:
        for link in self.hub.new_links:
            link.order = ORDER_INDEX
            for mid, iv in self.stream_defaults.items():
                link.set_interval(mid, iv, now)
        self.hub.new_links.clear()

    def _flush(self) -> None:
        for link in self.hub.links:
            link.flush()
        self.hub.prune()

    def broadcast(self, msg: Any, exclude: Link | None = None) -> None:
        for link in self.hub.links:
            if link is not exclude:
                link.send(msg)

    def _drain_outbox(self, now: float) -> None:
        out = self.autopilot.out
        if not self._origin_sent and self.autopilot.ekf_origin is not None:
            # like ArduPilot, announce the new EKF origin and home on every link
            self._origin_sent = True
            self.broadcast(self.build(M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN, now))
            self.broadcast(self.build(M.MAVLINK_MSG_ID_HOME_POSITION, now))
        if out.heartbeat:
            out.heartbeat = False
            self.broadcast(self.build(HEARTBEAT, now))
        for sev, text in out.texts:
            for msg in self._statustexts(sev, text):
                self.broadcast(msg)
        out.texts.clear()
        for seq in out.reached:
            self.broadcast(M.MAVLink_mission_item_reached_message(seq))
        out.reached.clear()
        for name in out.params:
            self.broadcast(self.param_table.value_message(name))
        out.params.clear()

    def _statustexts(self, severity: int, text: str) -> list[Any]:
        """STATUSTEXT message(s) for a text: long ones in 50-byte MAVLink 2 chunks sharing an
        id (1..65535), as ArduPilot sends them."""
        parts = chunks(text)
        if len(parts) == 1:
            return [M.MAVLink_statustext_message(severity, parts[0][1], 0, 0)]
        self._text_id = self._text_id % 65535 + 1
        return [M.MAVLink_statustext_message(severity, raw, self._text_id, seq)
                for seq, raw in parts]

    def _emit_streams(self, now: float) -> None:
        """Send every stream message due on each link, each built at most once a step (and
        packed once: send_again only renumbers the packet for the next link)."""
        cache: dict[int, Any] = {}
        limit = now + 1e-9
        build, truth, wheels = self.telemetry.build, self.truth, self._wheels
        for link in self.hub.links:
            for mid in link.take_due(now, limit):
                msg = cache.get(mid)
                if msg is None:
                    msg = build(mid, now, truth, wheels)
                    cache[mid] = msg if msg is not None else False
                if msg:
                    link.send_again(msg)

    # ------------------------------------------------------------------ for the MAVLink front
    def build(self, mid: int, now: float) -> Any:
        """One telemetry message of id mid as of now, or None if it has nothing to say."""
        return self.telemetry.build(mid, now, self.truth, self._wheels)

    def set_param(self, name: str, value: float) -> bool:
        """A PARAM_SET: False for a name the table does not hold; otherwise stored, and what
        depends on it (environment, system id, GPS rate, servo map) follows at once."""
        stored = self.param_table.set(name, value)
        if stored is None:
            return False
        self.autopilot.invalidate()
        if name.startswith("SIM_"):
            self.env = self._env_from_params()
        if name == "MAV_SYSID":
            self.sysid = int(stored)
            self.hub.set_source(self.sysid, 1)
        if name == "GPS1_RATE_MS":
            self.estimator.gps_period = max(0.05, stored / 1000.0)
        return True
