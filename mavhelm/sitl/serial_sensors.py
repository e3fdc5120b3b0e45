"""Serial instruments of the simulated boat, each on its own pseudo-terminal.

A real boat's companion computer reads a GPS, a heading sensor, an echo sounder, a DVL (or wheel
odometry) and a range-beacon receiver on serial ports. The simulator gives each one a pty, so the
companion opens ``/dev/pts/N`` with pyserial exactly as it would open ``/dev/ttyUSB0``.

Two layers, so the physics is testable without any I/O:

- a **sensor model** (``NmeaGps``, ``HeadingSensor``, ``EchoSounder``, ``DvlSensor``,
  ``AcousticLbl``, ``RadioRanges``): ``sample(truth, t, rng, scenario) -> list[str]`` returns the
  sentences due at its own rate up to ``t`` (noise, offsets, model-level faults: outliers,
  multipath, outages, drop-outs);
- a **port** (``SensorPort`` in memory, ``PtySerialPort`` on a pty): ``update(truth, now)`` once
  per simulator step asks the model, applies the line-level faults (garbage, truncation,
  latency/jitter) and writes every line due by ``now`` without ever blocking.

Every random number comes from ``scenario.rng(port name)`` (noise) and
``scenario.rng(port name + "/line")`` (line faults): same seed, same bytes, on any machine.
"""

from __future__ import annotations

import array
import fcntl
import math
import os
import termios
import time
import tty
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from mavhelm.sitl import nmea
from mavhelm.sitl.faults import Scenario
from mavhelm.sitl.flat_earth import Origin
from mavhelm.sitl.truth import Truth

#: Sound speed (m/s) used for acoustic travel times.
SOUND_SPEED = 1500.0
#: UTC (Unix seconds) of simulation time 0 when the simulation clock is not Unix time itself.
DEFAULT_EPOCH = 1_767_225_600.0  # 2026-01-01T00:00:00Z
#: At most this many samples are produced per call after a long gap, so a stall cannot flood.
MAX_CATCH_UP = 200


def utc_of(t: float, epoch: float | None) -> float:
    """UTC Unix seconds for simulation time ``t``: ``epoch + t``, or ``t`` itself when ``epoch``
    is None and ``t`` already looks like Unix time (after 2001), as a wall-clock run's is."""
    if epoch is None:
        return t if t >= 1e9 else DEFAULT_EPOCH + t
    return epoch + t


def _pose_at(truth: Truth, ts: float) -> tuple[float, float, float]:
    """(x, y, heading) at ``ts`` extrapolated from ``truth`` with its velocities: a sample
    scheduled between two simulator steps sees the vehicle where it was at its own time."""
    dt = ts - truth.t
    return truth.x + truth.vx * dt, truth.y + truth.vy * dt, (truth.heading + truth.yaw_rate * dt)


def body_velocity(truth: Truth) -> tuple[float, float]:
    """Velocity over ground in the body frame: (forward, starboard), m/s."""
    h = math.radians(truth.heading)
    s, c = math.sin(h), math.cos(h)
    return truth.vx * s + truth.vy * c, truth.vx * c - truth.vy * s


class SerialSensor(Protocol):
    """What a port needs from a sensor model."""

    name: str

    def sample(
        self, truth: Truth, t: float, rng: np.random.Generator, scenario: Scenario | None = None
    ) -> list[str]: ...


@dataclass
class _Periodic:
    """Samples at ``phase_s + k / rate_hz``; integer k so no drift over an hour's run."""

    rate_hz: float = 1.0
    phase_s: float = 0.0
    _k: int | None = field(default=None, init=False, repr=False)

    def due_times(self, t: float) -> list[float]:
        """Scheduled sample times in (last call, t], oldest first (late ones skipped past
        MAX_CATCH_UP)."""
        if self.rate_hz <= 0:
            return []
        period = 1.0 / self.rate_hz
        if self._k is None:  # first call: start at the first slot not before t
            self._k = max(0, math.ceil((t - self.phase_s) / period - 1e-9))
        last = math.floor((t - self.phase_s) / period + 1e-9)
        if last < self._k:
            return []
        first = max(self._k, last - MAX_CATCH_UP + 1)
        self._k = last + 1
        return [self.phase_s + k * period for k in range(first, last + 1)]


