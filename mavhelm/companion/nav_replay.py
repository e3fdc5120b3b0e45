"""``mavhelm nav replay MISSION LOG``: the mission's pNav over a recorded log, with a report.

The log is an ``.alog`` (mavhelm's own, or a converted data set) or a MAVLink ``.tlog``
(MAVProxy, QGroundControl), which goes through the mission's MAVLink bridge first so the
navigator sees what it would have seen live. With a truth in the log (``TRUTH_X``/``TRUTH_Y``:
the SITL's SIMSTATE, or a data set's ground truth) the report scores each position source.
The .olog/.xlog are written beside the log unless ``--no-nav-log``. The fault runs
(``--fault``) are independent replays of the same log, so they run in parallel processes
(``--jobs``, all cores by default) after the log as recorded, which runs first in this process
so that a bad mission or log is said once, as itself; the reports print in their order.
``--faults-only`` leaves the recorded run out (a fault's draws compared among themselves):
the first fault run then takes its place in this process.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import time
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from mavhelm.companion.alog import read_alog
from mavhelm.companion.navlog import NavLogFiles
from mavhelm.companion.tlog import bus_messages_from_tlog
from mavhelm.core.errors import SettingError
from mavhelm.core.mission import MissionError, load_mission
from mavhelm.nav.faults import FAULTS, applies, layout_of, parts, with_fault
from mavhelm.nav.replay import ReplayResult, replay


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("mission", help="mission file with the pNav block to run")
    parser.add_argument("log", help="recorded log: .alog, or a MAVLink .tlog")
    parser.add_argument("--period", type=float, default=0.1,
                        help="navigator tick in seconds (default 0.1, the companion's)")
    parser.add_argument("--nav-log", default=None,
                        help="folder for the .olog/.xlog (default: beside the log)")
    parser.add_argument("--no-nav-log", action="store_true", help="write no .olog/.xlog")
    parser.add_argument("--fault", action="append", default=[], type=_fault_name,
                        metavar="{" + ",".join([*FAULTS, "all"]) + "}",
                        help="also replay the log with this fault made on it (repeatable; "
                             "all: every fault that applies; A+B: both on one log), each "
                             "with its own report")
    parser.add_argument("--faults-only", action="store_true",
                        help="with --fault: replay only the fault runs, not the log as "
                             "recorded first")
    parser.add_argument("--seed", type=int, default=1, help="seed of the faults (default 1)")
    parser.add_argument("--jobs", type=int, default=None,
                        help="fault runs replayed at once (default: the machine's cores)")


def _fault_name(text: str) -> str:
    if text != "all":
        try:
            parts(text)
        except ValueError as exc:
            raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def replay_files(mission_path: str | Path, log_path: str | Path, *, period: float = 0.1,
                 nav_log: str | Path | None = None, write_nav_log: bool = True,
                 fault: str | None = None, seed: int = 1
                 ) -> tuple[ReplayResult, float, bool]:
    """Replay ``log_path`` through the mission's pNav, with ``fault`` made on it if given;
    returns the result, the wall seconds the replay took (reading the log not included) and
    whether the fault changed nothing in the log (``applies`` knows the mission, not the
    log: a gyro declared as a body-velocity sensor gives no speed to scale). The nav logs of
    a fault's run are named after it."""
    mission = load_mission(mission_path)
    block = mission.process("pNav")
    if block is None:
        raise MissionError(mission.path, 0, "the mission has no ProcessConfig = pNav block")
    log_path = Path(log_path)
    if log_path.suffix.lower() == ".tlog":
        messages = bus_messages_from_tlog(log_path, mission)
    else:
        messages = read_alog(log_path)
    unchanged = False
    if fault is not None:
        faulted = with_fault(fault, messages, layout_of(block), seed)
        unchanged = faulted == sorted(messages, key=lambda m: m.time)
        messages = faulted
    sink = None
    if write_nav_log:
        stem = f"{log_path.stem}_replay" + (f"_{fault}" if fault else "")
        try:
            sink = NavLogFiles(nav_log or log_path.parent, stem, timestamp=False)
        except (OSError, ValueError) as exc:
            raise SettingError("--nav-log" if nav_log else "the log's folder",
                               "the replay's nav logs", exc) from None
    started = time.perf_counter()
    try:
        result = replay(block, messages, period=period, log=sink)
    finally:
        if sink is not None:
            sink.close()
    return result, time.perf_counter() - started, unchanged


