"""Ground truth from a real ArduPilot SITL, for the simulated serial instruments.

``mavhelm instruments`` serves the boat's serial instruments (GPS, heading, echo sounder, DVL,
range beacons) beside a *real* ArduPilot SITL instead of ``mavhelm sim``. Their truth is the
SITL's own physics state, which it sends on any MAVLink link when asked (measured on ArduRover
4.8.0-dev SITL):

- ``SIMSTATE`` (#164): lat/lng as int32 1e-7 degrees (1 cm), roll/pitch/yaw (rad, yaw from
  north, clockwise), body gyro rates (rad/s). In the ``SR_EXTRA1`` stream (1 Hz by default,
  with ATTITUDE and AHRS2). **This is the position and heading.**
- ``SIM_STATE`` (#108): the same state plus the true NED velocity ``vn``/``ve``/``vd``. Not in
  any stream: only ``MAV_CMD_SET_MESSAGE_INTERVAL`` turns it on. Its lat/lon are float32
  fields into which ArduPilot writes degrees × 1e7 (steps of 64e-7°, 0.7 m), so it is used
  **for the velocity only**. A SITL or simulator that does not send it (``mavhelm sim``
  does not) gets its velocity differentiated from SIMSTATE positions over ``window_s``
  (a velocity ``window_s / 2`` old; the feed's ``velocity_source`` says which is in use).
- Neither carries a time stamp. ArduPilot sends every message due at one moment in one
  burst, so asking ``SYSTEM_TIME`` (#2) at the same interval puts a ``time_boot_ms`` right
  before each SIMSTATE (observed order: SYSTEM_TIME, SIMSTATE, SIM_STATE): a sample's time is
  the newest ``time_boot_ms`` the autopilot sent before it.

Time base. Truth times (and so the ``t`` field of the proprietary sentences) are the
autopilot's seconds since boot plus a fixed offset, chosen at the first sample so that the
time then equals the wall clock's Unix time: exactly how ``AutopilotClock`` (``mavhelm run
--clock autopilot``) builds the companion's clock. Both then advance at the autopilot's rate,
so they differ by a constant: zero to within the link latency at ``--speedup 1``, and
``(speedup - 1) ×`` the wall seconds between the two programs' first messages otherwise
(the companion stamps instrument data by the tick it reads them in, never by these fields).
A reboot (stamps jumping back) continues the time base instead of running backwards, as
``AutopilotClock`` does. NMEA UTC is the autopilot's UTC once ``SYSTEM_TIME.time_unix_usec``
carries it (after its GPS fix), so the serial GPS and the autopilot's GPS agree; before that
it is the truth time itself (Unix seconds). Fault-scenario windows (``--scenario``) are in
autopilot boot seconds (``BootTimeScenario``), the time the SITL's own logs and messages carry.

Everything here is pure (messages in, ``Truth`` out, no sockets, no clock read unless no
``offset`` is given), so it is tested with real encoded MAVLink and no SITL.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.core.clock import boot_seconds
from mavhelm.core.geodesy import lat_lon_e7
from mavhelm.sitl.faults import Fault, Scenario
from mavhelm.sitl.flat_earth import Origin
from mavhelm.sitl.truth import Truth

TRUTH_MESSAGES = (mavlink.MAVLINK_MSG_ID_SIMSTATE, mavlink.MAVLINK_MSG_ID_SIM_STATE,
                  mavlink.MAVLINK_MSG_ID_SYSTEM_TIME)
"""What the feed asks for, all at one interval so each SIMSTATE comes with its time stamp."""
DEFAULT_RATE_HZ = 10.0
"""Truth samples per autopilot second (the heading sensor samples at 10 Hz)."""
VELOCITY_MAX_AGE_S = 1.0
"""A SIM_STATE velocity older than this (autopilot s) is not used; positions are
differentiated instead."""
VELOCITY_WINDOW_S = 1.0
"""Autopilot seconds of SIMSTATE positions differentiated when there is no SIM_STATE."""
REBOOT_JUMP_S = 1.0
"""A time stamp this far behind the last one means the autopilot restarted."""


def stream_requests(rate_hz: float, target_system: int = 1,
                    target_component: int = 1) -> list[mavlink.MAVLink_command_long_message]:
    """SET_MESSAGE_INTERVAL commands for the truth messages at ``rate_hz`` (autopilot Hz).
    Per link, exact, and ACKed on ArduPilot; REQUEST_DATA_STREAM cannot turn SIM_STATE on."""
    if rate_hz <= 0:
        raise ValueError("rate_hz must be positive")
    interval_us = 1e6 / rate_hz
    return [mavlink.MAVLink_command_long_message(
        target_system, target_component, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0,
        float(mid), interval_us, 0, 0, 0, 0, 0) for mid in TRUTH_MESSAGES]


def heading_of_yaw(yaw_rad: float) -> float:
    """MAVLink yaw (rad, clockwise from north, (-π, π]) → heading degrees in [0, 360)."""
    h = math.degrees(yaw_rad) % 360.0
    return 0.0 if h >= 360.0 else h


def truth_from_simstate(msg: mavlink.MAVLink_simstate_message, t: float, origin: Origin, *,
                        velocity: tuple[float, float] = (0.0, 0.0),
                        water_depth: float = 20.0) -> Truth:
    """One SIMSTATE as ``Truth`` at time ``t`` in ``origin``'s local frame.

    ``velocity`` is (east, north) m/s over ground. SIMSTATE knows nothing of the water, so
    surge/sway are the body-frame velocity over ground, and ``z`` is 0 (a surface vehicle).
    The yaw rate is the body z gyro, which is the heading rate for a level hull.
    """
    x, y = origin.to_local(*lat_lon_e7(msg.lat, msg.lng))
    heading = heading_of_yaw(msg.yaw)
    vx, vy = velocity
    h = math.radians(heading)
    s, c = math.sin(h), math.cos(h)
    return Truth(t=t, x=x, y=y, heading=heading, yaw_rate=math.degrees(msg.zgyro),
                 surge=vx * s + vy * c, sway=vx * c - vy * s, vx=vx, vy=vy, z=0.0,
                 water_depth=water_depth, pitch=math.degrees(msg.pitch),
                 roll=math.degrees(msg.roll))


@dataclass
class BootTimeScenario(Scenario):
    """A scenario whose fault windows are autopilot boot seconds while the ports run on truth
    time: ``gps_outage from 120 to 180`` means the SITL's 120th to 180th second, whatever the
    wall-clock offset of the truth time. ``shift`` is the feed's ``offset``."""

    shift: float = 0.0

    @classmethod
    def of(cls, scenario: Scenario) -> BootTimeScenario:
        return cls(seed=scenario.seed, faults=list(scenario.faults), name=scenario.name)

    def active(self, kind: str, t: float) -> list[Fault]:
        return super().active(kind, t - self.shift)


