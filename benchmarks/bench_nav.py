"""Benchmark: pNav's filters — EKF predict+update time (target ≤ 50 µs), the companion tick
with the EKF on GPS + compass + DVL + gyro and 20 helm tasks (target p99 ≤ 1 ms), the replay
of the real Plaza1 log (target: a one-hour log of that density in ≤ 5 s) and the Plaza1 fault
variants (``mavhelm nav replay --fault all``: RMS, NEES and decisions of each).

Prints figures, wall and CPU time, and each target met or not; asserts nothing (a shared
machine's speed is not a test result). Run: ``make bench`` or
``.venv/bin/python -m benchmarks.bench_nav``.

Measured on the project's 2-core machine while other work ran on it (load average 1–4), the
code before and after the hot-path work run alternately in the same conditions; CPU time of
the thread or process unless said. Every accuracy figure and the fault table are unchanged, to
the bit (Plaza1 tracks and covariances compared).

- EKF predict+update, observations built before the clock: load ≈ 1.2: 110–128 µs before,
  50–60 µs after; load 2.5–4: 122–187 µs before, 53–81 µs after (× 0.45). With the
  observations built inside the timed loop (the former measure) it was 108 µs before at
  load 0.3. At the target on a lightly loaded machine, above it under load.
- Plaza1 replay, seconds for a one-hour log: load ≈ 2.3: 6.8 s CPU (7.2 s wall) before,
  4.7 s CPU (5.9 s wall) after; at load 0.3 before: 6.6 s wall. Met in CPU time; the wall
  time on a shared machine is above it.
- Companion tick, CPU per tick at load ≈ 2.3 (median / p99, µs): whole tick 885–930 / 1540
  before, 709–726 / 1394–1417 after; pNav 406–419 / 560 before, 263–272 / 410 after; pHelm
  156 / 230 before, 143 / 230 after; console 33 / 190 before, 7 / 195 after. Target NOT
  met: once a second the autopilot's 1 Hz streams arrive together (23 messages, 14 of which
  the companion does not use: RAW_IMU, SCALED_IMU2, POWER_STATUS, MEMINFO, AHRS …); decoding
  them all (pymavlink, ~7 µs each) and handling the others puts that tick's iMAVLink at
  ~390 µs (p90) to ~630 µs (p99) against a median of ~115 µs. With the serial instruments
  (pynmea2, ~110 µs), pHelm's 20 tasks (~145 µs) and pNav (~270 µs) a p99 of 1 ms is not
  within reach by trimming the hot paths alone. The link now decodes only what the bridge
  reads (``AutopilotLink.decode_only``): the 14 unread messages are recorded and counted, not
  unpacked (iMAVLink in the slowest 2 % of ticks ~870 → ~760 µs, load ≈ 1.2).
- The whole session's code against the session's start, interleaved old/new/old/new with
  nothing else running (the machine itself ran ~1.5× slower than earlier that day, so read
  the ratios): EKF 152–194 µs → 61–79 µs (× 0.40–0.46); one-hour replay 8.5/10.3 s →
  5.8/7.1 s CPU (× 0.68); whole tick CPU median 1406/1562 → 1179/1162 µs, p99 2587/3275 →
  2338/2162 µs (× 0.66–0.90). Scaled to the 107 µs / 6.2 s / 2.14 ms that the same old code
  measured at the start of the day: EKF ≈ 46 µs, replay ≈ 4.2 s, tick p99 ≈ 1.6 ms.
- pNav's second pass (fewer numpy calls in the EKF, a float state between one read and one
  write per step, Q added whole, a bit-exact χ² log tail in place of ``scipy.stats``' 150 µs
  call, the LSQ's normal equations written out, the queues' time-outs in one list), the code
  before and after run alternately, three rounds, CPU time, load 1.4–3.4 (another person's
  SITL runs): EKF predict+update 52.8/54.6/55.0 µs before, 46.3/50.7/62.7 µs after (best
  −12 %; the deterministic count under callgrind: 357 k → 326 k instructions a cycle,
  −8.6 %); one-hour replay 5.17/6.57/6.27 s before, 4.72/5.87/4.74 s after (best −9 %);
  pNav in the 20-task tick, CPU median 294/378/310 µs before, 353/327/296 µs after, p99
  503/600/499 before, 535/505/511 after: no change the load lets one see. Results unchanged
  to the bit (Plaza1 and its six fault variants: per-tick state, covariance, estimates,
  decisions, .olog/.xlog, tracks; the simulator's dead-reckoning, radio-range and LBL runs).
  Why the tick did not follow: there a numpy call costs 5–13 µs, not the 0.3–1 µs of a
  tight loop (the other apps run between two of pNav's steps and take the caches: the
  first ``np.dot`` of a tick measured 11 µs, ``np.add.reduce`` 12 µs, a one-cell write 2 µs;
  the EKF's predict 60–70 µs in the tick against 8 µs in a loop), and the EKF needs ~50 calls
  a tick, most of them BLAS/LAPACK products whose rounding (fused multiply-adds) a float
  loop would not reproduce. Halving pNav's share of the tick needs the small-state EKF in
  plain floats — results equal to rounding, no longer to the bit — which this pass did not do.
- The rest of the tick: the link frames MAVLink in one pass (``SkimmingParser.parse_buffer``,
  pymavlink still decoding each frame read) and leaves ArduSub's depth messages undecoded on a
  surface vehicle; the status snapshot is encoded only when it changed; a serial instrument
  reads with one ``readv``; a task's starvation check is one pass. Interleaved with the code
  of the session's start (per-app CPU, 150–300 s of the patrol each): the 1 Hz burst tick's
  iMAVLink 723/793 → 413/355 µs; whole tick CPU p99 1452/1357 → 1152/1256 µs (load ≈ 1),
  1766/1658 → 1503/1401 µs (load ≈ 2, a SITL beside it), 1761/1740 → 1377/1549 µs (after
  every merge of the day, load ≈ 1). ``bench_nav`` itself, once each, nothing else running:
  1.64 ms old, 1.61 ms new — a single 300 s run's p99 moves by ±15 % on this machine. The
  slowest 1 % of ticks are now not the autopilot's 1 Hz burst but the ticks where a GPS fix
  and a DVL reading reach pNav together (pNav 2.5× its median there). Not met: the tick needs
  ~40 % less across every app (pNav ~300, pHelm ~150, iMAVLink ~130, the serial readers ~90,
  iMAVLinkOut ~60 µs median), more than trimming gives.
- The idle time (``Companion.idle``, after each tick, before the loop sleeps): the .alog is
  formatted and flushed there, pNav's .olog/.xlog and the .tlog flushed, the ground
  station's HEARTBEAT and NAMED_VALUE_FLOATs sent, and Python's garbage collected
  (``core/collector.py``; CPython's own collector ran inside one tick in seventy, 0.2–0.4 ms,
  and every few minutes ~1.5 ms). The tick is now measured logging as ``mavhelm run`` does;
  before, the figures left the logger out (it cost ~80 µs of every tick). Old (the code
  before) and new interleaved, three 300 s runs each, CPU per tick, per-tick minimum of the
  three (the work, the machine's noise taken out): with logs, median 882 → 777 µs, p99
  1288 → 1069, p99.9 2301 → 1198 (an hour later, the machine slower: 969 → 846, 1629 →
  1451, 2734 → 1577); without logs, as the figures above, 784 → 801 and 1304 → 1352 (the
  same within the noise), p99.9 2207 → 1481. The idle time itself: median ~110 µs, p99
  ~350 µs. Single runs' p99 on this machine moved 1.45–2.06 ms (new) over the same hour.
- Where the tick's work goes, by phase (per-tick minimum, median µs): ticks without a GPS
  fix ~680, with the 5 Hz GPS fix and DVL reading ~900, the tick of the autopilot's 1 Hz
  messages ~1080 (iMAVLink 300 there against 70). So the work's p99 is that tick; the
  noise of this VM (every app 2–3× slower for a few ticks at a time) makes the rest.
- The tick is now run three times (``--tick-runs``): the target line gives the median of the
  runs' p99, and a line below it the p99 of the per-tick minimum (the work). The same code
  within one afternoon: per-tick-minimum p99 1.07 ms in a quiet hour, 1.44 ms in a slow one
  (single runs 1.45–2.06 ms; the Plaza1 replay 4.6 s then 5.3 s for a one-hour log, the EKF
  45 then 47 µs): on this VM the figures move with the host's load as much as with the code.
- Counted rather than timed (this VM's wall and CPU times moved ±15 % between two runs of
  the same code that day): instructions under callgrind (``valgrind --tool=callgrind``) of a
  replay of Plaza1's first 400 s, less those of the same script without the replay (the
  imports, 5.99 G). Q's cells rewritten in place, the EKF's dozen values a tick posted on
  the bus directly, a float posted without ``float()``, the survey check's offset column
  built once a review: 3.178 → 3.122 G (−1.8 %), results the same to the bit (Plaza1 and
  five fault variants: tracks, final x and P). The yaw-rate sense (``rate_sense.py``) then
  added 0.9 % (3.150 G). Each hot path is already trimmed to the few numpy calls it needs;
  what is left is the Python each slice runs, spread over some thirty functions of 1–5 %
  each (py-spy), none worth a fifth of the time on its own.
- The interpreter: the Makefile now builds the venv on the distribution's Python 3.11
  (Debian's optimised build) where there is one, pyenv's source build of 3.11.7 before. The
  same code, the machine quiet (load ≈ 0), one after the other: EKF predict+update 39–49 µs
  → 29–30 µs; Plaza1 replay for a one-hour log 4.9–5.1 s → 4.5 s; the 20-task tick, three
  runs each, per-tick minimum p99 0.93–1.05 ms either way, single runs' p99 1.33–1.90 ms
  either way (this VM's noise, not the interpreter, sets the tick's p99). Results the same
  to the bit (Plaza1 and five fault variants). A pure-Python loop: 0.42–0.44 s → 0.36 s.
- The speed-scale state on by default (added at the DVL's first speed: one state more in
  this tick's filter) and pNav's .olog/.xlog lines formatted in the idle time instead of the
  tick (their values kept, the lines the same byte for byte), a bus Message built with
  ``tuple.__new__``: under callgrind, 600 ticks of the rig (simulator included) 8.303 G →
  8.275 G instructions; formatting the logs had cost the tick ~110 k instructions (~4 %).
  Timed the same morning on this VM: single runs' p99 1.10–1.13 ms in a quiet hour (the
  work, per-tick minimum, 0.78 ms), 1.43–1.95 ms an hour later with every app's median
  15 % slower (the work 0.95 ms): the host sets the tick's p99 more than the code does.
- The local frame worked in ``math`` (pymap3d's formulae: its trigonometry goes through
  numpy's ufuncs, ten times ``math``'s on a lone float; the bridge converts two positions
  a GPS tick) and a socket read once a tick when it returns its whole queue: the GPS ticks'
  iMAVLink 100 → 78 µs median, the 1 Hz burst tick's 197 → 165 µs (the work, quiet
  machine). The same morning, two runs of three: median of the runs' p99 0.96 and 0.75 ms
  (met), per-tick minimum p99 0.70 and 0.65 ms; half an hour later, the host slower (every
  app's median 15–30 % up), 1.38 ms and 1.16 ms, the work 1.14 and 0.81 ms; the full
  ``bench_nav`` after the day's nav changes (a yaw-rate row and a stuck-heading check, a
  few µs a tick) 1.1 ms, the work 0.79 ms. On this VM the target is met when the host is
  quiet and not when it is busy.
- The host against the issue's day (2026-12-04, load 0.6-1.7): the code the issue measured
  (``3f4e5e0``, its own benchmark) ran its EKF loop at 81-84 µs (the issue: 47 µs), the
  Plaza1 replay at 4.6 s for a one-hour log (2.7 s) and its three-task tick at a p99 of
  1.72 ms (0.69 ms): this machine ran 1.7-2.5 times slower than on the day the targets
  were set. The code of that evening, here: EKF 49 µs, replay 5.7 s, the 20-task tick with
  logging p99 1.25 ms (the work 0.94 ms): the EKF and the tick faster than the issue's code
  on the same host, the replay 25 % slower (the checks added since: the survey check, the
  range alignment, the fix and kick watches, the LSQ's five states).
- Tried and dropped: the EKF's prediction in plain floats on lists (no numpy) for the
  7-state filter of this tick was no faster in the tick (predict/update ratio unchanged),
  so the cold-cache cost is not numpy's alone; the filter stays on numpy, where the 12-state
  figure above meets its 50 µs.
- 2026-12-05 (afternoon): where the slowest 1 % of ticks go, per-tick minimum of three runs
  by tick class: the autopilot's 1 Hz burst tick (23 frames, 7 decoded: pymavlink's decode
  8–21 µs each there against 3–5 µs in a loop) 811 µs median against 693 µs for the other
  GPS ticks, iMAVLink 214 against 108 µs; 56 of the 61 slowest ticks were burst ticks. The
  link now decodes the messages of numbers itself, pymavlink's way (property-tested against
  it field for field), drops unread frames while framing when no .tlog records them, and a
  serial port read whole is not asked again; the EKF's gate takes a 2–3-row χ² by Cholesky
  in floats. Interleaved with the code of the morning (three runs each, quiet machine): the
  work's p99 874/878/887 → 849/868/850 µs, the median of the runs' p99 943/963/1027 →
  928/1049/916 µs; an hour later, the host faster, 828/807 → 776/751 µs and 878/868 →
  854/828 µs. Most of what sets that p99 is left as it was: the runs' p99 move by
  ±10 % between two runs a minute apart on the same code, in clusters of slow ticks (in one
  run 34 of the 51 ticks 599–649 each took over 150 µs more than the same tick's least of
  the three runs) that are this VM's, not the process's.
- 2026-12-05 (evening): the slowest 2 % of pNav's ticks are those where a GPS fix ends a run
  made good (``alignment.py``, twice a second): its estimate 44 µs (the sensor's raw offset
  from the courses recomputed over the window's ~60 runs, sines and cosines each time, and
  the list of the runs' times for their largest gap) and the run itself 27 µs. The courses'
  sums and the window's largest gap are now kept as runs come and go (as the runs'
  corrections already were), a run's six sums taken in one pass: the estimate 44 → 11 µs
  there. The whole tick's work (per-tick minimum of three runs), interleaved with the code
  before, three times: 847/831/834 → 788/776/753 µs (−7 to −10 %); results the same to the
  printed digit on 168 replays (Plaza1 whole, half its ranges, started 300 and 800 s in;
  eleven faults, two seeds, both missions) and in the fault tables. Tried and dropped,
  measured in the tick: numba-compiled kernels for the prediction's F P Fᵀ + Q and for the
  correction (gain, state step, P − K S Kᵀ symmetrised, its Cholesky check): predict 36 →
  25 µs, ``_apply`` 36 → 16 µs, yet pNav 299 → 282 µs all told (the rest of the update
  slowed as the kernels took the caches): a compiled call in a cold tick costs about what a numpy
  call does, so replacing five calls by one saves ~3 µs each. Not worth a 40 MB compiler
  dependency, results no longer bit for bit, and a JIT compile at every cold start.
  ``bench_nav`` after the first step: runs' p99 1.02 / 0.89 / 1.00 ms (met, at the limit),
  the work 0.82 ms; nine single runs a few minutes before it: p99 843–1243 µs, two of nine
  over 1 ms. After the last: runs' p99 0.87 / 0.85 / 0.84 ms (met), the work 0.78 ms, EKF
  41 µs, replay 4.7 s. The slowest ticks are now the autopilot's 1 Hz burst again (52 of
  the 62 slowest), iMAVLink 158 µs there against 82 µs in the other GPS ticks.
- 2026-12-05 (late evening): the tick now runs five times by default and the target line is
  the median of the five runs' p99 (each printed): a single 300 s run's p99 is set by its 30
  slowest ticks, and one cluster of the VM's slow ticks lifts a run over the line on code
  that meets it (37 runs that evening, the same code: p99 0.79-1.06 ms, two over 1 ms; the
  work, per-tick minimum, 0.73-0.75 ms). Medians of five: 0.83-0.87 ms in five measurements
  over an hour, the full benchmark 0.87 ms (EKF 40.8 µs, replay 4.4 s). pNav's time slices
  are printed (one a tick in this rig; ``bench_tick_deployed`` counts 2.5 on the wall clock,
  where the autopilot's messages carry their own sample times, and its pNav costs as much
  again per slice: 1.7 ms median tick there, not met).
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mavhelm.companion.alog import read_alog
from mavhelm.core.bus import Message
from mavhelm.core.collector import IdleCollector
from mavhelm.core.mission import Block, load_mission
from mavhelm.nav.ekf import EKF, Beacon, BodyVelocity, EKFConfig, Range, Yaw
from mavhelm.nav.faults import FAULTS, applies, layout_of, with_fault
from mavhelm.nav.replay import replay

REPO = Path(__file__).resolve().parents[1]
PLAZA = REPO.parent / "shared" / "data" / "plaza" / "Plaza1.mat"


def percentiles_us(samples: list[float]) -> str:
    a = np.asarray(samples) * 1e6
    return f"median {np.median(a):7.1f} us   p99 {np.percentile(a, 99):7.1f} us   (n={a.size})"


def ekf_updates(drift: bool = False) -> tuple[float, float]:
    """One EKF with four beacons and the hidden states of the issue's 12-state figure (the
    heading bias, range scale and offsets; ``drift``: the bias's drift rate too, 13 states),
    fed Plaza-like slices. The slices are built before the clock starts: the figure is the
    filter's predict+update, not the making of observations and random numbers. Returns one
    cycle's wall and CPU time (s)."""
    beacons = [Beacon(str(k), 30 * math.cos(k), 30 * math.sin(k)) for k in range(4)]
    ekf = EKF(0.0, 0.0, 0.0, beacons=beacons,
              config=EKFConfig(estimate_yaw_bias=True, estimate_yaw_drift=drift))
    rng = np.random.default_rng(0)
    n, t = 20000, 0.0
    slices: list[tuple[float, Range | list[BodyVelocity | Yaw]]] = []
    for k in range(n):
        t += 0.1
        if k % 3 == 0:
            b = beacons[k % 4]
            slices.append((t, Range(t, b.name, math.hypot(b.x, b.y) + rng.normal(0, 0.3))))
        else:
            slices.append((t, [BodyVelocity(t, 0.0, 0.0, 0.0), Yaw(t, 0.0)]))
    wall, cpu = time.perf_counter(), time.thread_time()
    for t, observations in slices:
        ekf.advance(t)
        ekf.update(observations)
    cpu = (time.thread_time() - cpu) / n
    wall = (time.perf_counter() - wall) / n
    print(f"EKF (dim {ekf.dim}): {1 / wall:,.0f} predict+update cycles/s "
          f"({1e6 * wall:.0f} us each wall, {1e6 * cpu:.0f} us CPU)")
    return wall, cpu


