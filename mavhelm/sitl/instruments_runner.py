"""``mavhelm instruments``: the simulated serial instruments, driven by a real ArduPilot SITL.

``mavhelm sim --sensors`` serves the boat's serial instruments from its own vehicle model. This
serves the same kit (``runner.make_sensor_ports``: NMEA GPS, heading, echo sounder, DVL, range
beacons, one pseudo-terminal each) from the ground truth of *another* simulator — a real
ArduPilot SITL's SIMSTATE/SIM_STATE (``truth_feed``) — so the companion can run beside the
real autopilot with the same instruments it has on a boat::

    ardurover --model motorboat ...                  # SERIAL0 5760, SERIAL1 5762, SERIAL2 5763
    mavhelm run mission.moos --connect tcp:127.0.0.1:5760 --clock autopilot
    mavhelm instruments --truth tcp:127.0.0.1:5762 --mission mission.moos \\
        --beacons "1:0,100;2:100,0" --ranging radio

It prints each port's ``/dev/pts/N`` at once (the SITL need not be up yet), connects to the
truth link (retrying: a real SITL opens 5762/5763 only after a client is on 5760), asks for the
truth messages, and updates every port with each sample. A lost or silent link is said and
retried; the instruments are quiet meanwhile, as a boat's are when their source is off.
Stop with Ctrl-C.
"""

from __future__ import annotations

import argparse
import dataclasses
import errno
import select
import socket
import sys
import time
from collections.abc import Callable, Sequence
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.core.backoff import Backoff
from mavhelm.sitl.flat_earth import Origin
from mavhelm.sitl.models import MODEL_NAMES, get_model
from mavhelm.sitl.runner import (
    describe_port,
    make_sensor_ports,
    parse_beacons,
    positive_number,
)
from mavhelm.sitl.truth import Truth
from mavhelm.sitl.truth_feed import (
    DEFAULT_RATE_HZ,
    BootTimeScenario,
    TruthFeed,
    stream_requests,
)

PREFIX = "mavhelm instruments:"
SOURCE_SYSTEM = 255
SOURCE_COMPONENT = mavlink.MAV_COMP_ID_PERIPHERAL
"""Who the requests come from. The runner sends no heartbeat, so it never shows up as a
vehicle or a ground station to the others on the SITL's links."""
REQUEST_AGAIN_S = 2.0
"""Wall seconds without truth after asking before asking again (a request made while the
autopilot is still starting can be ignored)."""
SLOW_FACTOR = 2.5
"""Samples further apart than this many periods mean the rate asked for was not granted."""
SIM_STATE_TRIES = 3
"""Requests before settling for differentiated velocity (a simulator without SIM_STATE)."""
SILENT_S = 5.0
"""Wall seconds without a byte after which a connected link counts as lost."""


def parse_truth(text: str) -> tuple[str, int]:
    """``tcp:HOST:PORT`` → (host, port)."""
    parts = text.split(":")
    if len(parts) != 3 or parts[0].lower() != "tcp" or not parts[1]:
        raise argparse.ArgumentTypeError(f"--truth wants tcp:HOST:PORT, not {text!r}")
    try:
        port = int(parts[2])
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"bad port in {text!r}") from exc
    if not 0 < port < 65536:
        raise argparse.ArgumentTypeError(f"bad port in {text!r}")
    return parts[1], port


def parse_origin(text: str) -> Origin:
    """``LAT,LON[,ALT]`` (degrees; the altitude is accepted and unused: a flat, sea-level
    frame)."""
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        vals = []
    if len(vals) not in (2, 3) or not -90 <= vals[0] <= 90 or not -180 <= vals[1] <= 180:
        raise argparse.ArgumentTypeError(f"--origin wants LAT,LON[,ALT], not {text!r}")
    return Origin(vals[0], vals[1])