class TruthFeed:
    """MAVLink messages from an autopilot link in, ``Truth`` samples out.

    ``feed(msg)`` returns a ``Truth`` for each SIMSTATE of the autopilot (after its first
    HEARTBEAT names it and a ``time_boot_ms`` has been seen), else None. Messages of any other
    system or component (ground stations, the companion) are ignored: only the autopilot's
    stamps are its clock.

    ``origin``: the local frame (a mission's LatOrigin/LongOrigin); None takes the first
    SIMSTATE position, i.e. the SITL's home, which is what ``mavhelm sim --beacons`` means by
    metres from home. ``offset``: truth time = boot seconds + offset; None sets it from
    ``wall()`` (Unix seconds) at the first sample, like ``AutopilotClock``.
    """

    def __init__(self, origin: Origin | None = None, *, offset: float | None = None,
                 water_depth: float = 20.0, wall: Callable[[], float] = time.time,
                 window_s: float = VELOCITY_WINDOW_S,
                 velocity_max_age_s: float = VELOCITY_MAX_AGE_S) -> None:
        self.origin = origin
        self.offset = offset
        self.water_depth = water_depth
        self.window_s = window_s
        self.velocity_max_age_s = velocity_max_age_s
        self._wall = wall
        self.autopilot: tuple[int, int] | None = None
        self.boot_s: float | None = None
        self.utc_minus_boot: float | None = None
        self._velocity: tuple[float, float, float] | None = None   # boot s, east, north
        self._track: deque[tuple[float, float, float]] = deque()   # boot s, x, y
        self.velocity_source: str | None = None
        self.samples = 0
        self.reboots = 0
        self.last: Truth | None = None

    # -- time ------------------------------------------------------------------------------

    def time_of(self, boot_s: float) -> float:
        """Truth (companion-clock) seconds of autopilot boot time ``boot_s``."""
        if self.offset is None:
            self.offset = self._wall() - boot_s
        return boot_s + self.offset

    @property
    def gps_epoch(self) -> float | None:
        """``NmeaGps.epoch`` that makes NMEA UTC the autopilot's UTC (UTC = epoch + t), or
        None while the autopilot has no UTC (the GPS then uses t, which is Unix time)."""
        if self.utc_minus_boot is None or self.offset is None:
            return None
        return self.utc_minus_boot - self.offset

    def _stamp(self, boot_s: float) -> None:
        if self.boot_s is not None and boot_s < self.boot_s - REBOOT_JUMP_S:
            # The autopilot restarted: keep the time base running forwards from where it was.
            if self.offset is not None:
                self.offset = self.boot_s + self.offset - boot_s
            self._velocity = None
            self._track.clear()
            self.utc_minus_boot = None
            self.reboots += 1
        elif self.boot_s is not None and boot_s < self.boot_s:
            return  # a slightly older stamp (another stream's, sent late) never moves time back
        self.boot_s = boot_s

    # -- messages --------------------------------------------------------------------------

    def feed(self, msg: mavlink.MAVLink_message) -> Truth | None:
        """Take one received message; a ``Truth`` when it completes a sample."""
        kind = msg.get_type()
        source = (msg.get_srcSystem(), msg.get_srcComponent())
        if self.autopilot is None:
            if (kind == "HEARTBEAT" and msg.autopilot != mavlink.MAV_AUTOPILOT_INVALID
                    and msg.type != mavlink.MAV_TYPE_GCS):
                self.autopilot = source
            return None
        if source != self.autopilot:
            return None
        boot_ms = getattr(msg, "time_boot_ms", None)
        if isinstance(boot_ms, int):
            self._stamp(boot_seconds(boot_ms))
        if kind == "SYSTEM_TIME":
            if msg.time_unix_usec and self.boot_s is not None:
                self.utc_minus_boot = msg.time_unix_usec / 1e6 - boot_seconds(msg.time_boot_ms)
        elif kind == "SIM_STATE":
            if self.boot_s is not None:
                self._velocity = (self.boot_s, msg.ve, msg.vn)
        elif kind == "SIMSTATE":
            return self._sample(msg)
        return None

    def _sample(self, msg: mavlink.MAVLink_simstate_message) -> Truth | None:
        if self.boot_s is None:
            return None  # no stamp yet: the sample cannot be placed in time
        boot = self.boot_s
        try:
            lat, lon = lat_lon_e7(msg.lat, msg.lng)
        except ValueError:
            return None  # not a place on the earth: a corrupted sample
        if self.origin is None:
            self.origin = Origin(lat, lon)
        x, y = self.origin.to_local(lat, lon)
        self._track.append((boot, x, y))
        while self._track and boot - self._track[0][0] > self.window_s:
            self._track.popleft()
        truth = truth_from_simstate(msg, self.time_of(boot), self.origin,
                                    velocity=self._velocity_at(boot),
                                    water_depth=self.water_depth)
        self.samples += 1
        self.last = truth
        return truth

    def _velocity_at(self, boot: float) -> tuple[float, float]:
        if self._velocity is not None and boot - self._velocity[0] <= self.velocity_max_age_s:
            self.velocity_source = "SIM_STATE"
            return self._velocity[1], self._velocity[2]
        self.velocity_source = "differentiated"
        (b0, x0, y0), (b1, x1, y1) = self._track[0], self._track[-1]
        if b1 - b0 < 0.05:
            return 0.0, 0.0  # one sample so far: nothing to differentiate yet
        return (x1 - x0) / (b1 - b0), (y1 - y0) / (b1 - b0)
