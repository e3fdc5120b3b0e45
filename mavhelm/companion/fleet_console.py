"""``mavhelm view --connect URL``: every vehicle heard on a ground station's link, one line each
(``fleet.py`` says what is kept), redrawn every ``--every`` seconds, and with ``--web`` the
same on a page (the web view's server and page, each boat a marker at its NAV_X/NAV_Y, which
are metres from its own mission's origin: boats sharing an origin share the map). It only
listens."""

from __future__ import annotations

import argparse
import time

from pymavlink import mavutil

from mavhelm.companion.fleet import Fleet
from mavhelm.companion.web.server import WebProcess, parse_address


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--connect", required=True,
                        help="where the vehicles are heard, as a ground station would use it: "
                             "udpin:0.0.0.0:14550 (MAVProxy --out, telemetry radios' "
                             "forwarders), tcp:HOST:PORT, or a serial device")
    parser.add_argument("--every", type=float, default=1.0,
                        help="seconds between redraws (default 1)")
    parser.add_argument("--baud", type=int, default=57600, help="serial speed")
    parser.add_argument("--web", metavar="[HOST:]PORT", default=None, type=_address,
                        help="also serve the fleet on a web page (HOST defaults to 127.0.0.1)")


def _address(text: str) -> str:
    try:
        parse_address(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def run(args: argparse.Namespace) -> int:
    if not args.every > 0:
        args.usage_error("--every must be a positive number of seconds")
    conn = mavutil.mavlink_connection(args.connect, baud=args.baud, source_system=255,
                                      source_component=mavutil.mavlink.MAV_COMP_ID_MISSIONPLANNER,
                                      dialect="ardupilotmega")
    fleet = Fleet()
    print(f"mavhelm view: listening on {args.connect}", flush=True)
    web = None
    try:
        web = _serve(args.web)
        _listen(conn, fleet, args.every, web)
    except KeyboardInterrupt:
        print("mavhelm view: stopped", flush=True)
    finally:
        if web is not None:
            web.stop()
        conn.close()
    return 0


def _serve(address: str | None) -> WebProcess | None:
    if address is None:
        return None
    host, port = parse_address(address)
    web = WebProcess(host, port)
    web.start()
    print(f"mavhelm view: web page on {web.url}", flush=True)
    return web


def _listen(conn, fleet: Fleet, every: float, web: WebProcess | None) -> None:
    next_draw = time.monotonic()
    while True:
        msg = conn.recv_match(blocking=True, timeout=0.1)
        now = time.monotonic()
        if msg is not None and msg.get_type() != "BAD_DATA":
            try:
                fleet.take(msg, now)
            except (ValueError, TypeError, AttributeError, OverflowError):
                pass  # a malformed message changes nothing
        if now < next_draw:
            continue
        next_draw = now + every
        stamp = time.strftime("%H:%M:%S", time.gmtime())
        print(f"mavhelm view {stamp}: {len(fleet.boats)} vehicles", flush=True)
        for line in fleet.lines(now):
            print(f"  {line}", flush=True)
        if web is not None:
            web.offer({"type": "fleet", "t": round(time.time(), 1), "boats": fleet.rows(now)})
