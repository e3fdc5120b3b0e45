"""What a skipper wants after a run: which tasks ran, in what order, how each ended, and a plot."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mavhelm.companion.log_plot import unwrapped
from mavhelm.core.bus import Message
from mavhelm.core.mission import Mission
from mavhelm.sitl.truth import Truth


@dataclass
class TaskRecord:
    name: str
    started: float
    ended: float | None = None
    cause: str | None = None


@dataclass
class Summary:
    tasks: list[TaskRecord] = field(default_factory=list)
    online_at: float | None = None
    ended_at: float | None = None
    end_task: str | None = None
    distance: float = 0.0
    sim_time: float = 0.0
    wall_time: float = 0.0
    errors: list[str] = field(default_factory=list)

    @property
    def speedup(self) -> float:
        return self.sim_time / self.wall_time if self.wall_time > 0 else math.inf


def summarize(messages: Sequence[Message], track: Sequence[Truth],
              wall_time: float = 0.0) -> Summary:
    summary = Summary(wall_time=wall_time)
    open_tasks: dict[str, TaskRecord] = {}
    for m in messages:
        if m.name == "TASK_STARTED":
            record = TaskRecord(m.string, m.time)
            summary.tasks.append(record)
            open_tasks[m.string] = record
        elif m.name == "TASK_ENDED":
            name, _, cause = m.string.rpartition(":")
            ended = open_tasks.pop(name, None)
            if ended is not None:
                ended.ended, ended.cause = m.time, cause
        elif m.name == "HELM_STATE" and m.string == "ONLINE" and summary.online_at is None:
            summary.online_at = m.time
        elif m.name == "MISSION_ENDED" and summary.ended_at is None:
            summary.ended_at, summary.end_task = m.time, m.string
        elif m.name.endswith("_ERROR"):
            summary.errors.append(f"{m.time:8.1f}  {m.name} = {m.string}")
    summary.distance = sum(math.hypot(b.x - a.x, b.y - a.y)
                           for a, b in zip(track, track[1:], strict=False))
    summary.sim_time = track[-1].t - track[0].t if len(track) > 1 else 0.0
    return summary


def format_summary(summary: Summary) -> str:
    lines = ["Tasks (in the order they went active):"]
    for i, task in enumerate(summary.tasks, 1):
        end = (f"ended {task.ended:7.1f} s  ({task.cause})" if task.ended is not None
               else "still active at the end")
        lines.append(f"  {i:2d}. {task.name:<20s} started {task.started:7.1f} s  {end}")
    if summary.online_at is not None:
        lines.append(f"Helm online at {summary.online_at:.1f} s (operator switched to GUIDED)")
    if summary.ended_at is not None:
        mission_time = summary.ended_at - (summary.online_at or 0.0)
        lines.append(f"Mission ended by {summary.end_task} at {summary.ended_at:.1f} s "
                     f"({mission_time:.1f} s after hand-over)")
    else:
        lines.append("Mission did NOT reach EndMission")
    lines.append(f"Distance travelled {summary.distance:.0f} m in {summary.sim_time:.0f} s of "
                 f"simulated time; wall time {summary.wall_time:.1f} s "
                 f"({summary.speedup:.0f}x real time)")
    if summary.errors:
        lines.append("Errors:")
        lines.extend(f"  {e}" for e in summary.errors)
    return "\n".join(lines)


def waypoints(mission: Mission) -> list[tuple[str, float, float]]:
    """(task name, x, y) of every Location in the mission's tasks."""
    points = []
    for block in mission.tasks:
        name = block.get("Name", block.name) or block.name
        for entry in block.all("Location"):
            parts = entry.value.split(",")
            try:
                points.append((name, float(parts[0]), float(parts[1])))
            except (ValueError, IndexError):
                continue
    return points


