"""The companion's tick on the wall clock while its autopilot link is refused, broken, and
flooded: tick period (median, p99, worst) and the process's memory during a flood.

A fake autopilot on loopback TCP sends ArduPilot-shaped telemetry (HEARTBEAT 1 Hz, ATTITUDE
10 Hz, GPS 5 Hz) to a real Companion built from examples/demo.moos, ticking at its AppTick
(10 Hz) with the same loop as ``mavhelm run``. Phases: the port refused (companion started
first), normal, the connection reset and the port closed for 5 s, normal again, then one
second of flood (as many valid frames as loopback takes).
"""

from __future__ import annotations

import multiprocessing
import resource
import socket
import statistics
import time
from pathlib import Path

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.companion import Companion
from mavhelm.core.clock import WallClock
from tests.support.ports import free_port

ROOT = Path(__file__).resolve().parents[1]


PHASES = ("refuse", "up", "down", "flood", "stop")


class FakeAutopilot(multiprocessing.Process):
    """In its own process, so its sending does not take the companion's interpreter lock."""

    def __init__(self, port: int) -> None:
        super().__init__(daemon=True)
        self.port = port
        self.mav = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
        self._phase = multiprocessing.Value("i", 0)
        self._flood_bytes = multiprocessing.Value("q", 0)

    @property
    def phase(self) -> str:
        return PHASES[self._phase.value]

    @phase.setter
    def phase(self, name: str) -> None:
        self._phase.value = PHASES.index(name)

    @property
    def flood_bytes(self) -> int:
        return self._flood_bytes.value

    def frames(self, t: float, kind: str) -> bytes:
        if kind == "heartbeat":
            msg = mavlink.MAVLink_heartbeat_message(11, 3, 0x89, 15, 4, 3)
        elif kind == "attitude":
            msg = mavlink.MAVLink_attitude_message(int(t * 1000), 0.0, 0.0, 1.0, 0.0, 0.0, 0.1)
        else:
            msg = mavlink.MAVLink_gps_raw_int_message(int(t * 1e6), 3, 564120000, -54760000, 0,
                                                      80, 65535, 100, 9000, 12)
        return bytes(msg.pack(self.mav))

    def run(self) -> None:
        server = None
        conn = None
        t0 = time.monotonic()
        n = 0
        while self.phase != "stop":
            if self.phase in ("refuse", "down"):
                if conn is not None:
                    conn.close()
                    conn = None
                if server is not None:
                    server.close()
                    server = None
                time.sleep(0.01)
                continue
            if server is None:
                server = socket.socket()
                server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
                server.bind(("127.0.0.1", self.port))
                server.listen(1)
                server.settimeout(0.05)
            if conn is None:
                try:
                    conn, _ = server.accept()
                except TimeoutError:
                    continue
            t = time.monotonic() - t0
            try:
                if self.phase == "flood":
                    chunk = self.frames(t, "attitude") * 2000
                    conn.sendall(chunk)
                    self._flood_bytes.value += len(chunk)
                    continue
                out = self.frames(t, "attitude")
                if n % 2 == 0:
                    out += self.frames(t, "gps")
                if n % 10 == 0:
                    out += self.frames(t, "heartbeat")
                conn.sendall(out)
            except OSError:
                conn.close()
                conn = None
            n += 1
            time.sleep(0.1)


def rss_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def main() -> None:
    port = free_port()
    ap = FakeAutopilot(port)
    ap.start()
    clock = WallClock()
    companion = Companion.build(ROOT / "examples" / "demo.moos", clock,
                                connect=f"tcp:127.0.0.1:{port}", echo=None)
    period = companion.tick_period
    ticks: dict[str, list[float]] = {}
    rss: dict[str, list[float]] = {}
    plan = [("refused", "refuse", 3.0), ("normal", "up", 4.0), ("broken", "down", 5.0),
            ("restored", "up", 4.0), ("flood", "flood", 1.0), ("after flood", "up", 3.0)]
    next_tick = clock.now()
    last = None
    for name, phase, seconds in plan:
        ap.phase = phase
        end = clock.now() + seconds
        while clock.now() < end:
            now = clock.now()
            companion.tick(now)
            companion.idle()
            if last is not None:
                ticks.setdefault(name, []).append(now - last)
            last = now
            rss.setdefault(name, []).append(rss_mb())
            next_tick += period
            if next_tick < clock.now() - period:
                next_tick = clock.now()
            clock.sleep_until(next_tick)
    ap.phase = "stop"
    companion.close()
    ap.join(5)
    print(f"companion tick at AppTick {1 / period:g} Hz (period {period * 1000:.0f} ms), "
          "wall clock, loopback TCP")
    for name, _, _ in plan:
        gaps = sorted(ticks.get(name, [0.0]))
        p99 = gaps[min(len(gaps) - 1, int(0.99 * len(gaps)))]
        print(f"  {name:12} tick period median {statistics.median(gaps) * 1000:6.1f} ms  "
              f"p99 {p99 * 1000:6.1f} ms  worst {gaps[-1] * 1000:6.1f} ms   "
              f"RSS {min(rss[name]):.0f}-{max(rss[name]):.0f} MB")
    stats = companion.bridge.link.stats
    print(f"  flood: {ap.flood_bytes / 1e6:.1f} MB sent in 1 s; the link read "
          f"{stats.bytes_read / 1e6:.1f} MB in all and dropped {stats.bytes_dropped / 1e6:.1f} MB"
          f" unparsed; reconnects {stats.connects - 1}")


if __name__ == "__main__":
    main()