def _port_faults(scenario: Scenario | None, kind: str, t: float, name: str) -> list:
    if scenario is None:
        return []
    return scenario.active_matching(kind, t, port=name)


# ---------------------------------------------------------------------------- sensor models


@dataclass
class NmeaGps(_Periodic):
    """A GNSS receiver: GGA + RMC at ``rate_hz``. Error = white noise + a slow wander
    (first-order Gauss-Markov, like real multipath/atmosphere), per axis."""

    origin: Origin = field(default_factory=lambda: Origin(0.0, 0.0))
    name: str = "nmea_gps"
    noise_m: float = 0.5
    wander_m: float = 1.0
    wander_tau_s: float = 60.0
    speed_noise_mps: float = 0.05
    satellites: int = 10
    hdop: float = 0.9
    epoch: float | None = None
    talker: str = "GP"
    _wander: tuple[float, float] | None = field(default=None, init=False, repr=False)
    _last_ts: float | None = field(default=None, init=False, repr=False)

    def sample(
        self, truth: Truth, t: float, rng: np.random.Generator, scenario: Scenario | None = None
    ) -> list[str]:
        lines: list[str] = []
        for ts in self.due_times(t):
            x, y, _ = _pose_at(truth, ts)
            n = rng.standard_normal(5)  # always 5 draws: faults never shift the noise stream
            if self._wander is None:
                wx, wy = self.wander_m * n[0], self.wander_m * n[1]
            else:
                last = self._last_ts if self._last_ts is not None else ts
                a = math.exp(-(ts - last) / self.wander_tau_s)
                k = self.wander_m * math.sqrt(max(0.0, 1.0 - a * a))
                wx, wy = a * self._wander[0] + k * n[0], a * self._wander[1] + k * n[1]
            self._wander, self._last_ts = (wx, wy), ts
            utc = utc_of(ts, self.epoch)
            if _port_faults(scenario, "nmea_gps_outage", ts, self.name):
                lines += [
                    nmea.gga(utc, None, None, satellites=0, talker=self.talker),
                    nmea.rmc(utc, None, None, talker=self.talker),
                ]
                continue
            lat, lon = self.origin.to_global(
                x + wx + self.noise_m * n[2], y + wy + self.noise_m * n[3]
            )
            vx, vy = truth.vx, truth.vy
            sog = max(0.0, math.hypot(vx, vy) + self.speed_noise_mps * n[4])
            cog = math.degrees(math.atan2(vx, vy)) % 360.0
            lines += [
                nmea.gga(
                    utc,
                    lat,
                    lon,
                    satellites=self.satellites,
                    hdop=self.hdop,
                    altitude=truth.z,
                    talker=self.talker,
                ),
                nmea.rmc(utc, lat, lon, sog, cog, talker=self.talker),
            ]
        return lines


@dataclass
class HeadingSensor(_Periodic):
    """A heading sensor (gyro compass / GNSS compass) sending HDT; ``offset_deg`` is its
    installation misalignment (the spec's sensor *twist*)."""

    rate_hz: float = 10.0
    name: str = "heading"
    noise_deg: float = 0.3
    offset_deg: float = 0.0
    talker: str = "HE"

    def sample(
        self, truth: Truth, t: float, rng: np.random.Generator, scenario: Scenario | None = None
    ) -> list[str]:
        lines = []
        for ts in self.due_times(t):
            _, _, heading = _pose_at(truth, ts)
            noise = self.noise_deg * rng.standard_normal()
            lines.append(nmea.hdt(heading + self.offset_deg + noise, talker=self.talker))
        return lines


