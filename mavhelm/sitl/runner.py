"""``mavhelm sim``: the simulator served in real time (or N× faster) for a ground station.

Run it, point QGroundControl / MAVProxy / the companion at tcp:127.0.0.1:5760 (or 5762,
5763, or a --out UDP address), and it behaves like ArduPilot Rover SITL. Stop with Ctrl-C.
With ``--sensors`` it also serves the boat's serial instruments (NMEA GPS, heading, echo
sounder, DVL, range beacons) on pseudo-terminals and prints each one's ``/dev/pts/N``.
"""

from __future__ import annotations

import argparse
import math
import select
import sys
import time
from typing import Any

from mavhelm.sitl.flat_earth import Origin
from mavhelm.sitl.models import DEFAULT_MODEL, MODEL_NAMES, get_model

TICK = 0.01  # wall seconds between simulator steps
DEFAULT_HOME = (56.0, -3.0, 0.0)


def _port_free(host: str, port: int) -> bool:
    import socket

    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((host, port))
        except OSError:
            return False
    return True


class PacedClock:
    """Simulated seconds since start, running ``speedup`` times faster than the wall clock."""

    def __init__(self, speedup: float = 1.0) -> None:
        if speedup <= 0:
            raise ValueError("speedup must be positive")
        self.speedup = speedup
        self._start = time.monotonic()

    def now(self) -> float:
        return (time.monotonic() - self._start) * self.speedup


def _ports(text: str) -> list[int]:
    try:
        return [int(p) for p in text.split(",") if p.strip()]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"ports must be numbers, not {text!r}") from exc


def _out(text: str) -> tuple[str, int]:
    parts = text.split(":")
    if len(parts) != 3 or parts[0].lower() != "udp":
        raise argparse.ArgumentTypeError(f"--out wants udp:HOST:PORT, not {text!r}")
    try:
        return parts[1], int(parts[2])
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"bad port in {text!r}") from exc


def positive_number(text: str) -> float:
    """An argparse ``type=``: a positive, finite number."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not 0.0 < value < math.inf:
        raise argparse.ArgumentTypeError(f"expected a positive number, not {text!r}")
    return value


def _param(text: str) -> tuple[str, float]:
    """``NAME=VALUE`` of ``--param``."""
    name, sep, value = text.partition("=")
    try:
        number = float(value)
    except ValueError:
        number = math.nan
    if not sep or not name.strip() or not math.isfinite(number):
        raise argparse.ArgumentTypeError(f"--param wants NAME=VALUE, not {text!r}")
    return name.strip().upper(), number


def _home(text: str) -> tuple[float, float, float]:
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"--home wants LAT,LON[,HEADING], not {text!r}") from exc
    if len(vals) == 2:
        vals.append(0.0)
    if len(vals) != 3 or not -90 <= vals[0] <= 90 or not -180 <= vals[1] <= 180:
        raise argparse.ArgumentTypeError(f"--home wants LAT,LON[,HEADING], not {text!r}")
    return vals[0], vals[1], vals[2]


def parse_beacons(text: str) -> list[Any]:
    """``ID:X,Y[,Z][,TURNAROUND];...`` (local metres: X east, Y north, Z up; turn-around s)."""
    from mavhelm.sitl.serial_sensors import Beacon

    out = []
    for item in text.split(";"):
        if not item.strip():
            continue
        bid, sep, rest = item.partition(":")
        try:
            vals = [float(v) for v in rest.split(",")]
        except ValueError:
            vals = []
        if not sep or not bid.strip() or not 2 <= len(vals) <= 4:
            raise argparse.ArgumentTypeError(
                f"--beacons wants ID:X,Y[,Z][,TURNAROUND];..., not {item!r}")
        out.append(Beacon(bid.strip(), *vals))
    if not out:
        raise argparse.ArgumentTypeError("--beacons names no beacon")
    return out


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``mavhelm sim`` options."""
    parser.add_argument("--model", default=DEFAULT_MODEL, choices=MODEL_NAMES, metavar="NAME",
                        help="vehicle model: ArduPilot SITL's motorboat (steering + throttle), "
                             "motorboat-skid (twin thrusters), rover, rover-skid; or mavhelm's "
                             "own hulls: mavhelm-boat (default: twin thrusters, BlueBoat-like), "
                             "mavhelm-boat-rudder, mavhelm-rover (Ackermann), mavhelm-rover-skid")
    parser.add_argument("--defaults", default=None, metavar="FILE[,FILE...]",
                        help="ArduPilot .parm files applied over the parameter table, in "
                             "order, as the SITL's --defaults (e.g. rover.parm,motorboat.parm)")
    parser.add_argument("--port", type=_ports, default=[5760, 5762, 5763],
                        help="TCP ports to listen on, comma separated (default 5760,5762,5763)")
    parser.add_argument("--host", default="127.0.0.1", help="address to listen on")
    parser.add_argument("--out", type=_out, action="append", default=[],
                        help="also send to udp:HOST:PORT (repeatable)")
    parser.add_argument("--home", type=_home, default=None,
                        help="start position and heading: LAT,LON,HEADING (default: the "
                             "--mission's origin, else 56.0,-3.0)")
    parser.add_argument("--mission", default=None,
                        help="start at this mission's LatOrigin/LongOrigin (a mission's "
                             "waypoints are metres from its origin)")
    parser.add_argument("--speedup", type=positive_number, default=1.0,
                        help="run N times faster than real time (default 1)")
    parser.add_argument("--fast-start", action="store_true",
                        help="compress the start-up timeline to ~3 s")
    parser.add_argument("--scenario", default=None, help="fault scenario file (.scn)")
    parser.add_argument("--seed", type=int, default=None,
                        help="random seed (default: the scenario's, else 0)")
    parser.add_argument("--param", action="append", type=_param, default=[], metavar="NAME=VALUE",
                        help="set a parameter at start, e.g. SIM_CURRENT_SPD=0.5 (repeatable)")
    parser.add_argument("--sensors", action="store_true",
                        help="serve the serial sensors (NMEA GPS, heading, depth, DVL) on "
                             "pseudo-terminals and print their /dev/pts paths")
    parser.add_argument("--beacons", type=parse_beacons, default=None,
                        metavar="ID:X,Y[,Z][,TURNAROUND];...",
                        help="range beacons in the local frame (m from home, X east, Y north, "
                             "Z up; turn-around s) for a ranging sensor (needs --sensors)")
    parser.add_argument("--ranging", choices=("acoustic", "radio"), default="acoustic",
                        help="with --beacons: acoustic LBL (default) or radio ranges")