EXTRA_TASKS = 17
"""Tasks added to the box patrol's three (XYPattern, OverallTimeOut, EndMission): 20 in all,
every one running each tick — safety boxes that watch NAV_X/NAV_Y, and constant headings at
a priority that loses the arbitration but still votes."""


def _extra_tasks() -> str:
    boxes = [f"""    Task = LimitBox
    {{
        Name = Box{k}
        Priority = 1
        XMin = {-500 - k}
        XMax = {500 + k}
        YMin = -500
        YMax = 500
        EventFlag = OutOfBox{k}
    }}
""" for k in range(10)]
    headings = [f"""    Task = ConstantHeading
    {{
        Name = Heading{k}
        Priority = 9
        Heading = {40 * k}
        TimeOut = 3000
    }}
""" for k in range(EXTRA_TASKS - 10)]
    return "".join(boxes + headings)


def use_twenty_tasks() -> None:
    """Give the simulator tests' box patrol (``nav_sim_rig.BOX``) the ``EXTRA_TASKS``, once:
    the mission of the tick figures (here and ``bench_tick_deployed``)."""
    from tests.support import nav_sim_rig

    extra = _extra_tasks().replace("%", "%%")
    if not nav_sim_rig.BOX.endswith(extra):
        nav_sim_rig.BOX = nav_sim_rig.BOX + extra


