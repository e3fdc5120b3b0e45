"""``mavhelm view --connect URL``: every vehicle heard on a ground station's link, one line each
(``fleet.py`` says what is kept), redrawn every ``--every`` seconds. It only listens."""

from __future__ import annotations

import argparse
import time

from pymavlink import mavutil

from mavhelm.companion.fleet import Fleet


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--connect", required=True,
                        help="where the vehicles are heard, as a ground station would use it: "
                             "udpin:0.0.0.0:14550 (MAVProxy --out, telemetry radios' "
                             "forwarders), tcp:HOST:PORT, or a serial device")
    parser.add_argument("--every", type=float, default=1.0,
                        help="seconds between redraws (default 1)")
    parser.add_argument("--baud", type=int, default=57600, help="serial speed")


def run(args: argparse.Namespace) -> int:
    if not args.every > 0:
        args.usage_error("--every must be a positive number of seconds")
    conn = mavutil.mavlink_connection(args.connect, baud=args.baud, source_system=255,
                                      source_component=mavutil.mavlink.MAV_COMP_ID_MISSIONPLANNER,
                                      dialect="ardupilotmega")
    fleet = Fleet()
    print(f"mavhelm view: listening on {args.connect}", flush=True)
    next_draw = time.monotonic()
    try:
        while True:
            msg = conn.recv_match(blocking=True, timeout=0.1)
            now = time.monotonic()
            if msg is not None and msg.get_type() != "BAD_DATA":
                fleet.take(msg, now)
            if now >= next_draw:
                next_draw = now + args.every
                stamp = time.strftime("%H:%M:%S", time.gmtime())
                print(f"mavhelm view {stamp}: {len(fleet.boats)} vehicles", flush=True)
                for line in fleet.lines(now):
                    print(f"  {line}", flush=True)
    except KeyboardInterrupt:
        print("mavhelm view: stopped", flush=True)
    finally:
        conn.close()
    return 0
