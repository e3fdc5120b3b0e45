"""Benchmark: what the web view costs the companion's tick.

The demo mission, handed over in lockstep and then paced in real time for ``PACED_S`` seconds
(as on the boat: a frame every 0.25 s of wall time, not hundreds a second as an unpaced
lockstep would make), run without the web view, then with it serving a page that a separate
process reads over the websocket as a browser would (every frame JSON-decoded); the same again
in the other order and once more, so a drift of the shared machine's load shows. Prints the whole
companion tick's median and p99 for each, on the wall clock (what the helm sees, with whatever
else the computer does) and in CPU time (the tick's own work, which the machine's load does not
blur), the frames the page got, and, with the view, the CPU p99 of the ticks that sent a frame
against the others (the view puts a due frame off on a slow tick, so its work lands in the
slack: the ticks with a frame should not be the slowest).

Measured on the project's 2-core machine with nothing else running (its wall-clock p99 is
dominated by the host pausing the whole machine, 1.3–5 ms in runs without the view, so read the
CPU figures): two full runs of this benchmark gave a pooled CPU p99 of 1321 → 1343 µs (+1.6 %)
and 1379 → 1438 µs (+4.3 %; runs without the view alone spread 1239–1481 µs); in every run
with the view the ticks that sent a frame had a lower CPU p99 than those that did not
(1120–1283 against 1366–1591 µs); the view's own part of a tick, median 17 µs. The CPU median
rises more (643–679 → 698–737 µs, ~+8 %), beyond the view's own 17 µs: the server process and
the page's reader run on the other core of this 2-vCPU machine and slow the tick's thread
there. Before the tick handed the frame's making to the server: CPU p99 +15.6 %, wall +22 %.

Run: ``.venv/bin/python -m benchmarks.bench_web`` from the repository root.
"""

from __future__ import annotations

import asyncio
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from mavhelm.companion.web.server import WebProcess
from mavhelm.companion.web.view import WebView
from mavhelm.demo.harness import SimulatedRun

DEMO = Path(__file__).resolve().parent.parent / "examples" / "demo.moos"
PACED_S = 60.0


async def _read_frames(url: str) -> None:
    import aiohttp

    frames = 0
    async with aiohttp.ClientSession() as session:
        async with session.ws_connect(url) as ws:
            async for msg in ws:
                json.loads(msg.data)
                frames += 1
                if frames % 50 == 0:
                    print(frames, flush=True)


def client(url: str) -> None:
    """The page's side: read frames until the server goes away. It stands for a browser on the
    operator's computer, not on the boat's, so it runs at the lowest priority here: the
    benchmark measures what serving costs the companion, not what a browser beside it would."""
    os.nice(19)
    try:
        asyncio.run(_read_frames(url))
    except Exception:  # noqa: BLE001 - the benchmark's server closing ends the reader
        pass


def run_once(web: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray, str]:
    """The demo mission's companion tick times (wall and CPU) and the web view's own part of
    each (s); with ``web``, a line on the frames."""
    with SimulatedRun.start(DEMO, fast_start=False) as run:
        run.companion.community.profile = True
        cpu: list[float] = []
        framed: list[bool] = []
        tick = run.companion.tick
        server = reader = view = None

        def timed_tick(now: float) -> None:
            sent = server.sent if server is not None else 0
            t0 = time.thread_time()
            tick(now)
            cpu.append(time.thread_time() - t0)
            framed.append(server is not None and server.sent > sent)
        run.companion.tick = timed_tick  # type: ignore[method-assign]
        if web:
            server = WebProcess("127.0.0.1", 0)
            server.start()
            view = WebView(run.companion, server)
            run.companion.community.apps.append(view)
            reader = subprocess.Popen([sys.executable, "-m", "benchmarks.bench_web", "--client",
                                       f"ws://127.0.0.1:{server.port}/ws"],
                                      stdout=subprocess.DEVNULL)
            time.sleep(2.0)  # the reader connects
        try:
            run.hand_over()
            first = len(run.companion_tick_seconds)
            sim0, wall0 = run.clock.now(), time.perf_counter()
            while run.clock.now() - sim0 < PACED_S:
                ahead = (run.step() - sim0) - (time.perf_counter() - wall0)
                if ahead > 0:
                    time.sleep(ahead)
        finally:
            if server is not None:
                server.stop()
            if reader is not None:
                reader.wait(10)
        ticks = np.asarray(run.companion_tick_seconds[first:])
        cpu_ticks = np.asarray(cpu[first:])
        own = np.asarray(run.companion.community.app_seconds.get("iWeb", [0.0])[first:] or [0.0])
        if server is None or view is None:
            return ticks, cpu_ticks, own, ""
        with_frame = np.asarray(framed[first:])
        split = "  ".join(f"{label} {np.percentile(cpu_ticks[mask], 99) * 1e6:.1f} us "
                          f"(n={mask.sum()})" for label, mask in
                          (("with a frame", with_frame), ("without", ~with_frame)))
        return ticks, cpu_ticks, own, (
            f"frames sent {server.sent}, dropped {server.dropped}, put off {view.deferred}; "
            f"CPU p99 of the ticks {split}")


def main() -> None:
    if len(sys.argv) == 3 and sys.argv[1] == "--client":
        client(sys.argv[2])
        return
    print(f"web view cost on the demo mission ({PACED_S:g} s in real time; whole "
          "companion tick)")
    results: dict[bool, list[np.ndarray]] = {False: [], True: []}
    cpu_results: dict[bool, list[np.ndarray]] = {False: [], True: []}
    for web in (False, True, True, False, False, True):
        ticks, cpu, own, frames = run_once(web)
        results[web].append(ticks)
        cpu_results[web].append(cpu)
        extra = (f"\n      the view's own part of a tick: median {np.median(own) * 1e6:.1f} us, "
                 f"p99 {np.percentile(own, 99) * 1e6:.1f} us\n      {frames}") if web else ""
        print(f"  {'with' if web else 'without':7s} web: median {np.median(ticks) * 1e6:7.1f} us"
              f"   p99 {np.percentile(ticks, 99) * 1e6:7.1f} us   CPU median "
              f"{np.median(cpu) * 1e6:7.1f} us p99 {np.percentile(cpu, 99) * 1e6:7.1f} us"
              f"   (n={ticks.size}){extra}",
              flush=True)
    for label, table in (("wall", results), ("CPU", cpu_results)):
        p99 = {web: np.percentile(np.concatenate(runs), 99) for web, runs in table.items()}
        print(f"  {label} p99 over the runs: without {p99[False] * 1e6:.1f} us, with "
              f"{p99[True] * 1e6:.1f} us: {100.0 * (p99[True] / p99[False] - 1.0):+.1f} %")


if __name__ == "__main__":
    main()
