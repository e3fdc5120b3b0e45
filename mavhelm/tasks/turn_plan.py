"""The planned turn onto a line: an arc tangent to both lines at a corner, and how it is flown.

A route's corner (the line in, P0→P1, meets the line out, P1→P2, turning by Δ) is flown as the
line in, an arc of radius r tangent to both, and the line out: the *entry path* of the line
out. The arc leaves the line in r·tan(|Δ|/2) before the corner and joins the line out as far
after it, so the vehicle arrives on the line out, on its heading, instead of pursuing a carrot
across the corner and swinging past the line (at 5 m/s on the real SITL motorboat a survey's
U-turn over a 20 m join, flown by pursuit, rate-limited at 62 deg/s and overshot the join by
1 m before the turn onto the next leg; ``benchmarks/bench_tracking.py``).

The radius is the route's Lead (LeadTime × speed: a turn at 1 / LeadTime rad/s, 38 deg/s at the
default 1.5 s, within the SITL boats' 50–60 deg/s at 5 m/s), smaller where the arc would not
fit in half of either line (a survey's join: both of its corners' arcs, and the straight
between, fit in it). Before a corner of more than 90° the route slows down (``corner_speed``) so
that its arc, of the Lead at the slower speed, is tight.

The entry path is flown as a line is: the heading asked is the path's direction at the
vehicle's projection on it, ``ahead`` metres further on (the heading loop's lag run at the
speed, so the turn is asked for when it must start, and stops being asked for as early before
the arc's end), less atan(offset / Lead), the offset signed as a cross-track error (positive
to starboard of the path). On the straight parts that is the line's pursuit law; on the arc the
look-ahead is the feed-forward of the arc's turn rate the heading loop needs (a P loop of gain
Kψ lags a turning heading by ω / Kψ: 8° at 38 deg/s on the line loop's default 4.5 /s, plus
the vehicle's delay).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mavhelm.core.geodesy import wrap_degrees
from mavhelm.tasks.geometry import Point2, bearing, distance, offset, track_position

PARALLEL = 1.0
"""Degrees: lines this close to anti-parallel (and a join this close to square to them) make a
U-turn (``is_u_turn``)."""
U_TURN_LEADS = (0.5, 2.0)
"""A U-turn's radius (half its join) in Leads: tighter than half a Lead (faster than 2 /
LeadTime rad/s) it is flown as two corners; wider than two it is, too, rather than sweep that
far beyond the lines' ends."""
MIN_TURN = 1.0
"""Degrees: a smaller change of direction is no corner (the lines are flown as one)."""
MAX_TURN = 179.0
"""Degrees: a reversal sharper than this has no tangent arc that fits; pursuit flies it."""
MIN_RADIUS = 0.5
"""Metres: a corner whose arc would be tighter than this is flown by pursuit alone."""
FIT = 0.5
"""The arc joins each line no further than this fraction of its length from the corner, so the
arcs at both ends of a line (a survey's join) never overlap."""


@dataclass(frozen=True)
class Arc:
    """The entry path of a line: the line in up to ``start``, the arc, the line out from
    ``end``. ``sweep`` is the signed turn in radians (positive clockwise, to starboard)."""

    start: Point2
    end: Point2
    centre: Point2
    radius: float
    heading_in: float
    """Direction of the line in, degrees."""
    sweep: float

    @property
    def length(self) -> float:
        return self.radius * abs(self.sweep)

    @property
    def heading_out(self) -> float:
        return (self.heading_in + math.degrees(self.sweep)) % 360.0

    @property
    def turn_in(self) -> float:
        """How far before the corner the arc starts (and after it, ends), metres."""
        return self.radius * math.tan(abs(self.sweep) / 2.0)

    def locate(self, p: Point2) -> tuple[float, float]:
        """(distance along the entry path from the arc's start, negative on the line in;
        offset from the path, positive to starboard) of a vehicle at ``p``. Which part it is
        on is told by its angle about the centre, turned from the start in the turn's sense:
        within the sweep, the arc; beyond it, the line out, up to the bisector of the rest of
        the circle, and the line in after that."""
        side = 1.0 if self.sweep > 0 else -1.0
        sweep = math.degrees(abs(self.sweep))
        turned = (side * (bearing(self.centre, p) - bearing(self.centre, self.start))) % 360.0
        if turned <= sweep:
            return math.radians(turned) * self.radius, side * (self.radius
                                                              - distance(self.centre, p))
        if turned < (sweep + 360.0) / 2.0:
            past, xte = track_position(self.end, offset(self.end, self.heading_out, 1.0), p)
            return self.length + past, xte
        along, xte = track_position(self.start, offset(self.start, self.heading_in, 1.0), p)
        return along, xte

    def direction(self, s: float) -> float:
        """The path's direction (degrees) at ``s`` along it."""
        fraction = min(max(s / self.length, 0.0), 1.0) if self.length > 0 else 1.0
        return (self.heading_in + math.degrees(self.sweep) * fraction) % 360.0

    def heading(self, p: Point2, lead: float, ahead: float) -> tuple[float, float]:
        """(desired heading in degrees, offset in metres) for a vehicle at ``p``: the path's
        direction ``ahead`` metres beyond its projection, less atan(offset / lead)."""
        s, xte = self.locate(p)
        aim = self.direction(s + ahead) - math.degrees(math.atan(xte / max(lead, 1e-6)))
        return aim % 360.0, xte

    def done(self, p: Point2) -> bool:
        """Past the arc's end: the line out is flown by the line's own law."""
        return self.locate(p)[0] >= self.length