class TruthLink:
    """The TCP MAVLink link to the autopilot: connect, send, read what has arrived. Owns the
    socket itself (pymavlink encodes and parses) so that a closed connection is told apart
    from one with nothing to say."""

    def __init__(self, host: str, port: int) -> None:
        self.host, self.port = host, port
        self.sock: socket.socket | None = None
        self.mav = mavlink.MAVLink(None, srcSystem=SOURCE_SYSTEM, srcComponent=SOURCE_COMPONENT)
        self.mav.robust_parsing = True   # noise on the line becomes BAD_DATA, not an exception

    @property
    def where(self) -> str:
        return f"tcp:{self.host}:{self.port}"

    def connect(self) -> None:
        """Raises OSError when the port does not accept."""
        sock = socket.create_connection((self.host, self.port), timeout=2.0)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        sock.setblocking(False)
        self.sock = sock
        self.mav = mavlink.MAVLink(None, srcSystem=SOURCE_SYSTEM, srcComponent=SOURCE_COMPONENT)
        self.mav.robust_parsing = True

    def send(self, msg: mavlink.MAVLink_message) -> None:
        assert self.sock is not None
        data = msg.pack(self.mav)
        self.sock.settimeout(2.0)   # a few bytes: wait for the socket rather than cut them
        try:
            self.sock.sendall(data)
        finally:
            self.sock.setblocking(False)

    def read(self, timeout_s: float) -> tuple[list[mavlink.MAVLink_message], bool]:
        """The messages that arrived within ``timeout_s``, and whether the peer has closed."""
        assert self.sock is not None
        select.select([self.sock], [], [], timeout_s)
        out: list[mavlink.MAVLink_message] = []
        while True:
            try:
                data = self.sock.recv(65536)
            except (BlockingIOError, InterruptedError):
                return out, False
            if not data:
                return out, True
            out.extend(self.mav.parse_buffer(data) or [])

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()
            self.sock = None