@dataclass
class TickRun:
    """One run of the 20-task box patrol: per tick, wall and CPU time of the tick, CPU time of
    the idle time after it, and each app's share."""

    wall: list[float]
    cpu: list[float]
    idle: list[float]
    apps: dict[str, list[float]]
    collector: IdleCollector
    tasks: int
    slices: float
    """pNav's time slices a tick (one here: the simulator stamps every reading of a tick
    alike; ``bench_tick_deployed`` counts those of a companion on the wall clock)."""


def _tick_run() -> TickRun:
    from tests.support import nav_sim_rig
    from tests.support.nav_sim_rig import DEAD_RECKONING

    use_twenty_tasks()
    with tempfile.TemporaryDirectory() as folder:
        run = nav_sim_rig.start(DEAD_RECKONING, tmp_path=Path(folder), logs=True)
        try:
            companion = run.run.companion
            companion.community.profile = True
            cpu: list[float] = []
            idle_cpu: list[float] = []
            tick, idle = companion.tick, companion.idle

            def timed_tick(now: float) -> None:
                t0 = time.thread_time()
                tick(now)
                cpu.append(time.thread_time() - t0)

            def timed_idle() -> None:
                t0 = time.thread_time()
                idle()
                idle_cpu.append(time.thread_time() - t0)

            companion.tick = timed_tick  # type: ignore[method-assign]
            companion.idle = timed_idle  # type: ignore[method-assign]
            run.run.hand_over()
            run.run.run_for(300.0)
            fusion = companion.navigator.fusion
            return TickRun(run.run.companion_tick_seconds, cpu, idle_cpu,
                           dict(companion.community.app_seconds), companion.collector,
                           len(companion.helm.tasks),
                           (fusion.slices if fusion is not None else 0) / max(len(cpu), 1))
        finally:
            run.close()


