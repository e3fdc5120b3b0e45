"""``mavhelm sim``: the simulator served in real time (or N× faster) for a ground station.

Run it, point QGroundControl / MAVProxy / the companion at tcp:127.0.0.1:5760 (or 5762,
5763, or a --out UDP address), and it behaves like ArduPilot Rover SITL. Stop with Ctrl-C.
"""

from __future__ import annotations

import argparse
import select
import sys
import time

from mavhelm.geo import Origin

TICK = 0.01  # wall seconds between simulator steps


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


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The ``mavhelm sim`` options."""
    parser.add_argument("--vehicle", choices=("boat", "rover"), default="boat")
    parser.add_argument("--variant", default=None,
                        help="boat: skid (default, twin thrusters) | rudder; "
                             "rover: ackermann (default) | skid")
    parser.add_argument("--port", type=_ports, default=[5760, 5762, 5763],
                        help="TCP ports to listen on, comma separated (default 5760,5762,5763)")
    parser.add_argument("--host", default="127.0.0.1", help="address to listen on")
    parser.add_argument("--out", type=_out, action="append", default=[],
                        help="also send to udp:HOST:PORT (repeatable)")
    parser.add_argument("--home", type=_home, default=(56.0, -3.0, 0.0),
                        help="start position and heading: LAT,LON,HEADING")
    parser.add_argument("--speedup", type=float, default=1.0,
                        help="run N times faster than real time (default 1)")
    parser.add_argument("--fast-start", action="store_true",
                        help="compress the start-up timeline to ~3 s")
    parser.add_argument("--scenario", default=None, help="fault scenario file (.scn)")
    parser.add_argument("--seed", type=int, default=None,
                        help="random seed (default: the scenario's, else 0)")
    parser.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                        help="set a parameter at start, e.g. SIM_CURRENT_SPD=0.5 (repeatable)")


def _params(items: list[str]) -> dict[str, float]:
    out: dict[str, float] = {}
    for item in items:
        name, sep, value = item.partition("=")
        if not sep:
            raise ValueError(f"--param wants NAME=VALUE, not {item!r}")
        out[name.strip().upper()] = float(value)
    return out


def run(args: argparse.Namespace) -> int:
    """Serve until Ctrl-C. Returns the process exit status."""
    from mavhelm.sitl.simulator import Simulator

    if args.variant is not None:
        allowed = ("skid", "rudder") if args.vehicle == "boat" else ("ackermann", "skid")
        if args.variant not in allowed:
            print(f"mavhelm sim: --variant for a {args.vehicle} must be one of "
                  f"{', '.join(allowed)}", file=sys.stderr)
            return 2
    if args.speedup <= 0:
        print("mavhelm sim: --speedup must be positive", file=sys.stderr)
        return 2
    scenario = None
    seed = args.seed
    if args.scenario:
        from mavhelm.sitl.faults import Scenario, ScenarioError

        try:
            scenario = Scenario.from_file(args.scenario)
        except ScenarioError as exc:
            print(f"mavhelm sim: {exc}", file=sys.stderr)
            return 2
        if seed is None:
            seed = scenario.seed
    try:
        params = _params(getattr(args, "param", []) or [])
    except ValueError as exc:
        print(f"mavhelm sim: {exc}", file=sys.stderr)
        return 2
    lat, lon, heading = args.home
    clock = PacedClock(args.speedup)
    try:
        sim = Simulator(clock, vehicle=args.vehicle, variant=args.variant, ports=args.port,
                        host=args.host, udp_out=args.out, home=Origin(lat, lon),
                        start_heading=heading, fast_start=args.fast_start, scenario=scenario,
                        params=params, seed=seed or 0, epoch=time.time())
    except OSError as exc:
        print(f"mavhelm sim: cannot listen: {exc}", file=sys.stderr)
        return 1
    where = ", ".join(f"tcp:{args.host}:{p}" for p in sim.ports)
    outs = ", ".join(f"udp:{h}:{p}" for h, p in args.out)
    print(f"mavhelm sim: {args.vehicle} ({sim.variant}) at {lat:.6f},{lon:.6f} "
          f"listening on {where}" + (f", sending to {outs}" if outs else ""), flush=True)
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
