"""Routes with corners, for the sharp-corner tests and ``benchmarks/bench_corners.py``: a
zig-zag's points, the chain of TrackLines that flies it (as mission text), and the XTE in the
part of each line that is meant to be held (from 10 m along it to 5 m before its end)."""

from __future__ import annotations

import math

from mavhelm.tasks.geometry import Point2, track_position

WINDOW = (10.0, 5.0)
"""The held part of a line: from this far along it to this far before its end (m)."""


def zigzag(turn: float, legs: int = 4, leg: float = 60.0) -> list[Point2]:
    """A 20 m run-in east from (0, 0), then ``legs`` lines of ``leg`` m turning ``turn``°
    alternately to starboard and to port."""
    points = [(0.0, 0.0), (20.0, 0.0)]
    heading = 90.0
    for k in range(legs):
        x, y = points[-1]
        points.append((x + leg * math.sin(math.radians(heading)),
                       y + leg * math.cos(math.radians(heading))))
        heading += turn if k % 2 == 0 else -turn
    return points


def chained(points: list[Point2], lead: str = "") -> str:
    """The TrackLine tasks of a mission flying ``points`` in turn, each started by the one
    before's FinishFlag (so the helm links them), the last ending the mission; ``lead``: an
    extra entry line for each (e.g. ``Lead = 5``)."""
    blocks = []
    for k in range(len(points) - 1):
        (x1, y1), (x2, y2) = points[k], points[k + 1]
        start = f"        StartFlag = Line{k}\n" if k else ""
        finish = f"Line{k + 1}" if k < len(points) - 2 else "EndMission"
        blocks.append(f"""
    Task = TrackLine
    {{
        Name = T{k}
        P1 = {x1:.3f}, {y1:.3f}
        P2 = {x2:.3f}, {y2:.3f}
        Radius = 1
        {lead}
        Thrust = 100
        TimeOut = 200
{start}        FinishFlag = {finish}
    }}
""")
    return "".join(blocks)


def held_xte(track: list[tuple[float, float]],
             points: list[Point2]) -> list[tuple[float, float] | None]:
    """The RMS and the largest |XTE| (m) in the held part of each line after the run-in, from
    a track of (x, y) in time order, or None where the track never held it. A line's points
    are those from the track's nearest pass of its start to its nearest pass of its end, both
    before its nearest pass of the next line's end (so the next line of a sharp corner, which
    doubles back over this one, is not counted against it)."""
    start_along, end_short = WINDOW
    lines = list(zip(points[1:], points[2:], strict=False))
    worst: list[tuple[float, float] | None] = []
    cursor = 0
    for k, (p1, p2) in enumerate(lines):
        if not track[cursor:]:
            worst.append(None)
            continue
        stop = len(track)
        if k + 1 < len(lines):
            stop = _nearest(track, lines[k + 1][1], cursor, stop) + 1
        first = _nearest(track, p1, cursor, stop)
        last = _nearest(track, p2, first, stop)
        length = math.dist(p1, p2)
        held = []
        for p in track[first:last + 1]:
            along, xte = track_position(p1, p2, p)
            if start_along <= along <= length - end_short:
                held.append(abs(xte))
        worst.append((math.sqrt(sum(e * e for e in held) / len(held)), max(held)) if held
                     else None)
        cursor = last
    return worst


def _nearest(track: list[tuple[float, float]], p: Point2, lo: int, hi: int) -> int:
    return min(range(lo, hi), key=lambda i: math.dist(track[i], p))