def tick_with_ekf(runs: int = 5) -> tuple[tuple[float, float], float]:
    """The box patrol of the simulator tests, with the EKF on GPS, compass, DVL and gyro and
    20 helm tasks, logging as ``mavhelm run`` does (.alog, .olog, .xlog): pNav's and pHelm's
    share of each companion tick, and the whole tick (wall and the thread's CPU time); then
    the idle time after it (logs written, garbage collected).

    Run ``runs`` times: the simulation is deterministic, so tick k does the same work in
    every run, and the per-tick minimum over the runs is the work with this machine's noise
    taken out (a few ticks at a time when every app runs 2–3× slower). Returns the median
    over the runs of the whole tick's p99 (wall, CPU) and the p99 of the per-tick minimum
    CPU (s)."""
    done = [_tick_run() for _ in range(runs)]
    first = done[0]
    nav, helm = first.apps["pNav"], first.apps["pHelm"]
    both = [a + b for a, b in zip(nav, helm, strict=True)]
    print(f"box patrol in mavhelm sim, EKF on GPS + compass + DVL + gyro, {first.tasks} "
          f"helm tasks (10 Hz tick), logging; {runs} runs of 300 s, the first in detail:")
    print(f"  pNav          {percentiles_us(nav)}; {first.slices:.2f} time slices a tick")
    print(f"  helm+nav tick {percentiles_us(both)}")
    print(f"  whole companion tick {percentiles_us(first.wall)}")
    print(f"  whole tick, CPU      {percentiles_us(first.cpu)}")
    print(f"  idle time after it, CPU (logs written, telemetry sent, garbage collected) "
          f"{percentiles_us(first.idle)}")
    if first.collector.seconds:
        print(f"    of which garbage collections by generation "
              f"{first.collector.collections}, each {percentiles_us(first.collector.seconds)}")
    for k, r in enumerate(done[1:], start=2):
        print(f"  run {k}: whole tick, CPU {percentiles_us(r.cpu)}")
    n = min(len(r.cpu) for r in done)
    work = np.min(np.stack([r.cpu[:n] for r in done]), axis=0)
    print(f"  per-tick minimum over the {runs} runs (the work, the noise taken out), CPU "
          f"{percentiles_us(list(work))}")
    walls = [float(np.percentile(r.wall, 99)) for r in done]
    print("  each run's whole-tick p99, wall: " + " / ".join(f"{w * 1e3:.2f}" for w in walls)
          + " ms")
    wall = float(np.median(walls))
    cpu = float(np.median([np.percentile(r.cpu, 99) for r in done]))
    return (wall, cpu), float(np.percentile(work, 99))