class InstrumentsRunner:
    """The loop: keep the link up, ask for truth, turn it into samples, update the ports.

    ``step()`` does one pass and returns the samples it made, so tests can drive it; ``run()``
    loops until interrupted. ``say`` is where the console lines go.
    """

    def __init__(self, link: TruthLink, ports: Sequence[Any], feed: TruthFeed, *,
                 rate_hz: float = DEFAULT_RATE_HZ, say: Callable[[str], None] = print,
                 wall: Callable[[], float] = time.monotonic) -> None:
        self.link = link
        self.ports = list(ports)
        self.feed = feed
        self.rate_hz = rate_hz
        self.say = say
        self.wall = wall
        self.connected = False
        self._backoff = Backoff()  # the project's reconnect timing (1 s doubling to 8 s)
        self._waiting_said = False
        self._asked_at: float | None = None
        self._asks = 0
        self._heard_at = 0.0
        self._truth_at: float | None = None
        self._last_t: float | None = None
        self._gap: float | None = None     # autopilot s between the last two samples
        self._announced = False
        self._velocity_said: str | None = None
        self.connections = 0

    # -- link ------------------------------------------------------------------------------

    def _connect(self, now: float) -> None:
        try:
            self.link.connect()
        except OSError as exc:
            if not self._waiting_said:
                hint = (" (a real SITL opens 5762/5763 only once a client is on 5760)"
                        if exc.errno == errno.ECONNREFUSED else "")
                self.say(f"{PREFIX} waiting for {self.link.where}: "
                         f"{exc.strerror or exc}{hint}; {self._backoff.describe()}")
                self._waiting_said = True
            self._backoff.failed(now)
            return
        self.connected = True
        self.connections += 1
        self._waiting_said = False
        self._backoff.succeeded()
        self._asked_at = None
        self._asks = 0
        self._heard_at = now
        self._truth_at = None
        self._gap = None
        self.feed.autopilot = None   # learn it again: it may be another autopilot now
        self.say(f"{PREFIX} connected to {self.link.where}")

    def _lost(self, now: float, why: str) -> None:
        self.link.close()
        self.connected = False
        self._backoff.failed(now)
        self.say(f"{PREFIX} lost {self.link.where}: {why}; retrying")

    def _ask(self, now: float) -> None:
        system, component = self.feed.autopilot or (1, 1)
        for msg in stream_requests(self.rate_hz, system, component):
            self.link.send(msg)
        self._asked_at = now
        self._asks += 1

    # -- the loop --------------------------------------------------------------------------

    def step(self, timeout_s: float = 0.05) -> list[Truth]:
        now = self.wall()
        if not self.connected:
            if self._backoff.due(now):
                self._connect(now)
            if not self.connected:
                time.sleep(min(timeout_s, self._backoff.wait_s(now)))
                return []
        try:
            msgs, closed = self.link.read(timeout_s)
        except OSError as exc:
            self._lost(self.wall(), exc.strerror or str(exc))
            return []
        now = self.wall()
        samples: list[Truth] = []
        for msg in msgs:
            if msg.get_type() == "BAD_DATA":
                continue
            self._heard_at = now
            truth = self.feed.feed(msg)
            if truth is not None:
                samples.append(truth)
                self._update(truth, now)
        if closed:
            self._lost(now, "the autopilot closed the connection")
            return samples
        if now - self._heard_at > SILENT_S:
            self._lost(now, f"nothing received for {SILENT_S:g} s")
            return samples
        try:
            self._keep_asking(now)
        except OSError as exc:
            self._lost(now, exc.strerror or str(exc))
        return samples

    def _keep_asking(self, now: float) -> None:
        """Ask again until the truth comes at the rate asked for: a request made while the
        autopilot is still starting is ignored (SIMSTATE then stays at its 1 Hz default), and
        one that asks SIM_STATE of a simulator without it is tried ``SIM_STATE_TRIES`` times."""
        if self.feed.autopilot is None:
            return  # ask the autopilot by its ids, once its heartbeat has named them
        if self._asked_at is not None and now - self._asked_at < REQUEST_AGAIN_S:
            return
        if self._asked_at is None:
            self._ask(now)
            return
        why = None
        if self._truth_at is None or now - self._truth_at >= REQUEST_AGAIN_S:
            why = f"no SIMSTATE from {self.link.where}" + (
                " yet (is it a SITL?)" if self._truth_at is None else "")
        elif self._gap is not None and self._gap > SLOW_FACTOR / self.rate_hz:
            why = f"SIMSTATE every {self._gap:.2f} autopilot s, not at {self.rate_hz:g} Hz"
        elif self.feed.velocity_source != "SIM_STATE" and self._asks < SIM_STATE_TRIES:
            why = "no SIM_STATE (true velocity)"
        if why is not None:
            if self._asks >= 1:
                self.say(f"{PREFIX} {why}; asking again")
            self._ask(now)

    def _update(self, truth: Truth, now: float) -> None:
        self._truth_at = now
        if self._last_t is not None and truth.t > self._last_t:
            self._gap = truth.t - self._last_t
        self._last_t = truth.t
        if not self._announced:
            self._announced = True
            o, autopilot = self.feed.origin, self.feed.autopilot
            assert o is not None and self.feed.offset is not None and autopilot is not None
            self.say(f"{PREFIX} truth from autopilot {autopilot[0]} at "
                     f"{self.rate_hz:g} Hz; time stamps = autopilot boot s + "
                     f"{self.feed.offset:.3f}; origin {o.lat:.7f},{o.lon:.7f}")
        if self.feed.samples >= 5 and self.feed.velocity_source != self._velocity_said:
            self._velocity_said = self.feed.velocity_source
            how = ("SIM_STATE (true velocity)" if self._velocity_said == "SIM_STATE" else
                   f"differentiated SIMSTATE positions over {self.feed.window_s:g} s "
                   "(no SIM_STATE)")
            self.say(f"{PREFIX} velocity from {how}")
        for port in self.ports:
            if isinstance(port.scenario, BootTimeScenario) and self.feed.offset is not None:
                port.scenario.shift = self.feed.offset
            sensor = port.sensor
            if hasattr(sensor, "origin") and self.feed.origin is not None:
                sensor.origin = self.feed.origin
            if hasattr(sensor, "epoch"):
                sensor.epoch = self.feed.gps_epoch
            port.update(truth, truth.t)

    def run(self) -> None:
        """Until Ctrl-C."""
        while True:
            self.step()

    def close(self) -> None:
        self.link.close()


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``mavhelm instruments`` options."""
    parser.add_argument("--truth", type=parse_truth, required=True, metavar="tcp:HOST:PORT",
                        help="the SITL link to take ground truth from (SIMSTATE), e.g. "
                             "tcp:127.0.0.1:5762 so the companion keeps 5760")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--origin", type=parse_origin, default=None, metavar="LAT,LON[,ALT]",
                       help="the local frame's origin (default: where the vehicle is at the "
                            "first SIMSTATE, i.e. the SITL's home)")
    where.add_argument("--mission", default=None,
                       help="use this mission's LatOrigin/LongOrigin as the local frame")
    parser.add_argument("--beacons", type=parse_beacons, default=None,
                        metavar="ID:X,Y[,Z][,TURNAROUND];...",
                        help="range beacons in the local frame (m, X east, Y north, Z up; "
                             "turn-around s), as for mavhelm sim")
    parser.add_argument("--ranging", choices=("acoustic", "radio"), default="acoustic",
                        help="with --beacons: acoustic LBL (default) or radio ranges")
    parser.add_argument("--model", choices=MODEL_NAMES, default="motorboat", metavar="NAME",
                        help="the vehicle model, as the SITL's --model (default motorboat): a "
                             "boat gets echo sounder + DVL, a rover wheel odometry, no sounder")
    parser.add_argument("--water-depth", type=positive_number, default=20.0,
                        help="the seabed's depth below the surface, m (default 20)")
    parser.add_argument("--rate", type=positive_number, default=DEFAULT_RATE_HZ,
                        help="truth samples per autopilot second (default 10)")
    parser.add_argument("--scenario", default=None,
                        help="fault scenario file (.scn); its windows are autopilot seconds")
    parser.add_argument("--seed", type=int, default=None,
                        help="random seed (default: the scenario's, else 0)")


def run(args: argparse.Namespace) -> int:
    """Serve until Ctrl-C. Returns the process exit status."""
    from mavhelm.sitl.faults import Scenario, ScenarioError

    vehicle = get_model(args.model).vehicle
    try:
        scenario = Scenario.from_file(args.scenario) if args.scenario else Scenario()
    except ScenarioError as exc:
        print(f"{PREFIX} {exc}", file=sys.stderr)
        return 2
    if args.seed is not None:
        scenario = dataclasses.replace(scenario, seed=args.seed)
    scenario = BootTimeScenario.of(scenario)   # fault windows in autopilot boot seconds
    origin: Origin | None = args.origin
    if args.mission:
        from mavhelm.core.errors import LocatedError
        from mavhelm.core.geodesy import mission_origin
        from mavhelm.core.mission import load_mission

        try:
            mo = mission_origin(load_mission(args.mission))
        except LocatedError as exc:
            print(f"{PREFIX} {exc}", file=sys.stderr)
            return 2
        origin = Origin(mo.lat, mo.lon)
    host, port = args.truth
    try:
        # Built before the origin is known (the first SIMSTATE may give it): the GPS's origin
        # is set with every sample, so a placeholder here is never used.
        ports = make_sensor_ports(vehicle, origin or Origin(0.0, 0.0), scenario,
                                  args.beacons, args.ranging, epoch=None)
    except OSError as exc:
        print(f"{PREFIX} cannot open a pseudo-terminal: {exc}", file=sys.stderr)
        return 1
    feed = TruthFeed(origin, water_depth=args.water_depth)
    runner = InstrumentsRunner(TruthLink(host, port), ports, feed, rate_hz=args.rate,
                               say=lambda text: print(text, flush=True))
    try:
        print(f"{PREFIX} {vehicle} instruments, truth from tcp:{host}:{port}"
              + (f", origin {origin.lat:.7f},{origin.lon:.7f}" if origin else ""), flush=True)
        for p in ports:
            print(f"{PREFIX} {describe_port(p)}", flush=True)
        try:
            runner.run()
        except KeyboardInterrupt:
            print(f"{PREFIX} stopped", flush=True)
            return 0
    finally:
        runner.close()
        for p in ports:
            p.close()
    return 0