@dataclass
class EchoSounder(_Periodic):
    """An echo sounder sending DPT and DBT: depth below the transducer, which sits
    ``draft_m`` below the waterline. Beyond ``max_range_m`` or in a ``depth_dropout`` it loses
    the bottom and sends empty depth fields."""

    rate_hz: float = 2.0
    name: str = "depth"
    draft_m: float = 0.3
    noise_m: float = 0.03
    noise_frac: float = 0.005
    max_range_m: float = 100.0
    sentences: tuple[str, ...] = ("DPT", "DBT")
    talker: str = "SD"

    def sample(
        self, truth: Truth, t: float, rng: np.random.Generator, scenario: Scenario | None = None
    ) -> list[str]:
        lines: list[str] = []
        for ts in self.due_times(t):
            n, u = rng.standard_normal(), rng.random()
            true_depth = truth.water_depth - self.draft_m + truth.z
            depth: float | None = max(
                0.0, true_depth + (self.noise_m + self.noise_frac * true_depth) * n
            )
            drop = max(
                (
                    f.num("prob", 1.0)
                    for f in _port_faults(scenario, "depth_dropout", ts, self.name)
                ),
                default=0.0,
            )
            if true_depth > self.max_range_m or u < drop:
                depth = None
            for kind in self.sentences:
                if kind == "DPT":
                    lines.append(
                        nmea.dpt(depth, self.draft_m, self.max_range_m, talker=self.talker)
                    )
                elif kind == "DBT":
                    lines.append(nmea.dbt(depth, talker=self.talker))
                else:
                    raise ValueError(f"echo sounder cannot send {kind}")
        return lines


@dataclass
class DvlSensor(_Periodic):
    """Body velocity over ground (``$PMVHDVL``): a bottom-tracking DVL, or with
    ``report_altitude=False`` and ``max_altitude_m=inf`` a rover's wheel odometry. Loses bottom
    lock (status V) beyond ``max_altitude_m``."""

    rate_hz: float = 5.0
    name: str = "dvl"
    noise_mps: float = 0.01
    scale_error: float = 0.0
    draft_m: float = 0.3
    max_altitude_m: float = 80.0
    report_altitude: bool = True

    def sample(
        self, truth: Truth, t: float, rng: np.random.Generator, scenario: Scenario | None = None
    ) -> list[str]:
        lines = []
        for ts in self.due_times(t):
            n = rng.standard_normal(4)
            fwd, stbd = body_velocity(truth)
            altitude = truth.water_depth - self.draft_m + truth.z
            alt_field = altitude + 0.02 * n[3] if self.report_altitude else None
            if altitude > self.max_altitude_m:
                lines.append(nmea.pmvhdvl(ts, None, None, None, None))
                continue
            k = 1.0 + self.scale_error
            lines.append(
                nmea.pmvhdvl(
                    ts,
                    k * fwd + self.noise_mps * n[0],
                    k * stbd + self.noise_mps * n[1],
                    self.noise_mps * n[2],
                    alt_field,
                )
            )
        return lines


@dataclass(frozen=True)
class Beacon:
    """A range beacon at local (x east, y north, z up) metres; ``turnaround_s`` is an acoustic
    transponder's reply delay (included in the two-way travel time it produces)."""

    id: str
    x: float
    y: float
    z: float = 0.0
    turnaround_s: float = 0.0


def _range_errors(scenario: Scenario | None, t: float, beacon: str, u: float, mag: float) -> float:
    """Extra one-way metres from range_outlier (with its prob, |N(0, sigma)|, always long)
    and range_multipath (bias) faults active at ``t`` for ``beacon``."""
    if scenario is None:
        return 0.0
    extra = sum(
        f.num("bias") for f in scenario.active_matching("range_multipath", t, beacon=beacon)
    )
    outliers = scenario.active_matching("range_outlier", t, beacon=beacon)
    if outliers:
        worst = max(outliers, key=lambda f: f.num("prob"))
        if u < worst.num("prob"):
            extra += abs(mag) * worst.num("sigma")
    return extra