def _plaza(folder: Path) -> tuple[Block, list[Message]]:
    """Plaza1 converted into ``folder``: its pNav block and its bus messages."""
    alog, mission = folder / "p.alog", folder / "p.moos"
    subprocess.run([sys.executable, str(REPO / "examples/plaza/convert.py"), str(PLAZA),
                    str(alog), "--mission", str(mission)], check=True, capture_output=True)
    block = load_mission(mission).process("pNav")
    assert block is not None
    return block, read_alog(alog)


def plaza_replay() -> tuple[float, float] | None:
    """Plaza1 through the navigator, best of three (wall and CPU each); returns the wall and
    CPU time a one-hour log of that density would take (s), None without the data."""
    if not PLAZA.exists():
        print(f"Plaza replay: skipped, {PLAZA} is absent")
        return None
    with tempfile.TemporaryDirectory() as folder:
        block, messages = _plaza(Path(folder))
        runs = []
        for _ in range(3):  # a shared machine: the best of three is the code's own speed
            wall, cpu = time.perf_counter(), time.process_time()
            result = replay(block, messages)
            runs.append((time.perf_counter() - wall, time.process_time() - cpu))
        wall = min(w for w, _ in runs)
        cpu = min(c for _, c in runs)
        hour = 3600 / result.span
        print(f"Plaza1 replay through the navigator: {result.span:.0f} s of log, "
              f"{len(messages)} variables, {result.ticks} ticks; runs "
              + ", ".join(f"{w:.2f}" for w, _ in runs) + " s wall")
        print(f"  best {wall:.2f} s wall ({cpu:.2f} s CPU): {result.span / wall:.0f}x real time; "
              f"a one-hour log of this density: {hour * wall:.1f} s wall ({hour * cpu:.1f} s CPU)")
        print(f"  accuracy: {result.accuracy('NAV')}")
        return hour * wall, hour * cpu


