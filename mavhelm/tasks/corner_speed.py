"""The slow-down for a sharp corner: a skipper slows before a corner of more than 90° so the
turn can be made tight, and speeds up again once on the next line.

A route's planned turn (``turn_plan``) is an arc of one Lead (LeadTime × the speed) tangent to
both lines; it leaves the line in Lead · tan(Δ/2) before a corner of Δ and joins the line out as
far after it: one Lead at 90°, 2.4 Leads at 135°, 5.7 at 160°. At 5 m/s (Lead 7.5 m) a 135°
corner's arc starts 18 m before it, well inside the part of a 60 m line that is meant to be
held (from 10 m along it to 5 m before its end), and on the real SITL motorboat the XTE there
reached 5–6 m. A skipper slows down so the turn can be tight.

How slow. An arc of radius r started s metres back is s² / (2r) off the line (to the
parabola's approximation). At ``fraction`` cot²(Δ/2) of the speed the radius is that much
smaller and the arc starts Lead · cot(Δ/2) before the corner (0.41 Leads at 135°), so at every
distance before the corner it is no further off the line in than a 90° corner's arc at full
speed is (as far abeam the corner: Lead / 2), and it joins the line out as soon after it. The
turn rate on the arc is unchanged (speed / radius = 1 / LeadTime). Slower than the speed whose
Lead is the shortest (1 m) would not tighten the arc, and slower than ``MIN_FRACTION`` a hull
may not steer.

The slow-down is a thrust vote: ArduPilot Rover in GUIDED turns the thrust into a speed target
of thrust × WP_SPEED, so a fraction of the thrust is that fraction of the speed whatever
WP_SPEED is. Rover ramps its speed target down at ``ATC_DECEL_MAX`` (0 by default: then
``ATC_ACCEL_MAX``, 1 m/s² by default; ``AR_AttitudeControl::get_desired_speed_accel_limited``),
and its speed loop lags the target, so the vehicle starts slowing, from the speed measured,
its braking distance (``braking_distance``) before the slow arc's turn-in. Corners up to 90°
and a survey's U-turns (90° onto the join, 90° off it) are flown at full speed.
"""

from __future__ import annotations

import math

SHARP = 90.0
"""Degrees: corners sharper than this are slowed for (a 90° corner's arc leaves the line one
Lead before it, the reference for the sharper ones)."""
SQUARE = 1.0
"""Degrees: a corner this close to ``SHARP`` is square (a survey's corners, whose bearings are
computed, not given), flown at full speed."""
MIN_FRACTION = 0.15
"""The slowest a corner is taken, as a fraction of the speed (a judgement: slower, a boat's
rudder has little water over it). The real SITL motorboat took a 160° corner from 5 m/s at
0.75 m/s (briefly 0.5 m/s as its speed loop settled) on its 1.1 m arc."""
DECELERATION = 1.0
"""m/s²: how fast the vehicle slows when asked (ArduPilot Rover's ``ATC_ACCEL_MAX`` default,
which ``ATC_DECEL_MAX`` = 0, its default, means for slowing too)."""
SPEED_LAG_S = 1.0
"""Seconds between asking for less speed and the vehicle slowing at ``DECELERATION`` (the
helm's tick, telemetry, the autopilot's speed loop)."""


def fraction(turn: float, speed: float, lead_time: float, min_lead: float) -> float:
    """The fraction of ``speed`` (m/s) to take a corner of ``turn`` degrees (unsigned) at, with
    the Lead ``lead_time`` seconds of the speed but at least ``min_lead`` metres: cot²(turn/2),
    1 up to ``SHARP`` (and ``SQUARE`` beyond it), never below ``MIN_FRACTION`` nor slower than
    the speed whose Lead is ``min_lead`` (slower would not tighten the arc)."""
    if turn <= SHARP + SQUARE or speed <= 0.0:
        return 1.0
    want = 1.0 / math.tan(math.radians(turn) / 2.0) ** 2 if turn < 180.0 else 0.0
    floor = max(MIN_FRACTION, min_lead / (lead_time * speed))
    return min(1.0, max(want, floor))


def braking_distance(speed: float, slow: float) -> float:
    """Metres run while slowing from ``speed`` to ``slow`` (m/s): ``SPEED_LAG_S`` at the speed,
    then a steady ``DECELERATION``."""
    if slow >= speed:
        return 0.0
    return SPEED_LAG_S * speed + (speed * speed - slow * slow) / (2.0 * DECELERATION)