@dataclass
class AcousticLbl(_Periodic):
    """An LBL transceiver: pings every ``1/rate_hz`` s; each beacon hears the ping, waits its
    turn-around time and replies; the vehicle keeps moving meanwhile. When the listen window
    closes it sends one ``$PMVHLBL`` line with every beacon's two-way travel time (s), time
    stamped with the ping time — so the data are already ``listen_window_s`` old (spec 2.2.7).

    Errors: timing noise ``noise_s``, a systematic one-way ``offset_m`` (e.g. a mis-declared
    turn-around), range_outlier / range_multipath faults (one-way metres), no reply beyond
    ``max_range_m`` or after the window.
    """

    beacons: Sequence[Beacon] = ()
    rate_hz: float = 0.5
    name: str = "lbl"
    sound_speed: float = SOUND_SPEED
    listen_window_s: float = 3.0
    transducer_depth_m: float = 0.5
    noise_s: float = 0.0002
    offset_m: float = 0.0
    max_range_m: float = 2000.0
    _pending: list[dict] = field(default_factory=list, init=False, repr=False)

    def _xyz(self, truth: Truth, ts: float) -> tuple[float, float, float]:
        x, y, _ = _pose_at(truth, ts)
        return x, y, truth.z - self.transducer_depth_m

    def sample(
        self, truth: Truth, t: float, rng: np.random.Generator, scenario: Scenario | None = None
    ) -> list[str]:
        c = self.sound_speed
        for t0 in self.due_times(t):
            p0 = self._xyz(truth, t0)
            out = {b.id: math.dist(p0, (b.x, b.y, b.z)) for b in self.beacons}
            self._pending.append({"t0": t0, "out": out, "arrive": {}})
        lines: list[str] = []
        still: list[dict] = []
        for ping in self._pending:
            t0 = ping["t0"]
            for b in self.beacons:
                if b.id in ping["arrive"] or ping["out"][b.id] > self.max_range_m:
                    continue
                leave = t0 + ping["out"][b.id] / c + b.turnaround_s
                ta = max(t, leave)
                for _ in range(4):  # fixed point: the reply meets the moving vehicle
                    ta = leave + math.dist(self._xyz(truth, ta), (b.x, b.y, b.z)) / c
                if ta <= t:
                    ping["arrive"][b.id] = ta
            if t < t0 + self.listen_window_s:
                still.append(ping)
                continue
            replies: list[tuple[str, float | None]] = []
            for b in self.beacons:
                n, u, mag = rng.standard_normal(), rng.random(), rng.standard_normal()
                ta = ping["arrive"].get(b.id)
                if ta is None or ta > t0 + self.listen_window_s:
                    replies.append((b.id, None))
                    continue
                extra = self.offset_m + _range_errors(scenario, t0, b.id, u, mag)
                replies.append((b.id, ta - t0 + 2.0 * extra / c + self.noise_s * n))
            lines.append(nmea.pmvhlbl(t0, replies))
        self._pending = still
        return lines


@dataclass
class RadioRanges(_Periodic):
    """A radio ranging receiver (UWB / the Plaza data set's kind): one ``$PMVHRNG`` range per
    sample, to the beacons in turn (``round_robin``) or to all of them. Errors: Gaussian
    ``noise_m``, systematic ``offset_m`` (Plaza1: +2.8 m, MAD 0.8 m ⇒ noise_m ≈ 1.2), intrinsic
    ``outlier_prob``/``outlier_sigma_m``, the range faults, ``miss_prob`` and ``max_range_m``."""

    beacons: Sequence[Beacon] = ()
    rate_hz: float = 2.0
    name: str = "ranges"
    antenna_height_m: float = 1.0
    noise_m: float = 0.3
    offset_m: float = 0.0
    outlier_prob: float = 0.0
    outlier_sigma_m: float = 20.0
    miss_prob: float = 0.0
    max_range_m: float = 300.0
    round_robin: bool = True
    _next_beacon: int = field(default=0, init=False, repr=False)

    def sample(
        self, truth: Truth, t: float, rng: np.random.Generator, scenario: Scenario | None = None
    ) -> list[str]:
        lines = []
        for ts in self.due_times(t):
            if not self.beacons:
                break
            if self.round_robin:
                targets = [self.beacons[self._next_beacon % len(self.beacons)]]
                self._next_beacon += 1
            else:
                targets = list(self.beacons)
            x, y, _ = _pose_at(truth, ts)
            for b in targets:
                n, m1, m2 = rng.standard_normal(3)
                miss, u1, u2 = rng.random(3)
                true_r = math.dist((x, y, truth.z + self.antenna_height_m), (b.x, b.y, b.z))
                if true_r > self.max_range_m or miss < self.miss_prob:
                    continue
                r = true_r + self.offset_m + self.noise_m * n
                if u1 < self.outlier_prob:
                    r += abs(m1) * self.outlier_sigma_m
                r += _range_errors(scenario, ts, b.id, u2, m2)
                lines.append(nmea.pmvhrng(ts, b.id, max(0.0, r)))
        return lines


# --------------------------------------------------------------------------------- ports