def plaza_faults() -> None:
    """Each fault of the library on Plaza1: what ``mavhelm nav replay --fault`` reports."""
    if not PLAZA.exists():
        return
    with tempfile.TemporaryDirectory() as folder:
        block, messages = _plaza(Path(folder))
        layout = layout_of(block)
        print("Plaza1 fault variants (NAV position against truth; NEES of the EKF position):")
        for name in ["none", *(f for f in FAULTS if applies(f, layout))]:
            log = messages if name == "none" else with_fault(name, messages, layout)
            result = replay(block, log)
            fusion = result.navigator.fusion
            assert fusion is not None
            made = [d.kind for d in fusion.decisions]
            decided = ", ".join(f"{k} {made.count(k)}" for k in dict.fromkeys(made))
            print(f"  {name:15s} {result.accuracy('NAV')}; NEES mean "
                  f"{result.consistency().mean:.2f}; {decided}"
                  + (f"; FAILURE {result.failure}" if result.failure else ""))


FAULT_SEEDS = 6
"""Seeds each fault is made with in the table of ``plaza_fault_seeds`` (the tests and the
table above use seed 1)."""
COMPOUND_FAULTS = ("heading_wander+heading_jumps", "heading_drift+heading_jumps",
                   "heading_scale+heading_jumps", "heading_wander+heading_stuck",
                   "heading_drift+heading_stuck")