def plot_run(track: Sequence[Truth], messages: Sequence[Message], mission: Mission,
             path: str | Path, title: str = "") -> None:
    """Track coloured by the task that held the rudder, waypoints, heading over time and, for
    a vehicle with a depth (``NAV_DEPTH`` heard), depth over time."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    owners = [(m.time, m.string) for m in messages if m.name == "HELM_RUDDER_OWNER"]
    names = list(dict.fromkeys(name for _, name in owners))
    colours = {name: plt.cm.tab10(i % 10) for i, name in enumerate(names)}

    depth = [(m.time, m.double) for m in messages if m.name == "NAV_DEPTH" and m.is_double]
    widths = [1.2, 1, 1] if depth else [1.2, 1]
    fig, axes = plt.subplots(1, len(widths), figsize=(6.5 * len(widths), 6),
                             gridspec_kw={"width_ratios": widths})
    ax, ax_h = axes[0], axes[1]
    if depth:
        plot_depth(axes[2], depth, messages)
    plot_track(ax, track, owners, colours, mission, title)
    plot_heading(ax_h, track, owners, colours)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def owner_at(owners: Sequence[tuple[float, str]], t: float) -> str:
    """Who held the rudder at ``t``."""
    current = "none"
    for when, name in owners:
        if when > t:
            break
        current = name
    return current


def plot_track(ax: Any, track: Sequence[Truth], owners: Sequence[tuple[float, str]],
               colours: dict[str, Any], mission: Mission, title: str) -> None:
    """The track coloured by the task that held the rudder, and the mission's waypoints."""
    xs = [s.x for s in track]
    ys = [s.y for s in track]
    ax.plot(xs, ys, color="0.8", lw=1, zorder=1)
    for name in colours:
        if name == "none":
            continue
        held = [owner_at(owners, s.t) == name for s in track]
        sx = [s.x if h else math.nan for s, h in zip(track, held, strict=True)]
        sy = [s.y if h else math.nan for s, h in zip(track, held, strict=True)]
        ax.plot(sx, sy, color=colours[name], lw=2.5, label=f"rudder: {name}", zorder=2)
    for name, x, y in waypoints(mission):
        ax.plot(x, y, marker="*", ms=14, color="crimson", zorder=3)
        ax.annotate(name, (x, y), textcoords="offset points", xytext=(6, 6))
    if track:
        ax.plot(xs[0], ys[0], "go", label="start")
        ax.plot(xs[-1], ys[-1], "ks", label="end")
    ax.set_xlabel("X east (m)")
    ax.set_ylabel("Y north (m)")
    ax.set_aspect("equal", adjustable="datalim")
    ax.grid(True, alpha=0.3)
    ax.legend(loc="best", fontsize=8)
    ax.set_title(title or "Track (ground truth)")


def plot_heading(ax: Any, track: Sequence[Truth], owners: Sequence[tuple[float, str]],
                 colours: dict[str, Any]) -> None:
    """Heading over time, with the moments the rudder changes hands."""
    ax.plot([s.t for s in track], unwrapped([s.heading for s in track]), color="0.3", lw=1)
    top = ax.get_ylim()[1]
    for when, name in owners:
        ax.axvline(when, color=colours.get(name, "k"), ls="--", lw=0.8)
        ax.annotate(name, (when, top), rotation=90, fontsize=7, va="top")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("heading (deg, unwrapped: no jump at 0/360)")
    ax.set_title("Heading; dashed: rudder changes hands")
    ax.grid(True, alpha=0.3)


def plot_depth(ax: Any, depth: Sequence[tuple[float, float]],
               messages: Sequence[Message]) -> None:
    """NAV_DEPTH over time (down is down), with the tasks' starts marked."""
    ax.plot([t for t, _ in depth], [d for _, d in depth], color="navy", lw=1.5, label="NAV_DEPTH")
    for m in messages:
        if m.name == "TASK_STARTED":
            ax.axvline(m.time, color="0.6", ls="--", lw=0.8)
            ax.annotate(m.string, (m.time, 0), rotation=90, fontsize=7, va="top")
    ax.invert_yaxis()
    ax.set_xlabel("time (s)")
    ax.set_ylabel("depth (m)")
    ax.set_title("Depth; dashed: a task starts")
    ax.grid(True, alpha=0.3)


def write_track_csv(track: Sequence[Truth], path: str | Path) -> None:
    with open(path, "w") as f:
        f.write("t,x,y,heading,surge,yaw_rate\n")
        for s in track:
            f.write(f"{s.t:.2f},{s.x:.3f},{s.y:.3f},{s.heading:.2f},{s.surge:.3f},"
                    f"{s.yaw_rate:.3f}\n")