class SensorPort:
    """A sensor's serial line, in memory: applies line faults and latency, keeps the bytes in
    ``output`` (tests compare these streams byte for byte). Subclasses write them somewhere."""

    def __init__(
        self,
        sensor: SerialSensor,
        scenario: Scenario | None = None,
        *,
        name: str | None = None,
        eol: str = "\r\n",
        keep_output: bool = True,
    ) -> None:
        if name is not None:
            sensor.name = name  # one name for noise stream, fault selectors and port
        self.sensor = sensor
        self.name = sensor.name
        self.scenario = scenario if scenario is not None else Scenario()
        self.eol = eol
        self._rng = self.scenario.rng(self.name)
        self._line_rng = self.scenario.rng(self.name + "/line")
        self._queue: list[tuple[float, bytes]] = []
        self._last_due = -math.inf
        self.keep_output = keep_output
        self.output = bytearray()
        self.stats = {"lines": 0, "written": 0, "dropped": 0, "garbled": 0, "truncated": 0}

    def _faults(self, kind: str, t: float) -> list:
        return self.scenario.active_matching(kind, t, port=self.name)

    def _corrupt(self, line: str, now: float) -> bytes:
        data = line.encode("ascii")
        r = self._line_rng
        trunc = max((f.num("prob") for f in self._faults("serial_truncate", now)), default=0.0)
        if trunc > 0 and r.random() < trunc:
            star = data.rfind(b"*")
            end = star if star > 1 else len(data)
            data = data[: int(r.integers(1, max(2, end)))]  # cut before the checksum
            self.stats["truncated"] += 1
        garbage = max((f.num("prob") for f in self._faults("serial_garbage", now)), default=0.0)
        if garbage > 0 and r.random() < garbage:
            junk = r.integers(0, 256, size=int(r.integers(1, 9)), dtype=np.uint8).tobytes()
            at = int(r.integers(0, len(data) + 1))
            data = data[:at] + junk + data[at:]
            self.stats["garbled"] += 1
        return data + self.eol.encode("ascii")

    def _delay(self, now: float) -> float:
        lat = [
            f for f in self.scenario.active("sensor_latency", now) if f.matches(sensor=self.name)
        ]
        delay = 0.0
        for f in lat:
            jitter = f.num("jitter", 0.0)
            delay += f.num("delay") + (jitter * self._line_rng.random() if jitter > 0 else 0.0)
        return delay

    def _due_lines(self, truth: Truth, now: float) -> list[bytes]:
        for line in self.sensor.sample(truth, now, self._rng, self.scenario):
            self.stats["lines"] += 1
            data = self._corrupt(line, now)
            due = max(now + self._delay(now), self._last_due)  # serial data never overtakes
            self._last_due = due
            self._queue.append((due, data))
        ready = [d for due, d in self._queue if due <= now]
        self._queue = [(due, d) for due, d in self._queue if due > now]
        return ready

    def poll(self, truth: Truth, now: float) -> bytes:
        """Sample the sensor up to ``now``; return the bytes due by ``now`` (faults applied),
        without writing them anywhere."""
        return b"".join(self._due_lines(truth, now))

    def update(self, truth: Truth, now: float) -> int:
        """Once per simulator step: emit every line due by ``now``. Returns bytes written."""
        lines = self._due_lines(truth, now)
        return self._write(lines) if lines else 0

    def _write(self, lines: list[bytes]) -> int:
        data = b"".join(lines)
        if self.keep_output:
            self.output += data
        self.stats["written"] += len(lines)
        return len(data)

    def settle(self) -> None:
        """Lockstep: return once what was written is readable (in memory it always is)."""

    def close(self) -> None:
        """Nothing to release in memory; ptys override."""

    def __enter__(self) -> SensorPort:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


PTY_SETTLE_S = 1.0
"""Longest wall-time wait for a pty's bytes to reach its slave side (lockstep only)."""
PTY_READ_BUFFER = 4095
"""A pty's line-discipline buffer: more than this waits in the kernel until the reader reads."""


