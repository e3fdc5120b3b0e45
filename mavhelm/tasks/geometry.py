"""Plane geometry of the track-following tasks (TrackLine, XYPattern, Orbit, Survey).

Pure functions, no state and no I/O. The local frame is the mission's: ``x`` east, ``y`` north,
metres; bearings and headings are degrees clockwise from north in [0, 360).

Track position of a point P relative to a segment P1→P2:

- *along-track* distance: how far P's projection lies along the line from P1 (negative
  behind P1, beyond the segment's length past P2);
- *cross-track* distance: the signed distance from the line, **positive to starboard** (to the
  right of someone travelling from P1 to P2), negative to port.
"""

from __future__ import annotations

import math

Point2 = tuple[float, float]
"""A point of the local frame: (x east, y north) in metres."""

DEGENERATE = 1e-6
"""A segment shorter than this (metres) has no direction: it is treated as its end point."""


def bearing(a: Point2, b: Point2) -> float:
    """Compass bearing from ``a`` to ``b`` in degrees [0, 360); 0 when they coincide."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    if dx == 0.0 and dy == 0.0:
        return 0.0
    angle = math.degrees(math.atan2(dx, dy)) % 360.0
    return 0.0 if angle >= 360.0 else angle


def distance(a: Point2, b: Point2) -> float:
    return math.hypot(b[0] - a[0], b[1] - a[1])


def offset(p: Point2, bearing_deg: float, metres: float) -> Point2:
    """The point ``metres`` from ``p`` along compass bearing ``bearing_deg``."""
    b = math.radians(bearing_deg)
    return p[0] + metres * math.sin(b), p[1] + metres * math.cos(b)


def track_position(p1: Point2, p2: Point2, p: Point2) -> tuple[float, float]:
    """(along-track, cross-track) of ``p`` relative to the segment ``p1``→``p2``, in metres.

    Cross-track is positive to starboard of the direction of travel. For a degenerate segment
    (``p1`` ≈ ``p2``) along-track is 0 and cross-track is 0: it has no line to be off.
    """
    dx, dy = p2[0] - p1[0], p2[1] - p1[1]
    length = math.hypot(dx, dy)
    if length < DEGENERATE:
        return 0.0, 0.0
    ux, uy = dx / length, dy / length
    rx, ry = p[0] - p1[0], p[1] - p1[1]
    along = rx * ux + ry * uy
    cross = rx * uy - ry * ux  # (ux, uy) turned 90° clockwise is (uy, -ux): starboard
    return along, cross


def carrot(p1: Point2, p2: Point2, p: Point2, lead: float) -> Point2:
    """The point a vehicle at ``p`` steers for: its projection on the line ``p1``→``p2`` plus
    ``lead`` metres along it (spec 1.4.3), never beyond ``p2``. A degenerate segment's carrot
    is ``p2``."""
    length = distance(p1, p2)
    if length < DEGENERATE:
        return p2
    along, _ = track_position(p1, p2, p)
    s = min(along + lead, length)
    t = s / length
    return p1[0] + t * (p2[0] - p1[0]), p1[1] + t * (p2[1] - p1[1])


def lawnmower(center: Point2, a: float, b: float, spacing: float,
              rotation: float) -> list[tuple[Point2, Point2]]:
    """The legs of a mow-the-lawn survey of an ``a`` × ``b`` box, in the order they are flown.

    The box is centred on ``center``; its ``a`` side runs along compass direction ``rotation``
    (the legs' direction) and its ``b`` side across it. There are ``floor(b / spacing) + 1``
    legs, ``spacing`` apart and centred across the box (so the outer legs are on its edges when
    ``b`` is a multiple of ``spacing``). Leg 0 is the one furthest to port of ``rotation`` and is
    flown along ``rotation``; each next leg is one spacing to starboard and flown the other way
    (boustrophedon), so the end of one leg and the start of the next are ``spacing`` apart.
    Each leg is (start, end).
    """
    if a <= 0.0 or b <= 0.0 or spacing <= 0.0:
        raise ValueError("survey extents and spacing must be positive")
    count = int(math.floor(b / spacing + 1e-9)) + 1
    width = (count - 1) * spacing
    legs: list[tuple[Point2, Point2]] = []
    for i in range(count):
        across = -width / 2.0 + i * spacing
        mid = offset(center, rotation + 90.0, across)
        back, front = offset(mid, rotation, -a / 2.0), offset(mid, rotation, a / 2.0)
        legs.append((back, front) if i % 2 == 0 else (front, back))
    return legs


def polygon(center: Point2, radius: float, sides: int) -> list[Point2]:
    """The vertices of a regular polygon inscribed in a circle, vertex 0 due north of the
    centre and the others clockwise from it (vertex k at bearing k × 360 / sides)."""
    if sides < 3 or radius <= 0.0:
        raise ValueError("a polygon needs at least 3 sides and a positive radius")
    return [offset(center, k * 360.0 / sides, radius) for k in range(sides)]


def nearest(points: list[Point2], p: Point2) -> int:
    """Index of the point nearest ``p`` (the first one on a tie)."""
    if not points:
        raise ValueError("no points")
    return min(range(len(points)), key=lambda i: (distance(points[i], p), i))


def side_length(radius: float, sides: int) -> float:
    """Length of a side of the regular polygon of ``sides`` inscribed in a circle of ``radius``."""
    return 2.0 * radius * math.sin(math.pi / sides)
