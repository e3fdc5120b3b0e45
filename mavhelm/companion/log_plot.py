"""``mavhelm log plot RUN``: a run's track, who steered, heading and nav error in one PNG, from
the companion's ``.alog`` or the ``.tlog`` of its MAVLink traffic.

A heading is drawn unwrapped (a boat holding north crosses 0/360 every few seconds; drawn raw
that is a wall of vertical lines), so a turn reads as a slope and a steady course as a flat
line. The nav error (pNav's position against the simulator's truth) is drawn when the log has
truth (``TRUTH_X``/``TRUTH_Y``, a simulated run).
"""

from __future__ import annotations

import argparse
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from pymavlink import mavutil

from mavhelm.companion.alog import read_alog
from mavhelm.companion.status import Goal, Snapshot, TaskEnded
from mavhelm.companion.status_wire import STATUS_PAYLOAD_TYPE, decode

Series = list[tuple[float, float]]


@dataclass
class RunSeries:
    """What the plot needs, each as (time, value) in the log's time."""

    x: Series = field(default_factory=list)
    y: Series = field(default_factory=list)
    heading: Series = field(default_factory=list)
    truth_x: Series = field(default_factory=list)
    truth_y: Series = field(default_factory=list)
    owners: list[tuple[float, str]] = field(default_factory=list)
    """(time, task) whenever the rudder changes hands ("none": nobody)."""

    def add_owner(self, t: float, owner: str) -> None:
        owner = owner or "none"
        if not self.owners or self.owners[-1][1] != owner:
            self.owners.append((t, owner))


ALOG_SERIES = {"NAV_X": "x", "NAV_Y": "y", "NAV_HEADING": "heading", "TRUTH_X": "truth_x",
               "TRUTH_Y": "truth_y"}
TLOG_SERIES = {"NAV_X": "x", "NAV_Y": "y", "NAV_HDG": "heading"}
"""The companion's NAMED_VALUE_FLOATs (``bridge/output.py``)."""


def from_alog(path: Path) -> RunSeries:
    run = RunSeries()
    for m in read_alog(path):
        attr = ALOG_SERIES.get(m.name)
        if attr is not None and m.is_double and math.isfinite(m.double):
            getattr(run, attr).append((m.time, m.double))
        elif m.name == "HELM_RUDDER_OWNER":
            run.add_owner(m.time, "" if m.string == "none" else m.string)
    return run


def from_tlog(path: Path) -> RunSeries:
    """The companion's own frames in a .tlog: its NAMED_VALUE_FLOATs and its typed status."""
    run = RunSeries()
    log = mavutil.mavlink_connection(str(path), dialect="ardupilotmega")
    try:
        while (msg := log.recv_match(type=["NAMED_VALUE_FLOAT", "TUNNEL"])) is not None:
            t = float(log.timestamp)  # the record's time stamp (set as each is read)
            if msg.get_type() == "NAMED_VALUE_FLOAT":
                attr = TLOG_SERIES.get(str(msg.name).rstrip("\x00"))
                if attr is not None and math.isfinite(msg.value):
                    getattr(run, attr).append((t, float(msg.value)))
                continue
            if msg.payload_type != STATUS_PAYLOAD_TYPE:
                continue
            event = decode(bytes(msg.payload[:max(0, min(msg.payload_length, 128))]))
            if isinstance(event, (Goal, Snapshot)):
                run.add_owner(t, event.owner)
            elif isinstance(event, TaskEnded) and run.owners and run.owners[-1][1] == event.name:
                run.add_owner(t, "")
    finally:
        log.close()
    return run


def read_run(path: Path) -> RunSeries:
    return from_tlog(path) if path.suffix == ".tlog" else from_alog(path)


def find_log(run: Path) -> Path:
    """RUN itself if it is a log, else the newest .alog (or .tlog) in the folder."""
    if run.is_file():
        return run
    if not run.is_dir():
        raise FileNotFoundError(f"no such run folder or log: {run}")
    for pattern in ("*.alog", "*.tlog"):
        logs = sorted(run.glob(pattern), key=lambda p: p.stat().st_mtime)
        if logs:
            return logs[-1]
    raise FileNotFoundError(f"no .alog or .tlog in {run}")


def unwrapped(degrees: list[float]) -> np.ndarray:
    """Headings without the 0/360 jumps, starting in [0, 360)."""
    if not degrees:
        return np.array([])
    return np.degrees(np.unwrap(np.radians(np.asarray(degrees) % 360.0)))


def _pairs(a: Series, b: Series) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """x and y posted together (same time stamp): times, xs, ys."""
    ys = dict(b)
    joined = [(t, v, ys[t]) for t, v in a if t in ys]
    if not joined:
        return np.array([]), np.array([]), np.array([])
    t, x, y = (np.asarray(c) for c in zip(*joined, strict=True))
    return t, x, y