def corner_arc(p0: Point2, p1: Point2, p2: Point2, radius: float) -> Arc | None:
    """The arc of at most ``radius`` tangent to P0→P1 and P1→P2 that fits (``FIT``), or None
    where the corner is too slight, too sharp or too tight for one."""
    heading_in, heading_out = bearing(p0, p1), bearing(p1, p2)
    turn = wrap_degrees(heading_out - heading_in)
    if not MIN_TURN <= abs(turn) <= MAX_TURN:
        return None
    half = math.tan(math.radians(abs(turn)) / 2.0)
    room = FIT * min(distance(p0, p1), distance(p1, p2))
    r = min(radius, room / half)
    if r < MIN_RADIUS:
        return None
    d = r * half
    start, end = offset(p1, heading_in, -d), offset(p1, heading_out, d)
    side = 1.0 if turn > 0 else -1.0
    centre = offset(start, heading_in + 90.0 * side, r)
    return Arc(start, end, centre, r, heading_in, math.radians(turn))


def is_u_turn(p0: Point2 | None, p1: Point2, p2: Point2, p3: Point2 | None,
              radius: float) -> bool:
    """Whether P0→P1, the join P1→P2 and P2→P3 make a U-turn flown as one half circle: the
    lines anti-parallel, the join square to them, half the join within ``U_TURN_LEADS`` of
    ``radius`` (the Lead)."""
    if p0 is None or p3 is None:
        return False
    heading_in, heading_join, heading_out = bearing(p0, p1), bearing(p1, p2), bearing(p2, p3)
    reverse = abs(wrap_degrees(heading_out - heading_in - 180.0))
    square = abs(abs(wrap_degrees(heading_join - heading_in)) - 90.0)
    half = distance(p1, p2) / 2.0
    low, high = U_TURN_LEADS
    return reverse <= PARALLEL and square <= PARALLEL and low * radius <= half <= high * radius


def u_turn_arc(p0: Point2, p1: Point2, p2: Point2) -> Arc:
    """The half circle from P1, on the heading of P0→P1, to P2 (abeam of P1): its diameter is
    the join, so the vehicle flies the line in to its end and the line out from its start
    (a survey's legs are covered whole) and turns beyond them."""
    heading_in = bearing(p0, p1)
    turn = wrap_degrees(bearing(p1, p2) - heading_in)
    side = 1.0 if turn > 0 else -1.0
    centre = ((p1[0] + p2[0]) / 2.0, (p1[1] + p2[1]) / 2.0)
    return Arc(p1, p2, centre, distance(p1, p2) / 2.0, heading_in, side * math.pi)


def is_half_circle(arc: Arc | None) -> bool:
    """Whether an entry path is a U-turn's half circle (``u_turn_arc``; a corner's arc turns
    at most ``MAX_TURN``)."""
    return arc is not None and abs(arc.sweep) > math.radians(MAX_TURN)


def entry_path(p0: Point2, p1: Point2, p2: Point2, after: Point2 | None, radius: float, *,
               after_half_circle: bool, u_turn: bool | None = None) -> Arc | None:
    """The planned turn onto the line P1→P2 from P0→P1 (``after`` the point after P2, where
    known): the half circle of a U-turn whose join this line is; none where the line in was
    entered by a half circle (``after_half_circle``: it brought the vehicle onto this line);
    else the corner's arc (``corner_arc``), where one fits. ``u_turn``: whether this line is
    a U-turn's join, as decided earlier (None: as ``is_u_turn`` says at ``radius``).

    Whether the line in was a half circle is what was flown, not the classification redone
    at the speed measured now: the speed is measured afresh at every corner, and a U-turn
    classed as two corners at its second corner (or the reverse) would leave that corner
    unplanned (2.9 m past the line on the real SITL rover-skid at 4 m/s, where a repeated GPS
    fix dipped the speed measured across the threshold)."""
    if is_u_turn(p0, p1, p2, after, radius) if u_turn is None else u_turn:
        return u_turn_arc(p0, p1, p2)
    if after_half_circle:
        return None
    return corner_arc(p0, p1, p2, radius)


def turn_in(p0: Point2, p1: Point2, p2: Point2, after: Point2 | None, radius: float,
            lag: float, *, on_half_circle: bool, u_turn: bool | None = None) -> float | None:
    """How far before P1 to leave the line P0→P1 for P1→P2 (``after`` as for ``entry_path``;
    ``lag``: the way run during the heading loop's lag, metres; ``on_half_circle``: the line
    P0→P1 was entered by a U-turn's half circle), so the turn is asked for when it must start:
    at a U-turn's join, the lag; at the end of a join entered by its half circle, nothing (the
    half circle ends on the line out); at a corner with an arc, where the arc starts plus the
    lag, at most ``FIT`` of the line; None where no turn is planned (too slight or too sharp:
    pursuit's own turn-in). ``u_turn``: whether P1→P2 is a U-turn's join, as decided earlier
    (None: as ``is_u_turn`` says at ``radius``)."""
    if on_half_circle:
        return 0.0
    if is_u_turn(p0, p1, p2, after, radius) if u_turn is None else u_turn:
        return min(lag, FIT * distance(p0, p1))
    arc = corner_arc(p0, p1, p2, radius)
    if arc is None:
        return None
    return min(arc.turn_in + lag, FIT * distance(p0, p1))