_SENTENCES = {"NmeaGps": "NMEA GGA+RMC", "HeadingSensor": "NMEA HDT",
              "EchoSounder": "NMEA DPT+DBT", "DvlSensor": "$PMVHDVL body velocity",
              "AcousticLbl": "$PMVHLBL travel times", "RadioRanges": "$PMVHRNG ranges"}


def describe_port(port: Any) -> str:
    """``nmea_gps on /dev/pts/7 (NMEA GGA+RMC, 1 Hz)``."""
    sensor = port.sensor
    what = _SENTENCES.get(type(sensor).__name__, type(sensor).__name__)
    if type(sensor).__name__ == "DvlSensor" and not sensor.report_altitude:
        what = "$PMVHDVL wheel odometry"
    beacons = getattr(sensor, "beacons", None)
    if beacons:
        what += f", {len(beacons)} beacon{'s' if len(beacons) != 1 else ''}"
    return f"{port.name} on {port.slave_path} ({what}, {sensor.rate_hz:g} Hz)"


def make_sensor_ports(vehicle: str, origin: Origin, scenario: Any, beacons: list[Any] | None,
                      ranging: str, epoch: float | None = None) -> list[Any]:
    """The serial sensor kit on ptys: ``default_ports`` for a boat; a rover has no echo
    sounder and its "DVL" is wheel odometry (no altitude, never loses lock)."""
    from mavhelm.sitl.serial_sensors import DvlSensor, PtySerialPort, default_ports

    ports = default_ports(origin, scenario, beacons or (), ranging=ranging, pty=True)
    try:
        if vehicle == "rover":
            keep: list[Any] = []
            for port in ports:
                if port.name in ("depth", "dvl"):
                    port.close()
                    if port.name == "dvl":
                        keep.append(PtySerialPort(
                            DvlSensor(report_altitude=False, max_altitude_m=math.inf),
                            scenario))
                else:
                    keep.append(port)
            ports = keep
        for port in ports:
            if hasattr(port.sensor, "epoch"):
                port.sensor.epoch = epoch  # NMEA UTC = the simulator's GPS time
    except BaseException:
        for port in ports:
            port.close()
        raise
    return ports


class _Refused(Exception):
    """A start-up problem: its message goes to stderr and ``status`` is the exit status."""

    def __init__(self, message: str, status: int = 2) -> None:
        super().__init__(message)
        self.status = status


def _scenario(args: argparse.Namespace) -> tuple[Any, int | None]:
    """(the fault scenario or None, the seed: --seed, else the scenario's)."""
    if not args.scenario:
        return None, args.seed
    from mavhelm.sitl.faults import Scenario, ScenarioError

    try:
        scenario = Scenario.from_file(args.scenario)
    except ScenarioError as exc:
        raise _Refused(str(exc)) from None
    return scenario, scenario.seed if args.seed is None else args.seed