"""Faults made together in that table too: a real heading's bad day seldom brings one."""

_worker: tuple[Block, list[Message]] | None = None


def _load_plaza(alog: str, mission: str) -> None:
    global _worker
    block = load_mission(mission).process("pNav")
    assert block is not None
    _worker = (block, read_alog(alog))


def _fault_rms(job: tuple[str, int]) -> float:
    assert _worker is not None
    block, messages = _worker
    name, seed = job
    return replay(block, with_fault(name, messages, layout_of(block), seed)).accuracy("NAV").rms


def plaza_fault_seeds(seeds: int = FAULT_SEEDS) -> None:
    """Each fault made with ``seeds`` seeds (the jumps' times and sizes, the moved beacon's
    direction, the outliers drawn): NAV RMS per seed against the 1.0 m floor. One seed is one
    draw of the fault; the floor is a claim about the class."""
    if not PLAZA.exists():
        return
    with tempfile.TemporaryDirectory() as folder:
        block, _ = _plaza(Path(folder))
        layout = layout_of(block)
        names = [f for f in (*FAULTS, *COMPOUND_FAULTS) if applies(f, layout)]
        jobs = [(name, seed) for name in names for seed in range(1, seeds + 1)]
        with multiprocessing.Pool(2, _load_plaza, (str(Path(folder) / "p.alog"),
                                                   str(Path(folder) / "p.moos"))) as pool:
            rms = pool.map(_fault_rms, jobs)
    print(f"Plaza1 fault variants, NAV RMS (m) for seeds 1-{seeds} (floor 1.0 m):")
    for k, name in enumerate(names):
        row = rms[k * seeds:(k + 1) * seeds]
        over = sum(r > 1.0 for r in row)
        print(f"  {name:28s} " + " ".join(f"{r:5.2f}" for r in row)
              + f"   worst {max(row):.2f}" + (f"  ({over} over the floor)" if over else ""))


