"""Benchmark: the simulator alone in lockstep (one TCP client draining the default streams plus
GPS_RAW_INT at 5 Hz and ATTITUDE at 10 Hz), with and without a fault scenario. Prints figures.
"""

from __future__ import annotations

import socket
import time
from pathlib import Path

from mavhelm.core.clock import SimClock
from mavhelm.sitl.faults import Scenario
from mavhelm.sitl.simulator import Simulator

SIM_SECONDS = 300.0
STEP = 0.05
SCENARIO = Path(__file__).resolve().parent.parent / "examples/scenarios/gps_outage_harbour.scn"


def speedup(scenario: Scenario | None) -> tuple[float, int]:
    clock = SimClock(0.0)
    sim = Simulator(clock, ports=(0,), fast_start=True, scenario=scenario)
    client = socket.create_connection(("127.0.0.1", sim.ports[0]))
    client.setblocking(False)
    while not sim.links:
        sim.service(0.0)
    link = sim.links[0]
    link.set_interval(24, 0.2, 0.0)
    link.set_interval(30, 0.1, 0.0)
    t0 = time.perf_counter()
    try:
        for _ in range(int(SIM_SECONDS / STEP)):
            sim.step(clock.advance(STEP))
            try:
                while client.recv(65536):
                    pass
            except BlockingIOError:
                pass
    finally:
        client.close()
        sim.close()
    return SIM_SECONDS / (time.perf_counter() - t0), link.bytes_sent


def main() -> None:
    for label, scenario in (("no faults", None),
                            ("gps_outage_harbour.scn", Scenario.from_file(SCENARIO))):
        factor, sent = speedup(scenario)
        print(f"simulator alone, {label:<24s} {factor:6.0f}x real time "
              f"({sent / SIM_SECONDS / 1024:.1f} KiB/s of MAVLink)")


if __name__ == "__main__":
    main()