class PtySerialPort(SensorPort):
    """A sensor on a pseudo-terminal: the companion opens ``slave_path`` with pyserial.

    The master is non-blocking: when the reader is slow or absent and the pty buffer fills,
    whole lines are dropped and counted in ``stats["dropped"]`` — the simulator never waits on
    a serial reader. A line only partly accepted is finished first next time, so no line is
    cut by the simulator itself. Bytes the companion writes to the port are read and discarded
    (their count is in ``stats["rx_bytes"]``).
    """

    def __init__(
        self,
        sensor: SerialSensor,
        scenario: Scenario | None = None,
        *,
        name: str | None = None,
        eol: str = "\r\n",
        keep_output: bool = False,
    ) -> None:
        super().__init__(sensor, scenario, name=name, eol=eol, keep_output=keep_output)
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no CR/LF translation, no echo: bytes pass as on a UART
        os.set_blocking(self._master, False)
        self.slave_path: str = os.ttyname(self._slave)
        self._partial = b""
        self._readable_at_least: int | None = None
        self.stats["rx_bytes"] = 0
        self.stats["bytes"] = 0

    def _send(self, chunk: bytes) -> int:
        try:
            return os.write(self._master, chunk)
        except (BlockingIOError, InterruptedError):
            return 0

    def _write(self, lines: list[bytes]) -> int:
        self._drain_input()
        unread = self._unread() if self._readable_at_least is None else 0
        if self.keep_output:
            self.output += b"".join(lines)
        total = 0
        if self._partial:
            n = self._send(self._partial)
            self._partial = self._partial[n:]
            total += n
        for i, line in enumerate(lines):
            if self._partial:
                self.stats["dropped"] += len(lines) - i
                break
            n = self._send(line)
            total += n
            if n == 0:
                self.stats["dropped"] += 1
            else:
                self.stats["written"] += 1
                self._partial = line[n:]
        self.stats["bytes"] += total
        self._readable_at_least = (unread if self._readable_at_least is None
                                   else self._readable_at_least) + total
        return total

    def _unread(self) -> int:
        """Bytes waiting in the slave's read buffer (the companion has not read them yet)."""
        if self._slave < 0:
            return 0
        count = array.array("i", [0])
        try:
            fcntl.ioctl(self._slave, termios.FIONREAD, count)
        except OSError:
            return 0
        return count[0]

    def settle(self, timeout_s: float = PTY_SETTLE_S) -> None:
        """Wait (briefly, in wall time) until the bytes written this step have reached the slave.

        The kernel hands a pty's bytes from master to slave on a worker thread; on a loaded
        machine that can take several of the lockstep's simulated ticks, and a reader would then
        stamp a heading ticks late. Lockstep calls this after each simulator step so that a line
        is readable in the step that wrote it, as on a real UART."""
        want, self._readable_at_least = self._readable_at_least, None
        if want is None:
            return
        want = min(want, PTY_READ_BUFFER)
        deadline = time.monotonic() + timeout_s
        while self._unread() < want and time.monotonic() < deadline:
            time.sleep(0.0005)

    def _drain_input(self) -> None:
        while True:
            try:
                chunk = os.read(self._master, 4096)
            except (BlockingIOError, InterruptedError, OSError):
                return
            if not chunk:
                return
            self.stats["rx_bytes"] += len(chunk)

    def close(self) -> None:
        """Close both ends; a companion still holding the slave then sees EOF / errors."""
        for fd in (self._master, self._slave):
            if fd >= 0:
                try:
                    os.close(fd)
                except OSError:
                    pass
        self._master = self._slave = -1

    def __del__(self) -> None:  # a forgotten port must not leak two fds per test
        if getattr(self, "_master", -1) >= 0:
            self.close()


def update_all(ports: Sequence[SensorPort], truth: Truth, now: float) -> None:
    """Convenience for the simulator loop: update every port, in order."""
    for port in ports:
        port.update(truth, now)


def default_ports(
    origin: Origin,
    scenario: Scenario | None = None,
    beacons: Sequence[Beacon] = (),
    *,
    ranging: str = "acoustic",
    pty: bool = True,
) -> list[SensorPort]:
    """The usual boat kit with default settings: NMEA GPS, HDT heading, echo sounder, DVL, and
    (if ``beacons``) an acoustic LBL transceiver or a radio ranging receiver (``ranging``)."""
    sensors: list[SerialSensor] = [
        NmeaGps(origin=origin),
        HeadingSensor(),
        EchoSounder(),
        DvlSensor(),
    ]
    if beacons:
        if ranging == "acoustic":
            sensors.append(AcousticLbl(beacons=beacons))
        elif ranging == "radio":
            sensors.append(RadioRanges(beacons=beacons))
        else:
            raise ValueError(f"ranging must be 'acoustic' or 'radio', not {ranging!r}")
    cls = PtySerialPort if pty else SensorPort
    return [cls(s, scenario) for s in sensors]