def nav_error(run: RunSeries) -> tuple[np.ndarray, np.ndarray]:
    """(time, metres) of pNav's position from the truth, at each nav fix."""
    t, x, y = _pairs(run.x, run.y)
    tt, tx, ty = _pairs(run.truth_x, run.truth_y)
    if t.size == 0 or tt.size < 2:
        return np.array([]), np.array([])
    inside = (t >= tt[0]) & (t <= tt[-1])
    t, x, y = t[inside], x[inside], y[inside]
    return t, np.hypot(x - np.interp(t, tt, tx), y - np.interp(t, tt, ty))


def _track(ax, run: RunSeries, colours: dict[str, Any], title: str) -> None:
    """The NAV track, each stretch coloured by the task that held the rudder, over the truth."""
    t, x, y = _pairs(run.x, run.y)
    ax.plot(x, y, color="0.75", lw=1)
    owner_times = np.asarray([w for w, _ in run.owners])
    owner_of = np.searchsorted(owner_times, t, side="right") - 1
    for name, colour in colours.items():
        held = np.asarray([i >= 0 and run.owners[i][1] == name for i in owner_of], dtype=bool)
        if held.any():
            ax.plot(np.where(held, x, np.nan), np.where(held, y, np.nan), lw=2.5,
                    color=colour, label=f"rudder: {name}")
    _, tx, ty = _pairs(run.truth_x, run.truth_y)
    if tx.size:
        ax.plot(tx, ty, color="k", lw=0.6, ls=":", label="truth")
    ax.plot(x[0], y[0], "go", label="start")
    ax.plot(x[-1], y[-1], "ks", label="end")
    ax.set(xlabel="X east (m)", ylabel="Y north (m)", title=title)
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)


def _heading(ax, run: RunSeries, start: float, colours: dict[str, Any]) -> None:
    times = np.asarray([s[0] for s in run.heading]) - start
    ax.plot(times, unwrapped([s[1] for s in run.heading]), color="0.2", lw=1)
    for when, name in run.owners:
        ax.axvline(when - start, color=colours.get(name, "0.6"), ls="--", lw=0.8)
    ax.set(ylabel="heading (deg, unwrapped)", title="NAV heading; dashed: rudder changes hands")
    ax.grid(True, alpha=0.3)


def _owners(ax, run: RunSeries, start: float, end: float, colours: dict[str, Any]) -> None:
    """One bar per stretch a task held the rudder."""
    ends = [when for when, _ in run.owners[1:]] + [max(end, run.owners[-1][0])]
    for (when, name), until in zip(run.owners, ends, strict=True):
        if name in colours:
            ax.barh(name, until - when, left=when - start, color=colours[name])
    ax.set(ylabel="task steering")
    ax.grid(True, alpha=0.3)


def plot(run: RunSeries, out: Path, title: str) -> None:
    """Track (left); heading, who steered and the nav error over time (right)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    times = [s[0] for series in (run.x, run.heading) for s in series]
    start, end = min(times), max(times)
    names = list(dict.fromkeys(name for _, name in run.owners if name != "none"))
    colours = {name: plt.cm.tab10(i % 10) for i, name in enumerate(names)}
    err_t, err = nav_error(run)
    rows = 3 if err.size else 2
    fig = plt.figure(figsize=(14, 7))
    _track(fig.add_subplot(1, 2, 1), run, colours, title)
    _heading(fig.add_subplot(rows, 2, 2), run, start, colours)
    axes = fig.add_subplot(rows, 2, 4)
    if run.owners:
        _owners(axes, run, start, end, colours)
    if err.size:
        axes = fig.add_subplot(rows, 2, 6)
        axes.plot(err_t - start, err, color="tab:red", lw=1)
        axes.set(ylabel="nav error (m)")
        axes.grid(True, alpha=0.3)
    axes.set(xlabel="time (s)")
    fig.tight_layout()
    fig.savefig(out, dpi=100)
    plt.close(fig)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("run", help="a run folder (its newest .alog, else .tlog) or a log file")
    parser.add_argument("--out", default=None,
                        help="the PNG to write (default: beside the log, <log>_plot.png)")


def run(args: argparse.Namespace) -> int:
    log = find_log(Path(args.run))
    series = read_run(log)
    if not series.x:
        print(f"mavhelm log plot: {log} has no NAV_X/NAV_Y to draw")
        return 1
    out = Path(args.out) if args.out else log.with_name(f"{log.stem}_plot.png")
    plot(series, out, f"{log.name}: track, coloured by the task steering")
    print(f"mavhelm log plot: {out}")
    return 0
