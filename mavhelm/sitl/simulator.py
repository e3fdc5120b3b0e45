"""The simulator: a vehicle model, the ArduPilot Rover logic and MAVLink links, in lockstep.

``Simulator.step(now)`` is the whole world for one tick: read and obey every link, advance the
physics in fixed 20 ms sub-steps (the autopilot's control loop runs in each), emit the telemetry
streams that fell due, then feed the serial sensors. Nothing reads the wall clock and nothing
blocks; randomness comes from ``numpy.random.default_rng(seed)`` and the scenario's named
streams, so a run is repeatable from (seed, scenario, sequence of ``now``).

This module is the vehicle's plumbing: construction, physics sub-stepping, links and stream
scheduling, and the MAVLink dispatcher. What the autopilot believes (GPS receiver, EKF) is in
``estimator.py``; how each outgoing message is built is in ``telemetry.py``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.sitl import autopilot as ap
from mavhelm.sitl import boat, rover
from mavhelm.sitl.estimator import Estimator
from mavhelm.sitl.flat_earth import Origin
from mavhelm.sitl.links import Link, LinkHub
from mavhelm.sitl.statustext import BANNER, chunks
from mavhelm.sitl.telemetry import HEARTBEAT, Telemetry
from mavhelm.sitl.truth import Truth

DEFAULT_HOME = Origin(56.0, -3.0)
DT = 0.02  # physics and control-loop sub-step, s (ArduPilot Rover runs its controllers at 50 Hz)
EPOCH_BASE = 1_767_225_600.0  # 2026-01-01 UTC: Unix time of sim t=0 when the clock is relative

M = mavlink
# Streams as ArduPilot groups them (Rover/GCS_Mavlink.cpp), for REQUEST_DATA_STREAM.
STREAMS: dict[int, tuple[int, ...]] = {
    M.MAV_DATA_STREAM_RAW_SENSORS: (M.MAVLINK_MSG_ID_RAW_IMU, M.MAVLINK_MSG_ID_SCALED_IMU2,
                                    M.MAVLINK_MSG_ID_SCALED_PRESSURE),
    M.MAV_DATA_STREAM_EXTENDED_STATUS: (
        M.MAVLINK_MSG_ID_SYS_STATUS, M.MAVLINK_MSG_ID_POWER_STATUS, M.MAVLINK_MSG_ID_MEMINFO,
        M.MAVLINK_MSG_ID_MISSION_CURRENT, M.MAVLINK_MSG_ID_GPS_RAW_INT,
        M.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT, M.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT),
    M.MAV_DATA_STREAM_POSITION: (M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT,
                                 M.MAVLINK_MSG_ID_LOCAL_POSITION_NED),
    M.MAV_DATA_STREAM_RC_CHANNELS: (M.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW,
                                    M.MAVLINK_MSG_ID_RC_CHANNELS),
    M.MAV_DATA_STREAM_EXTRA1: (M.MAVLINK_MSG_ID_ATTITUDE, M.MAVLINK_MSG_ID_SIMSTATE,
                               M.MAVLINK_MSG_ID_AHRS2),
    M.MAV_DATA_STREAM_EXTRA2: (M.MAVLINK_MSG_ID_VFR_HUD,),
    M.MAV_DATA_STREAM_EXTRA3: (
        M.MAVLINK_MSG_ID_AHRS, M.MAVLINK_MSG_ID_SYSTEM_TIME, M.MAVLINK_MSG_ID_RANGEFINDER,
        M.MAVLINK_MSG_ID_DISTANCE_SENSOR, M.MAVLINK_MSG_ID_BATTERY_STATUS,
        M.MAVLINK_MSG_ID_EKF_STATUS_REPORT, M.MAVLINK_MSG_ID_VIBRATION,
        M.MAVLINK_MSG_ID_WHEEL_DISTANCE),
}
BOAT_ONLY = {M.MAVLINK_MSG_ID_RANGEFINDER, M.MAVLINK_MSG_ID_DISTANCE_SENSOR}
ROVER_ONLY = {M.MAVLINK_MSG_ID_WHEEL_DISTANCE}
# Fixed emission order (deterministic): heartbeat first, then stream order.
_ORDER = [HEARTBEAT] + [m for s in STREAMS.values() for m in s]
_ORDER_INDEX = {m: i for i, m in enumerate(_ORDER)}

# Every message Telemetry.build() knows (ArduPilot answers FAILED for ids it has no ap_message for).
# EXTENDED_SYS_STATE is in no Rover stream but, like every vehicle, Rover sends it on request.
KNOWN = set(_ORDER) | {M.MAVLINK_MSG_ID_HOME_POSITION, M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN,
                       M.MAVLINK_MSG_ID_AUTOPILOT_VERSION, M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE}

# The simulation's own parameters. Wind and wave names and defaults are ArduPilot SITL's
# (SIM_WIND_DIR: where the wind comes from); the waves are stored only, not simulated. The rest
# are the simulator's: SIM_CURRENT_* (water current, flowing *to*), SIM_DEPTH, SIM_GPS_NOISE
# (receiver wander σ, m) and SIM_EKF_DR_TIME (s of dead reckoning before the estimate is lost).
SIM_PARAMS: dict[str, float] = {
    "SIM_WIND_SPD": 0.0, "SIM_WIND_DIR": 180.0, "SIM_WIND_T": 1.0,
    "SIM_WAVE_ENABLE": 0.0, "SIM_WAVE_AMP": 0.5, "SIM_WAVE_DIR": 0.0, "SIM_WAVE_LENGTH": 10.0,
    "SIM_WAVE_SPEED": 0.5,
    "SIM_CURRENT_SPD": 0.0, "SIM_CURRENT_DIR": 0.0, "SIM_DEPTH": 20.0,
    "SIM_GPS_NOISE": 0.4, "SIM_EKF_DR_TIME": 10.0,
}
_INT_PARAMS = {"SIM_WIND_T", "SIM_WAVE_ENABLE"}

# AC_Fence parameters with Rover's defaults: FENCE_TYPE 6 = circle + polygon, not enabled.
FENCE_PARAMS = {"FENCE_ENABLE": 0.0, "FENCE_TYPE": 6.0, "FENCE_ACTION": 1.0,
                "FENCE_RADIUS": 300.0, "FENCE_MARGIN": 2.0}

# MAVLink FTP (FILE_TRANSFER_PROTOCOL payload): opcodes and NAK error codes.
FTP_NONE, FTP_TERMINATE, FTP_RESET, FTP_READ, FTP_WRITE, FTP_BURST_READ = 0, 1, 2, 5, 7, 15
FTP_NAMED = {3, 4, 6, 8, 9, 10, 11, 12, 13, 14}  # list, open, create, remove, mkdir, crc, …
FTP_ACK, FTP_NAK = 128, 129
FTP_ERR_FAIL_ERRNO, FTP_ERR_UNKNOWN_COMMAND, FTP_ERR_FILE_NOT_FOUND = 2, 7, 10
ENOENT = 2


class Simulator:
    """A stand-in for ArduPilot Rover SITL that serves MAVLink on TCP ports and UDP outputs."""

    def __init__(self, clock: Any, *, vehicle: str = "boat", variant: str | None = None,
                 ports: Sequence[int] = (5760, 5762, 5763), host: str = "127.0.0.1",
                 udp_out: Sequence[tuple[str, int]] = (), home: Origin = DEFAULT_HOME,
                 start_heading: float = 0.0, fast_start: bool = False, scenario: Any = None,
                 params: dict[str, float] | None = None, seed: int = 0,
                 serial_sensors: Sequence[Any] = (), epoch: float | None = None,
                 wait_for_client: bool = False) -> None:
        if vehicle not in ("boat", "rover"):
            raise ValueError(f"vehicle must be boat or rover, not {vehicle!r}")
        self.vehicle = vehicle
        self.is_boat = vehicle == "boat"
        self.variant = variant or ("skid" if self.is_boat else "ackermann")
        allowed = ("skid", "rudder") if self.is_boat else ("ackermann", "skid")
        if self.variant not in allowed:
            raise ValueError(f"{vehicle} variant must be one of {allowed}, not {self.variant!r}")
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
        skid = self.variant == "skid"
        timeline = ap.Timeline.fast() if fast_start else ap.Timeline()
        sim_params = dict(SIM_PARAMS)
        sim_params["SIM_DEPTH"] = 20.0 if self.is_boat else 0.0
        merged = dict(sim_params)
        merged.update(FENCE_PARAMS)
        merged.update({k.upper(): v for k, v in (params or {}).items()})
        self.autopilot = ap.Autopilot(boat=self.is_boat, skid=skid, boot_time=self.boot,
                                      timeline=timeline, params=merged, latlon=home.to_global)
        self.params = self.autopilot.params
        self._sysid = int(self.params["MAV_SYSID"])
        hdg = math.radians(start_heading % 360.0)
        if self.is_boat:
            self._model_params: Any = boat.BoatParams(variant=self.variant)
            self._state: Any = boat.BoatState(heading=hdg)
            self._step_fn: Any = boat.step
            self._truth_fn: Any = boat.truth
        else:
            self._model_params = rover.RoverParams(variant=self.variant)
            self._state = rover.RoverState(heading=hdg)
            self._step_fn = rover.step
            self._truth_fn = rover.truth
        self.env = self._env_from_params()
        self.truth: Truth = self._truth_fn(self._state, self._t, self.env, self._model_params)
        self._wheels = [0.0, 0.0]
        self._compass_bias = 0.0
        self.estimator = Estimator(self.boot,
                                   max(0.05, self.params.get("GPS1_RATE_MS", 200) / 1000.0),
                                   self._gps_rng, self.autopilot.timeline, faults=self._faults,
                                   named_rng=self._srng)
        self.telemetry = Telemetry(self.autopilot, self.estimator, home=home, boot=self.boot,
                                   epoch=self.epoch, is_boat=self.is_boat)
        self._origin_sent = False
        self._text_id = 0  # id of the last chunked STATUSTEXT
        # wait_for_client: like the real SITL, listen on the first port only and keep the clock
        # (boot) stopped until a client connects there; then open the other ports
        self.started = not wait_for_client
        ports = list(ports)
        self._later_ports = [] if self.started else ports[1:]
        self.hub = LinkHub(ports if self.started else ports[:1], host, udp_out,
                           srcSystem=self._sysid, srcComponent=1, scenario=scenario)
        self._defaults: dict[int, float] = {HEARTBEAT: 1.0}
        for msgs in STREAMS.values():
            for mid in msgs:
                if (mid in BOAT_ONLY and not self.is_boat) or (mid in ROVER_ONLY
                                                               and self.is_boat):
                    continue
                self._defaults[mid] = 1.0
        self._param_names = sorted(self.params)
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
                self._handle(link, msg, now)
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
        self.truth = self._truth_fn(self._state, self._t, self.env, self._model_params)
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
    def _env_from_params(self) -> boat.Environment:
        p = self.params
        cs, cd = p.get("SIM_CURRENT_SPD", 0.0), math.radians(p.get("SIM_CURRENT_DIR", 0.0))
        return boat.Environment(current_east=cs * math.sin(cd), current_north=cs * math.cos(cd),
                                wind_speed=p.get("SIM_WIND_SPD", 0.0),
                                wind_from=p.get("SIM_WIND_DIR", 0.0),
                                water_depth=p.get("SIM_DEPTH", 20.0))

    def _vehicle_inputs(self) -> tuple[float, float]:
        """Servo PWM → the model's actuator commands, via SERVOn_FUNCTION like SITL's frames."""
        a = self.autopilot
        outs = a.servo_outputs()
        vals: dict[int, float] = {}
        for ch, fn, lo, hi, trim, rev in a.servo_map():
            pwm = outs[ch - 1]
            v = (pwm - trim) / max((hi - trim) if pwm >= trim else (trim - lo), 1)
            vals[fn] = -v if rev else v
        if ap.FN_THROTTLE_LEFT in vals or ap.FN_THROTTLE_RIGHT in vals:
            left = vals.get(ap.FN_THROTTLE_LEFT, 0.0)
            right = vals.get(ap.FN_THROTTLE_RIGHT, 0.0)
            steer, thr = 0.5 * (left - right), 0.5 * (left + right)
        else:
            steer = vals.get(ap.FN_STEERING, 0.0)
            thr = vals.get(ap.FN_THROTTLE, 0.0)
            left, right = thr + steer, thr - steer
        if self.variant == "skid":
            return left, right
        return steer, thr

    def _substep(self, t: float) -> None:
        a = self.autopilot
        e = self.estimator
        st = self._state
        p = self.params
        if e.update_gps(t, self.truth, p.get("SIM_GPS_NOISE", 0.4)):
            a.gps_has_fix = e.has_fix
        if self.is_boat:
            surge, sway = st.u, st.v
        else:
            surge, sway = st.speed, None
        e.update(a.est, t, DT, heading=st.heading, yaw_rate=st.r, surge=surge, sway=sway,
                 compass_bias=self._compass_bias, have_origin=a.ekf_origin is not None,
                 dr_time=p.get("SIM_EKF_DR_TIME", 10.0))
        a.update(t, DT)
        inputs = self._vehicle_inputs()
        self._state = self._step_fn(self._state, inputs, self.env, DT, self._model_params)
        self._t = t
        st = self._state
        if self.is_boat:
            s, c = math.sin(st.heading), math.cos(st.heading)
            ce, cn = self.env.drift(self._model_params.leeway)
            vx = st.u * s + st.v * c + ce
            vy = st.u * c - st.v * s + cn
            e.record(t, st.x, st.y, vx, vy)
        else:
            vx, vy = st.speed * math.sin(st.heading), st.speed * math.cos(st.heading)
            e.record(t, st.x, st.y, vx, vy)
            half = 0.2 * st.r  # wheel track 0.4 m
            self._wheels[0] += (st.speed + half) * DT
            self._wheels[1] += (st.speed - half) * DT

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
            link.order = _ORDER_INDEX
            for mid, iv in self._defaults.items():
                link.set_interval(mid, iv, now)
        self.hub.new_links.clear()

    def _flush(self) -> None:
        for link in self.hub.links:
            link.flush()
        self.hub.prune()

    def _broadcast(self, msg: Any, exclude: Link | None = None) -> None:
        for link in self.hub.links:
            if link is not exclude:
                link.send(msg)

    def _drain_outbox(self, now: float) -> None:
        out = self.autopilot.out
        if not self._origin_sent and self.autopilot.ekf_origin is not None:
            # like ArduPilot, announce the new EKF origin and home on every link
            self._origin_sent = True
            self._broadcast(self._build(M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN, now))
            self._broadcast(self._build(M.MAVLINK_MSG_ID_HOME_POSITION, now))
        if out.heartbeat:
            out.heartbeat = False
            self._broadcast(self._build(HEARTBEAT, now))
        for sev, text in out.texts:
            for msg in self._statustexts(sev, text):
                self._broadcast(msg)
        out.texts.clear()
        for seq in out.reached:
            self._broadcast(M.MAVLink_mission_item_reached_message(seq))
        out.reached.clear()
        for name in out.params:
            self._broadcast(self._param_value(name))
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
        cache: dict[int, Any] = {}
        limit = now + 1e-9
        build, truth, wheels = self.telemetry.build, self.truth, self._wheels
        for link in self.hub.links:
            if link.next_any > limit:
                continue
            due = link.next_due
            iv = link.intervals
            for mid in link.schedule():
                t_due = due[mid]
                if t_due > limit:
                    continue
                interval = iv[mid]
                nxt = t_due + interval
                due[mid] = nxt if nxt > limit else now + interval
                msg = cache.get(mid)
                if msg is None:
                    msg = build(mid, now, truth, wheels)
                    cache[mid] = msg if msg is not None else False
                if msg:
                    link.send(msg)
            link.next_any = min(due[m] for m in link.schedule()) if link.schedule() else 1e300

    # ------------------------------------------------------------------ message building
    def _build(self, mid: int, now: float) -> Any:
        """One telemetry message of id mid as of now, or None if it has nothing to say."""
        return self.telemetry.build(mid, now, self.truth, self._wheels)

    # ------------------------------------------------------------------ parameters
    def _param_type(self, name: str) -> int:
        v = self.params[name]
        if name in _INT_PARAMS:
            return M.MAV_PARAM_TYPE_INT8
        float_like = (not float(v).is_integer() or any(
            k in name for k in ("SPEED", "TIME", "RADIUS", "ATC_", "WP_", "CRUISE", "LOIT_",
                                "SIM_", "GAIN", "ACCEL", "TURN_RATE", "MARGIN")))
        return M.MAV_PARAM_TYPE_REAL32 if float_like else M.MAV_PARAM_TYPE_INT16

    def _param_value(self, name: str) -> Any:
        idx = self._param_names.index(name) if name in self._param_names else 65535
        return M.MAVLink_param_value_message(name.encode(), float(self.params[name]),
                                             self._param_type(name), len(self._param_names), idx)

    def _set_param(self, name: str, value: float) -> bool:
        if name not in self.params:
            return False
        if self._param_type(name) != M.MAV_PARAM_TYPE_REAL32:
            value = float(int(round(value)))
        self.params[name] = float(value)
        self.autopilot.invalidate()
        if name.startswith("SIM_"):
            self.env = self._env_from_params()
        if name == "MAV_SYSID":
            self._sysid = int(value)
            self.hub.set_source(self._sysid, 1)
        if name == "GPS1_RATE_MS":
            self.estimator.gps_period = max(0.05, value / 1000.0)
        return True

    # ------------------------------------------------------------------ message handling
    def _for_us(self, msg: Any) -> bool:
        ts = getattr(msg, "target_system", 0)
        tc = getattr(msg, "target_component", 0)
        return ts in (0, self._sysid) and tc in (0, 1)

    def _forward(self, link: Link, msg: Any) -> None:
        """MAVLink routing: broadcasts go to every other link; targeted ones to where the
        target system was seen."""
        ts = getattr(msg, "target_system", getattr(msg, "target", None))
        tc = getattr(msg, "target_component", 0)
        raw = None
        for other in self.hub.links:
            if other is link:
                continue
            seen = other.systems_seen
            if (ts is None or ts == 0 or (ts, tc) in seen
                    or (tc == 0 and any(s == ts for s, _ in seen))):
                if raw is None:
                    raw = bytes(msg.get_msgbuf())
                other.send_raw(raw)

    def _ack(self, link: Link, msg: Any, command: int, result: int) -> None:
        link.send(M.MAVLink_command_ack_message(command, result, 0, 0, msg.get_srcSystem(),
                                                msg.get_srcComponent()))

    def _handle(self, link: Link, msg: Any, now: float) -> None:
        src = msg.get_srcSystem()
        link.systems_seen.add((src, msg.get_srcComponent()))
        self._forward(link, msg)
        t = msg.get_type()
        a = self.autopilot
        if t == "HEARTBEAT":
            a.gcs_heartbeat(src, now)
            return
        if not self._for_us(msg):
            return
        if t == "COMMAND_LONG":
            self._command(link, msg, now, msg.command,
                          [msg.param1, msg.param2, msg.param3, msg.param4, msg.param5,
                           msg.param6, msg.param7], None)
        elif t == "COMMAND_INT":
            self._command(link, msg, now, msg.command,
                          [msg.param1, msg.param2, msg.param3, msg.param4, msg.x, msg.y, msg.z],
                          msg.frame)
        elif t == "SET_MODE":
            if msg.base_mode & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                a.set_mode(int(msg.custom_mode), now)
        elif t == "SET_ATTITUDE_TARGET":
            a.set_attitude_target(msg.type_mask, tuple(msg.q), msg.body_yaw_rate, msg.thrust,
                                  now)
        elif t == "SET_POSITION_TARGET_LOCAL_NED":
            self._position_target_local(msg, now)
        elif t == "SET_POSITION_TARGET_GLOBAL_INT":
            self._position_target_global(msg, now)
        elif t == "RC_CHANNELS_OVERRIDE":
            vals = [getattr(msg, f"chan{i}_raw", 0) for i in range(1, 19)]
            a.rc_override_msg(src, vals, now)
        elif t == "PARAM_REQUEST_LIST":
            # GCS_MAVLINK::handle_param_request_list sends the banner first, on this link
            for text in BANNER:
                link.send(M.MAVLink_statustext_message(ap.SEVERITY_INFO, text.encode(), 0, 0))
            for name in self._param_names:
                link.send(self._param_value(name))
        elif t == "PARAM_REQUEST_READ":
            name = msg.param_id if isinstance(msg.param_id, str) else msg.param_id.decode()
            name = name.rstrip("\x00")
            if msg.param_index >= 0 and msg.param_index < len(self._param_names):
                name = self._param_names[msg.param_index]
            if name in self.params:
                link.send(self._param_value(name))
        elif t == "PARAM_SET":
            name = msg.param_id if isinstance(msg.param_id, str) else msg.param_id.decode()
            name = name.rstrip("\x00")
            if self._set_param(name, msg.param_value):
                self._broadcast(self._param_value(name))
        elif t == "REQUEST_DATA_STREAM":
            self._request_data_stream(link, msg, now)
        elif t == "MISSION_REQUEST_LIST":
            link.send(M.MAVLink_mission_count_message(src, msg.get_srcComponent(), 0,
                                                      getattr(msg, "mission_type", 0)))
        elif t == "MANUAL_CONTROL":
            if msg.target in (0, self._sysid):
                a.manual_control_msg(src, msg.y, msg.z, now)
        elif t == "TIMESYNC":
            if msg.tc1 == 0:  # a request: answer with our clock, echoing theirs
                link.send(M.MAVLink_timesync_message(int((now - self.boot) * 1e9), msg.ts1))
        elif t == "FILE_TRANSFER_PROTOCOL":
            self._ftp(link, msg)

    def _ftp(self, link: Link, msg: Any) -> None:
        """MAVLink FTP with no file system behind it: every file is missing, so a client's
        MAVFTP parameter download fails at once and it falls back to PARAM_REQUEST_LIST.
        Replies follow ArduPilot's GCS_FTP: seq + 1, same session, req_opcode = the request's
        opcode, NAK with the error code in data[0] (FailErrno also carries errno in data[1])."""
        payload = bytes(msg.payload)
        if len(payload) < 12:
            return
        seq = payload[0] | (payload[1] << 8)
        session, opcode = payload[2], payload[3]
        if opcode in (FTP_ACK, FTP_NAK):
            return  # not a request: ArduPilot eats these
        data = b""
        if opcode in (FTP_NONE, FTP_TERMINATE, FTP_RESET):
            reply = FTP_ACK  # nothing is open, so closing succeeds
        elif opcode in FTP_NAMED:
            reply, data = FTP_NAK, bytes((FTP_ERR_FAIL_ERRNO, ENOENT))  # as for a missing file
        elif opcode in (FTP_READ, FTP_WRITE, FTP_BURST_READ):
            reply, data = FTP_NAK, bytes((FTP_ERR_FILE_NOT_FOUND,))  # no file open
        else:
            reply, data = FTP_NAK, bytes((FTP_ERR_UNKNOWN_COMMAND,))
        out = (bytes(((seq + 1) & 0xFF, ((seq + 1) >> 8) & 0xFF, session, reply, len(data),
                      opcode, 0, 0, 0, 0, 0, 0)) + data)
        link.send(M.MAVLink_file_transfer_protocol_message(
            0, msg.get_srcSystem(), msg.get_srcComponent(), list(out.ljust(251, b"\0"))))

    def _request_data_stream(self, link: Link, msg: Any, now: float) -> None:
        rate = msg.req_message_rate if msg.start_stop else 0
        ids = (STREAMS.keys() if msg.req_stream_id == M.MAV_DATA_STREAM_ALL
               else [msg.req_stream_id])
        for sid in ids:
            for mid in STREAMS.get(sid, ()):
                if (mid in BOAT_ONLY and not self.is_boat) or (mid in ROVER_ONLY
                                                               and self.is_boat):
                    continue
                if rate > 0:
                    link.set_interval(mid, 1.0 / rate,
                                      min(link.next_due.get(mid, now), now + 1.0 / rate))
                else:
                    link.set_interval(mid, 0.0, now)

    def _command(self, link: Link, msg: Any, now: float, cmd: int, p: list[float],
                 frame: int | None) -> None:
        a = self.autopilot
        result = ap.RESULT_UNSUPPORTED
        after: list[Any] = []
        if cmd == M.MAV_CMD_DO_SET_MODE:
            # GCS_MAVLINK::_set_mode_common: only custom modes; anything else is DENIED
            result = ap.RESULT_DENIED
            if int(p[0]) & M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
                ok = a.set_mode(int(p[1]), now)
                result = ap.RESULT_ACCEPTED if ok else ap.RESULT_FAILED
        elif cmd == M.MAV_CMD_COMPONENT_ARM_DISARM:
            result = a.arm(p[0] > 0.5, now, force=int(round(p[1])) in (2989, 21196))
        elif cmd == M.MAV_CMD_DO_SET_SERVO:
            result = a.do_set_servo(int(p[0]), int(p[1]))
        elif cmd == M.MAV_CMD_SET_MESSAGE_INTERVAL:
            mid, us = int(p[0]), p[1]
            if mid not in KNOWN:
                a.out.texts.append((ap.SEVERITY_INFO, f"No ap_message for mavlink id ({mid})"))
                result = ap.RESULT_FAILED
            else:
                if us < 0:
                    iv = 0.0
                elif us == 0:
                    iv = self._defaults.get(mid, 0.0)
                else:
                    iv = us / 1e6
                link.set_interval(mid, iv, now + iv)
                result = ap.RESULT_ACCEPTED
        elif cmd == M.MAV_CMD_GET_MESSAGE_INTERVAL:
            mid = int(p[0])
            iv = link.intervals.get(mid, 0.0)
            after = [M.MAVLink_message_interval_message(mid,
                                                        int(iv * 1e6) if iv > 0 else -1)]
            result = ap.RESULT_ACCEPTED
        elif cmd == M.MAV_CMD_REQUEST_MESSAGE:
            mid = int(p[0])
            if mid in KNOWN:
                after = [self._build(mid, now)]  # may be None: nothing to say yet
                result = ap.RESULT_ACCEPTED
            else:
                result = ap.RESULT_FAILED
        elif cmd == M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            after = [self._build(M.MAVLINK_MSG_ID_AUTOPILOT_VERSION, now)]
            result = ap.RESULT_ACCEPTED
        elif cmd == M.MAV_CMD_GET_HOME_POSITION:
            # GCS_MAVLINK::handle_command_get_home_position: FAILED until home is set
            if a.home is None:
                result = ap.RESULT_FAILED
            else:
                after = [self._build(M.MAVLINK_MSG_ID_HOME_POSITION, now),
                         self._build(M.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN, now)]
                result = ap.RESULT_ACCEPTED
        elif cmd == M.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            result = ap.RESULT_ACCEPTED if a.set_mode(ap.RTL, now) else ap.RESULT_FAILED
        elif cmd == M.MAV_CMD_MISSION_START:
            result = ap.RESULT_ACCEPTED if a.set_mode(ap.AUTO, now) else ap.RESULT_FAILED
        elif cmd == M.MAV_CMD_DO_CHANGE_SPEED:
            if a.mode == ap.GUIDED and a.guided_sub in ("wp", "loiter") and p[1] > 0:
                a.guided_speed = float(p[1])
                result = ap.RESULT_ACCEPTED
            else:
                result = ap.RESULT_FAILED
        elif cmd == M.MAV_CMD_DO_REPOSITION and frame is not None:
            lat, lon = p[4] / 1e7, p[5] / 1e7
            if lat == 0 and lon == 0:
                result = ap.RESULT_DENIED
            else:
                x, y = self.home.to_local(lat, lon)
                change = bool(int(p[1]) & M.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE)
                result = a.guided_reposition(x, y, p[0], change, now)
        self._ack(link, msg, cmd, result)
        for m in after:
            if m is not None:
                link.send(m)

    def _position_target_local(self, msg: Any, now: float) -> None:
        a = self.autopilot
        if a.mode != ap.GUIDED or a.ekf_origin is None:
            return
        f = msg.coordinate_frame
        if f not in (M.MAV_FRAME_LOCAL_NED, M.MAV_FRAME_LOCAL_OFFSET_NED, M.MAV_FRAME_BODY_NED,
                     M.MAV_FRAME_BODY_OFFSET_NED):
            return
        body = f in (M.MAV_FRAME_BODY_NED, M.MAV_FRAME_BODY_OFFSET_NED)
        est = a.est
        if f == M.MAV_FRAME_LOCAL_NED:
            ox, oy = a.ekf_origin
            x, y = ox + msg.y, oy + msg.x
        elif f == M.MAV_FRAME_LOCAL_OFFSET_NED:
            x, y = est.x + msg.y, est.y + msg.x
        else:
            h = math.radians(est.heading)
            north = msg.x * math.cos(h) - msg.y * math.sin(h)
            east = msg.x * math.sin(h) + msg.y * math.cos(h)
            x, y = est.x + east, est.y + north
        a.set_position_target(type_mask=msg.type_mask, frame="body" if body else "ned", x=x, y=y,
                              vx=msg.vx, vy=msg.vy, yaw=msg.yaw, yaw_rate=msg.yaw_rate, now=now)

    def _position_target_global(self, msg: Any, now: float) -> None:
        a = self.autopilot
        if a.mode != ap.GUIDED:
            return
        if msg.coordinate_frame not in (0, 3, 5, 6, 10, 11):
            return
        x = y = None
        if (msg.type_mask & ap.POS_IGNORE) != ap.POS_IGNORE:
            if abs(msg.lat_int) > 900_000_000 or abs(msg.lon_int) > 1_800_000_000:
                return
            x, y = self.home.to_local(msg.lat_int / 1e7, msg.lon_int / 1e7)
        a.set_position_target(type_mask=msg.type_mask, frame="ned", x=x, y=y, vx=msg.vx,
                              vy=msg.vy, yaw=msg.yaw, yaw_rate=msg.yaw_rate, now=now,
                              message="SET_POSITION_TARGET_GLOBAL_INT")