def _defaults(args: argparse.Namespace) -> Any:
    """The --defaults files, read leniently (their skipped lines said on stderr), or None."""
    if not getattr(args, "defaults", None):
        return None
    from mavhelm.sitl.parm_file import ParmFileError, read_defaults

    try:
        defaults = read_defaults(args.defaults, strict=False)
    except ParmFileError as exc:
        raise _Refused(f"--defaults: {exc}") from None
    for skipped in defaults.skipped:
        print(f"mavhelm sim: {skipped} (skipped, as ArduPilot does)", file=sys.stderr)
    return defaults


def _start(args: argparse.Namespace) -> tuple[float, float, float]:
    """(lat, lon, heading): --home, else the --mission's origin, else DEFAULT_HOME."""
    if args.home is not None:
        return args.home
    if not getattr(args, "mission", None):
        return DEFAULT_HOME
    from mavhelm.core.errors import LocatedError
    from mavhelm.core.geodesy import mission_origin
    from mavhelm.core.mission import load_mission

    try:
        origin = mission_origin(load_mission(args.mission))
    except LocatedError as exc:
        raise _Refused(str(exc)) from None
    return origin.lat, origin.lon, 0.0


def _sensor_ports(args: argparse.Namespace, vehicle: str, home: Origin, scenario: Any,
                  seed: int | None, epoch: float) -> list[Any]:
    """The serial instruments' ptys with --sensors (none without)."""
    beacons = getattr(args, "beacons", None)
    if not getattr(args, "sensors", False):
        if beacons:
            raise _Refused("--beacons needs --sensors")
        return []
    from mavhelm.sitl.faults import Scenario

    # the serial noise comes from the scenario's streams; --seed seeds them without one
    sensor_scenario = scenario if scenario is not None else Scenario(seed=seed or 0)
    try:
        return make_sensor_ports(vehicle, home, sensor_scenario, beacons,
                                 getattr(args, "ranging", "acoustic"), epoch)
    except OSError as exc:
        raise _Refused(f"cannot open a pseudo-terminal: {exc}", 1) from None


def _listen_refused(args: argparse.Namespace, exc: OSError) -> _Refused:
    """Why the simulator could not listen, with free ports to try when they are taken."""
    busy = [p for p in args.port if p and not _port_free(args.host, p)]
    if not busy:
        return _Refused(f"cannot listen: {exc}", 1)
    spare = ",".join(str(p + 10) for p in args.port)
    return _Refused(f"TCP port {busy[0]} on {args.host} is already in use (another SITL or "
                    f"mavhelm sim?): choose free ones with --port, e.g. --port {spare}", 1)


def run(args: argparse.Namespace) -> int:
    """Serve until Ctrl-C. Returns the process exit status."""
    try:
        return _run(args)
    except _Refused as exc:
        print(f"mavhelm sim: {exc}", file=sys.stderr)
        return exc.status


def _run(args: argparse.Namespace) -> int:
    from mavhelm.sitl.simulator import Simulator

    model = get_model(args.model)
    scenario, seed = _scenario(args)
    params = dict(getattr(args, "param", []) or [])
    defaults = _defaults(args)
    lat, lon, heading = _start(args)
    home = Origin(lat, lon)
    epoch = time.time()
    clock = PacedClock(args.speedup)
    ports = _sensor_ports(args, model.vehicle, home, scenario, seed, epoch)
    try:
        try:
            sim = Simulator(clock, model=model, ports=args.port, host=args.host,
                            udp_out=args.out, home=home,
                            start_heading=heading, fast_start=args.fast_start,
                            scenario=scenario, params=params, seed=seed or 0, epoch=epoch,
                            serial_sensors=ports,
                            defaults=defaults)
        except OSError as exc:
            raise _listen_refused(args, exc) from None
        where = ", ".join(f"tcp:{args.host}:{p}" for p in sim.ports)
        outs = ", ".join(f"udp:{h}:{p}" for h, p in args.out)
        print(f"mavhelm sim: {model.name} at {lat:.6f},{lon:.6f} "
              f"listening on {where}" + (f", sending to {outs}" if outs else ""), flush=True)
        for port in ports:
            print(f"mavhelm sim: {describe_port(port)}", flush=True)
        return _serve(sim, clock)
    finally:
        for port in ports:
            port.close()


def _serve(sim: Any, clock: PacedClock) -> int:
    """Step the simulator on the paced clock until Ctrl-C."""
    try:
        while True:
            sim.step(clock.now())
            socks = [s for s in sim.hub.servers] + [lk.sock for lk in sim.links]
            select.select(socks, [], [], TICK)
    except KeyboardInterrupt:
        print("mavhelm sim: stopped", flush=True)
        return 0
    finally:
        sim.close()