def _target(what: str, figures: tuple[float, float] | None, limit: float, unit: str,
            scale: float) -> str:
    """One target's line: wall time (what the issue asks) and CPU time (the code's own cost
    when other work shares the machine), each met or not."""
    if figures is None:
        return f"  {what} <= {limit:g} {unit}: not measured"
    said = [f"{value * scale:.1f} {unit} {kind} ({'met' if value * scale <= limit else 'NOT MET'})"
            for kind, value in zip(("wall", "CPU"), figures, strict=True)]
    return f"  {what} <= {limit:g} {unit}: " + ", ".join(said)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--tick-runs", type=int, default=5,
                        help="runs of the 20-task tick (default 5; the target is the median "
                             "of their p99s, their per-tick minimum the work without the "
                             "machine's noise)")
    args = parser.parse_args()
    print(f"Python {sys.version.split()[0]} at {sys.executable} (the interpreter moves every "
          "figure: Debian's 3.11 build ran the EKF ~25 % faster than pyenv's)")
    cycle = ekf_updates()
    ekf_updates(drift=True)
    hour = plaza_replay()
    plaza_faults()
    plaza_fault_seeds()
    p99, work = tick_with_ekf(max(args.tick_runs, 1))
    print("targets (issue 15 item 7), on this machine now:")
    print(_target("EKF predict+update", cycle, 50, "us", 1e6))
    print(_target("whole companion tick p99 (median of the runs)", p99, 1, "ms", 1e3))
    print(f"    the work alone (per-tick minimum of the runs): p99 {work * 1e3:.2f} ms CPU")
    print(_target("one-hour log replayed", hour, 5, "s", 1.0))


if __name__ == "__main__":
    main()