def run(args: argparse.Namespace) -> int:
    if not args.period > 0:
        print("mavhelm nav replay: --period must be > 0", flush=True)
        return 2
    if args.jobs is not None and args.jobs < 1:
        print("mavhelm nav replay: --jobs must be at least 1", flush=True)
        return 2
    if args.faults_only and not args.fault:
        print("mavhelm nav replay: --faults-only needs --fault", flush=True)
        return 2
    runs, note = _faults(args)
    if note:
        print(note, flush=True)
    first, *faults = runs
    lines, failed = _replay_report((args, first), first=True)
    _print_run(first, lines)
    worst = int(failed)
    jobs = min(args.jobs or os.cpu_count() or 1, len(faults))
    with contextlib.ExitStack() as stack:
        reports: Iterator[tuple[list[str], bool]]
        if jobs > 1:
            pool = ProcessPoolExecutor(max_workers=jobs)
            stack.callback(pool.shutdown, cancel_futures=True)
            reports = pool.map(_replay_report, [(args, f) for f in faults])
        else:
            reports = map(_replay_report, [(args, f) for f in faults])
        for fault, (lines, failed) in zip(faults, reports, strict=True):
            _print_run(fault, lines)
            worst = max(worst, int(failed))
    return worst


def _print_run(fault: str | None, lines: list[str]) -> None:
    if fault is not None:
        print(f"\n== fault {fault} ==")
    for line in lines:
        print(line, flush=True)


def _replay_report(job: tuple[argparse.Namespace, str | None],
                   first: bool = False) -> tuple[list[str], bool]:
    """One run's report lines and whether the navigator failed in it. A later fault run (in
    a worker process) reports an error as a line rather than raising: the log and mission
    were already read once without one; the ``first`` run raises it."""
    args, fault = job
    try:
        result, seconds, unchanged = replay_files(
            args.mission, args.log, period=args.period, nav_log=args.nav_log,
            write_nav_log=not args.no_nav_log, fault=fault, seed=args.seed)
    except Exception as exc:  # noqa: BLE001 - a worker's error must reach the report whole
        if first:
            raise
        return [f"mavhelm nav replay: the {fault} run failed: {exc}"], True
    speedup = result.span / seconds if seconds > 0 else float("inf")
    said = [f"the fault {fault} finds nothing to act on in this log: the run is the log as "
            "recorded"] if unchanged else []
    return ([*said, *result.report(),
             f"replay took {seconds:.2f} s of wall time ({speedup:.0f}x the log's duration)"],
            result.failure is not None)


def _faults(args: argparse.Namespace) -> tuple[list[str | None], str]:
    """The runs asked for: the log as recorded (unless ``--faults-only``), then each fault
    (``all``: those that apply to the mission). The first runs in this process. With it, what
    to tell the user where ``all`` found no fault to make: the library makes its faults on
    the readings of the sensors a pNav block declares (``SENSOR_*``), and a block that only
    routes sources (``X = GPS @ 2``) declares none."""
    if not args.fault:
        return [None], ""
    names = list(dict.fromkeys(args.fault))
    note = ""
    if "all" in names:
        mission = load_mission(args.mission)
        block = mission.process("pNav")
        layout = layout_of(block) if block is not None else None
        names = [f for f in FAULTS if layout is not None and applies(f, layout)]
        if not names and layout is not None:
            note = ("--fault all: no fault of the library applies to this mission's pNav: "
                    "faults are made on the readings of the sensors it declares (SENSOR_XY, "
                    "SENSOR_ORIENTATION, SENSOR_RANGE, SENSOR_LBL, SENSOR_BODY_VEL) and it "
                    "declares none of these; replaying the log as recorded only")
    if args.faults_only and names:
        return names, note
    return [None, *names], note
