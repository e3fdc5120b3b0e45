"""pNav's least-squares position fix from beacon ranges (spec 2.2): pure logic, no clock.

The LSQ filter has no memory of earlier fixes and no vehicle model: it accrues ranges over a
short window until the position is observable (ranges to at least ``min_beacons`` different
beacons), solves by Gauss–Newton (Newton–Raphson on the linearised range equations, with step
halving), publishes the fix and starts again from scratch. Being memory-less it cannot diverge,
which is why it boots the EKF when the start is known only roughly and watches it afterwards
(spec 2.2.9; the checks are :mod:`mavhelm.nav.filter_safety`).

Data rejection (spec 2.2.6): a solution whose weighted residuals fail a χ² test (with n − 2
degrees of freedom, n − 3 with the offset) has its worst range dropped and is solved again
while enough beacons remain; the range dropped is the one whose absence leaves the most
consistent fix (not merely the largest residual, which a bad range can hide). With little
redundancy (three ranges to three beacons: one degree of freedom) a bad range can still be
absorbed into a wrong fix, which is why the EKF is booted only on a repeatable stream of fixes
(see :mod:`mavhelm.nav.replay`).

The spec's LSQ has five states, X, Y, Z, heading and tide, from every pose-proportional
observation. :func:`solve_joint` is that one solve: the window's ranges (with their sensor's
lever, through which the heading moves the antenna), XY fixes, depths, orientation readings
and a FIXEDTIDE, one Gauss–Newton over the states they observe; the others are held (Z at
the surface, the heading at north, the tide at FIXEDTIDE's value or 0) and named in the fix's
``unobserved``. The ranges are slant ranges in the vehicle's plane (a beacon's z is relative
to it), so they do not see Z, and a depth alone cannot part Z from the tide: the tide is
solved only against a tide observation. The χ² rejection tests the position equations
(ranges and fixes) and drops a range or an XY fix; a heading's spread over the window is the
static model's error, not a bad reading. Without a lever or an XY fix nothing ties the
heading to the ranges and the normal equations are block-diagonal: the position block is
:func:`solve` (same solution, its faster path), the rest its own small solve.

Optional hidden state: with ``estimate_offset`` and ranges to one beacon more than needed, a
common range offset (a turn-around delay shared by the net) is solved for as well; the fix
then says what it found (``offset``).

Why by hand rather than ``scipy.optimize.least_squares``: measured on the same 400
Plaza-like problems, same starts and stopping rule (``benchmarks/bench_lsq.py``, three runs
on a loaded two-core machine), this Gauss–Newton took 280–555 µs a fix for x, y against
scipy's 565–1115 µs, and 205–265 µs with the offset against 355–366 µs: 1.3× to 2.0× faster
(scipy's per-call set-up dominates problems of 2 or 3 unknowns). The positions agree to
1e-14 m median, within 1 cm in every fix but one of 400 with the offset (where the two
descents reach different minima of an ill-posed offset).

The vehicle is taken to be still during the window (spec 2.2.2: the LSQ uses a static model):
keep ``window`` a few seconds, so a moving vehicle's fix is smeared by at most speed × window.
"""

from __future__ import annotations

import dataclasses
import math
from collections import deque
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass
from typing import Final

from mavhelm.nav.chi_square import chi2_logsf, chi2_ppf
from mavhelm.nav.ekf import Beacon, Depth, Position, Range, Yaw
from mavhelm.nav.settings import LSQ_WINDOW


@dataclass(frozen=True)
class Fix:
    """An LSQ position: ``t`` is the newest range's time, ``sigma`` the larger 1-σ of the
    position (from the normal equations and the ranges' noise), ``rms`` the residual RMS (m),
    ``chi2`` the sum of squared weighted residuals and ``dof`` its degrees of freedom,
    ``offset`` the common range offset solved for (0 when not estimated); ``yaw`` (rad),
    ``z`` (m, up), ``depth`` (m, at the depth sensor: tide − z − its height) and ``tide``
    (m) from the same solve when the window's data observe them (the spec's five-state LSQ:
    X, Y, Z, heading, tide), None otherwise; ``unobserved`` names the states left out."""

    t: float
    x: float
    y: float
    sigma: float
    rms: float
    n: int
    beacons: tuple[str, ...]
    offset: float = 0.0
    chi2: float = 0.0
    dof: int = 0
    yaw: float | None = None
    depth: float | None = None
    z: float | None = None
    tide: float | None = None
    unobserved: tuple[str, ...] = ()


_Row = tuple[float, float, float, float, float]
"""One range equation: beacon x, y, z², range less the beacon's prior offset, weight 1/σ."""


def solve(ranges: Sequence[Range], beacons: dict[str, Beacon], *,
          guess: tuple[float, float] | None = None, estimate_offset: bool = False,
          max_iterations: int = 25, tolerance: float = 1e-4) -> Fix | None:
    """Gauss–Newton fix from ``ranges`` (each corrected by its beacon's prior offset); None if
    unobservable (fewer than 3 beacons, or 4 with ``estimate_offset``) or not converging.

    The iteration starts from ``guess``; without one, from the beacons' centroid and then six
    points around the net until a solution fits the ranges within 3 σ each, keeping the
    lowest-residual one, so the mirror solution of a poor geometry is not taken by accident.

    Plain Python floats, not numpy: with 3 to 8 ranges and 2 or 3 unknowns numpy's per-call
    overhead is the whole cost (measured 680 µs a fix with numpy, a fifth of a Plaza replay).
    """
    names = sorted({r.beacon for r in ranges})
    if len(names) < (4 if estimate_offset else 3):
        return None
    rows: list[_Row] = [(beacons[r.beacon].x, beacons[r.beacon].y, beacons[r.beacon].z ** 2,
                         r.z - beacons[r.beacon].offset, 1.0 / max(r.sigma, 1e-6))
                        for r in ranges]
    k = 3 if estimate_offset else 2
    good_enough = 9.0 * len(ranges)  # within 3 σ per range: stop trying other starts
    best: tuple[float, list[float]] | None = None
    centroid = (sum(beacons[n].x for n in names) / len(names),
                sum(beacons[n].y for n in names) / len(names))
    for start in [guess] if guess is not None else _starts(rows, centroid):
        cost, p = _descend([start[0], start[1], 0.0], rows, k, max_iterations, tolerance)
        same = best is not None and math.hypot(p[0] - best[1][0], p[1] - best[1][1]) < 0.1
        if best is None or cost < best[0]:
            best = (cost, p)
        if best[0] <= good_enough or same:
            break  # a good fit, or the same minimum found from two starts
    return None if best is None else _fix(best[1], rows, k, ranges, names)


def _starts(rows: list[_Row], centroid: tuple[float, float]) -> list[tuple[float, float]]:
    """The beacons' centroid, then six points on a circle through the farthest beacon."""
    cx, cy = centroid
    spread = max(max(math.hypot(bx - cx, by - cy) for bx, by, *_ in rows), 1.0)
    return [(cx, cy)] + [(cx + spread * math.cos(a), cy + spread * math.sin(a))
                         for a in (2 * math.pi * j / 6 for j in range(6))]


def _descend(p: list[float], rows: list[_Row], k: int, max_iterations: int,
             tolerance: float) -> tuple[float, list[float]]:
    """Gauss–Newton steps from ``p``, each halved until it lowers the cost; (cost, p)."""

    def step_of(q: list[float]) -> list[float] | None:
        step = _solve_small(*_normal_equations(q, rows, k))
        return step + [0.0] if step is not None and k == 2 else step

    return _gauss_newton(p, lambda q: _cost(q, rows), step_of, range(3), max_iterations,
                         tolerance)


def _gauss_newton(p: list[float], cost_of: Callable[[list[float]], float],
                  step_of: Callable[[list[float]], list[float] | None], states: Sequence[int],
                  max_iterations: int, tolerance: float) -> tuple[float, list[float]]:
    """Gauss–Newton from ``p`` on ``states``: each step (None: the normal equations are
    singular) halved until it does not raise the cost; stops when a step taken is below
    ``tolerance`` or even a thousandth of one raises the cost. Returns (cost, p)."""
    cost = cost_of(p)
    for _ in range(max_iterations):
        step = step_of(p)
        if step is None:
            break
        scale = 1.0
        while scale > 1e-3:
            trial = list(p)
            for state, delta in zip(states, step, strict=True):
                trial[state] += scale * delta
            trial_cost = cost_of(trial)
            if trial_cost <= cost:
                break
            scale *= 0.5
        else:
            break
        p, cost = trial, trial_cost
        if scale * math.sqrt(sum(v * v for v in step)) < tolerance:
            break
    return cost, p


def _fix(p: list[float], rows: list[_Row], k: int, ranges: Sequence[Range],
         names: list[str]) -> Fix | None:
    """The fix at the solution ``p``, with its 1-σ from the normal equations."""
    normal, _ = _normal_equations(p, rows, k)
    cov = _inverse_small(normal)
    if cov is None:
        return None  # a degenerate net: the position is not determined
    half_sum, half_diff = (cov[0][0] + cov[1][1]) / 2, (cov[0][0] - cov[1][1]) / 2
    sigma = math.sqrt(max(half_sum + math.hypot(half_diff, cov[0][1]), 0.0))
    residuals = [(z - _distance(p, bx, by, bz2) - p[2], w) for bx, by, bz2, z, w in rows]
    return Fix(t=max(r.t for r in ranges), x=p[0], y=p[1], sigma=sigma,
               rms=math.sqrt(sum(r * r for r, _ in residuals) / len(residuals)),
               n=len(ranges), beacons=tuple(names), offset=p[2],
               chi2=sum((w * r) ** 2 for r, w in residuals), dof=len(ranges) - k)


def _distance(p: list[float], bx: float, by: float, bz2: float) -> float:
    return max(math.sqrt((p[0] - bx) ** 2 + (p[1] - by) ** 2 + bz2), 1e-6)


def _cost(p: list[float], rows: list[_Row]) -> float:
    x, y, offset = p[0], p[1], p[2]  # _distance inline: this runs a dozen times a fix
    return sum((w * (z - max(math.sqrt((x - bx) ** 2 + (y - by) ** 2 + bz2), 1e-6) - offset))
               ** 2 for bx, by, bz2, z, w in rows)


def _normal_equations(p: list[float], rows: list[_Row],
                      k: int) -> tuple[list[list[float]], list[float]]:
    """JᵀWJ and JᵀWr of the weighted range equations at ``p`` (k unknowns: x, y[, offset]).

    Written out for the two or three unknowns, each sum term the loop over (i, j) would make,
    ``(w² J_i) J_j`` and ``(w² J_i) r`` (the offset's J is 1): the same floats, without a
    Python loop per entry."""
    x, y, offset = p[0], p[1], p[2]
    n00 = n01 = n10 = n11 = r0 = r1 = 0.0
    n02 = n12 = n20 = n21 = n22 = r2 = 0.0
    for bx, by, bz2, z, w in rows:
        d = max(math.sqrt((x - bx) ** 2 + (y - by) ** 2 + bz2), 1e-6)  # _distance, inline
        jx, jy = (x - bx) / d, (y - by) / d
        w2 = w * w
        r = z - d - offset
        wx, wy = w2 * jx, w2 * jy
        r0 += wx * r
        r1 += wy * r
        n00 += wx * jx
        n01 += wx * jy
        n10 += wy * jx
        n11 += wy * jy
        if k == 3:
            n02 += wx
            n12 += wy
            n20 += w2 * jx
            n21 += w2 * jy
            n22 += w2
            r2 += w2 * r
    if k == 2:
        return [[n00, n01], [n10, n11]], [r0, r1]
    return [[n00, n01, n02], [n10, n11, n12], [n20, n21, n22]], [r0, r1, r2]


def _solve_small(a: list[list[float]], b: list[float]) -> list[float] | None:
    """x with a x = b for a 2×2 or 3×3 symmetric positive system; None if singular."""
    inv = _inverse_small(a)
    if inv is None:
        return None
    return [sum(inv[i][j] * b[j] for j in range(len(b))) for i in range(len(b))]


def _inverse_small(a: list[list[float]]) -> list[list[float]] | None:
    """The inverse of a 2×2 or 3×3 matrix by cofactors; None when it is (nearly) singular
    (a determinant below 1e-12 of the product of its diagonal: a net too degenerate)."""
    if len(a) == 2:
        det = a[0][0] * a[1][1] - a[0][1] * a[1][0]
        if not abs(det) > 1e-12 * abs(a[0][0] * a[1][1]) or det == 0.0:
            return None
        return [[a[1][1] / det, -a[0][1] / det], [-a[1][0] / det, a[0][0] / det]]
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = a
    c00, c01, c02 = a11 * a22 - a12 * a21, a12 * a20 - a10 * a22, a10 * a21 - a11 * a20
    det = a00 * c00 + a01 * c01 + a02 * c02
    if not abs(det) > 1e-12 * abs(a00 * a11 * a22) or det == 0.0:
        return None
    return [[c00 / det, (a02 * a21 - a01 * a22) / det, (a01 * a12 - a02 * a11) / det],
            [c01 / det, (a00 * a22 - a02 * a20) / det, (a02 * a10 - a00 * a12) / det],
            [c02 / det, (a01 * a20 - a00 * a21) / det, (a00 * a11 - a01 * a10) / det]]

# ----------------------------------------------------------------------------- the joint solve

POSE_STATES: Final = ("X", "Y", "Z", "HEADING", "TIDE", "OFFSET")
"""The LSQ's states (spec 2.2: "five state", X, Y, Z, heading, tide; the common range offset
is this project's sixth, off unless ``LSQ_OFFSET``)."""
_X, _Y, _Z, _H, _T, _O = range(6)
_RANGE, _FIX_X, _FIX_Y, _DEPTH, _YAW, _TIDE = range(6)
_POSITION_KINDS: Final = (_RANGE, _FIX_X, _FIX_Y)

_Eq = tuple[int, float, float, float, float, float, float, float]
"""One scalar pose-proportional equation: kind, measured value, weight 1/σ, then a range's
beacon x, y, z² (a depth's sensor height first), then the sensor's lever x, y (body)."""


def _equation(p: list[float], sin_h: float, cos_h: float,
              eq: _Eq) -> tuple[float, tuple[tuple[int, float], ...]]:
    """The residual (measured − predicted) of ``eq`` at ``p`` and its non-zero derivatives."""
    kind, z, _w, a, b, c, lx, ly = eq
    if kind == _RANGE:
        dx = p[_X] + lx * cos_h - ly * sin_h - a
        dy = p[_Y] + lx * sin_h + ly * cos_h - b
        d = max(math.sqrt(dx * dx + dy * dy + c), 1e-6)
        dh = (dx * (-lx * sin_h - ly * cos_h) + dy * (lx * cos_h - ly * sin_h)) / d
        return z - d - p[_O], ((_X, dx / d), (_Y, dy / d), (_H, dh), (_O, 1.0))
    if kind == _FIX_X:
        return (z - p[_X] - lx * cos_h + ly * sin_h,
                ((_X, 1.0), (_H, -lx * sin_h - ly * cos_h)))
    if kind == _FIX_Y:
        return (z - p[_Y] - lx * sin_h - ly * cos_h,
                ((_Y, 1.0), (_H, lx * cos_h - ly * sin_h)))
    if kind == _DEPTH:
        return z - (p[_T] - p[_Z] - a), ((_Z, -1.0), (_T, 1.0))
    if kind == _YAW:
        return math.remainder(z - p[_H], 2 * math.pi), ((_H, 1.0),)
    return z - p[_T], ((_T, 1.0),)


def _joint_cost(p: list[float], eqs: list[_Eq]) -> float:
    s, c = math.sin(p[_H]), math.cos(p[_H])
    return sum((eq[2] * _equation(p, s, c, eq)[0]) ** 2 for eq in eqs)


def _joint_normal(p: list[float], eqs: list[_Eq], slot: dict[int, int]
                  ) -> tuple[list[list[float]], list[float]]:
    """JᵀWJ and JᵀWr of ``eqs`` at ``p`` over the solved states (``slot``: state → column)."""
    k = len(slot)
    normal = [[0.0] * k for _ in range(k)]
    rhs = [0.0] * k
    s, c = math.sin(p[_H]), math.cos(p[_H])
    for eq in eqs:
        r, partials = _equation(p, s, c, eq)
        w2 = eq[2] * eq[2]
        cols = [(slot[i], v) for i, v in partials if i in slot and v != 0.0]
        for i, vi in cols:
            rhs[i] += w2 * vi * r
            for j, vj in cols:
                normal[i][j] += w2 * vi * vj
    return normal, rhs


def _joint_descend(p: list[float], eqs: list[_Eq], slot: dict[int, int], max_iterations: int,
                   tolerance: float) -> tuple[float, list[float]]:
    """Gauss–Newton steps over the solved states, each halved until it lowers the cost."""
    return _gauss_newton(p, lambda q: _joint_cost(q, eqs),
                         lambda q: _solve_any(*_joint_normal(q, eqs, slot)),
                         sorted(slot, key=slot.__getitem__), max_iterations, tolerance)


def _solve_any(a: list[list[float]], b: list[float]) -> list[float] | None:
    if len(a) == 1:
        return [b[0] / a[0][0]] if a[0][0] > 0.0 else None
    inv = _inverse_small(a) if len(a) <= 3 else _inverse_gauss_jordan(a)
    if inv is None:
        return None
    return [sum(inv[i][j] * b[j] for j in range(len(b))) for i in range(len(b))]


def _inverse_gauss_jordan(a: list[list[float]]) -> list[list[float]] | None:
    """The inverse of a small symmetric positive matrix (4 to 6 states) by Gauss–Jordan with
    partial pivoting; None when a pivot falls below 1e-12 of its diagonal (singular)."""
    n = len(a)
    m = [list(row) + [1.0 if i == j else 0.0 for j in range(n)] for i, row in enumerate(a)]
    for col in range(n):
        pivot = max(range(col, n), key=lambda r: abs(m[r][col]))
        if not abs(m[pivot][col]) > 1e-12 * max(abs(a[col][col]), 1e-300):
            return None
        m[col], m[pivot] = m[pivot], m[col]
        inv_p = 1.0 / m[col][col]
        m[col] = [v * inv_p for v in m[col]]
        for r in range(n):
            if r != col and m[r][col] != 0.0:
                f = m[r][col]
                m[r] = [vr - f * vc for vr, vc in zip(m[r], m[col], strict=True)]
    return [row[n:] for row in m]


def solve_joint(ranges: Sequence[Range], poses: Sequence[Yaw | Depth | Position],
                beacons: dict[str, Beacon], *, guess: tuple[float, float] | None = None,
                estimate_offset: bool = False, tide: float = 0.0,
                tide_sigma: float | None = None, max_iterations: int = 25,
                tolerance: float = 1e-4) -> Fix | None:
    """One Gauss–Newton solve of every pose-proportional observation of a window: ranges
    (with their sensor's lever, which ties the heading in), XY fixes, depths, headings and the
    tide (``tide_sigma``: FIXEDTIDE's σ, else the tide is held at ``tide``). Only the states
    the data observe are solved; the rest are held and named in ``unobserved``: Z needs a
    depth, the heading an orientation reading, the tide a tide observation (the ranges are in
    the vehicle's plane, so they do not see Z, and a depth alone cannot part Z from the tide),
    the offset a fourth beacon. X and Y need ranges to three beacons or an XY fix: else None,
    as when the solve does not converge or the net is degenerate. Starts as :func:`solve`."""
    names = sorted({r.beacon for r in ranges})
    fixes, yaws, depths = _by_kind(poses)
    if len(names) < (4 if estimate_offset else 3) and not fixes:
        return None
    eqs = _equations(ranges, fixes, depths, yaws, beacons, tide, tide_sigma)
    slot = _slots(bool(depths), bool(yaws), tide_sigma is not None,
                  estimate_offset and len(names) >= 4)
    start, lever_z = _pose_start(depths, yaws, tide)
    limits = (max_iterations, tolerance)
    if fixes or any(r.lever[0] or r.lever[1] for r in ranges):
        best = _joint_best(eqs, slot, start, _joint_starts(guess, fixes, names, beacons),
                           limits)
        return _joint_fix(best, eqs, slot, ranges, fixes, names, lever_z)
    # nothing ties the heading into the ranges: the normal equations are block-diagonal, and
    # the position block is :func:`solve`'s problem (its faster path, the same solution)
    fix = solve(ranges, beacons, guess=guess, estimate_offset=estimate_offset,
                max_iterations=max_iterations, tolerance=tolerance)
    if fix is None:
        return None
    pose_slot = {st: k for k, st in enumerate(st for st in slot if st in (_Z, _H, _T))}
    p = [fix.x, fix.y, *start[2:5], fix.offset]
    if pose_slot:
        _, p = _joint_descend(p, eqs[len(ranges):], pose_slot, *limits)
    return dataclasses.replace(fix, **_pose_fields(p, slot, lever_z))


def _by_kind(poses: Sequence[Yaw | Depth | Position]
             ) -> tuple[list[Position], list[Yaw], list[Depth]]:
    return ([p for p in poses if isinstance(p, Position)],
            [p for p in poses if isinstance(p, Yaw)], [p for p in poses if isinstance(p, Depth)])


def _slots(depth: bool, heading: bool, tide: bool, offset: bool) -> dict[int, int]:
    """The solved states (X and Y always, the others when observed) → their column."""
    seen = ((_Z, depth), (_H, heading), (_T, tide), (_O, offset))
    return {state: k for k, state in enumerate([_X, _Y] + [st for st, yes in seen if yes])}


def _joint_best(eqs: list[_Eq], slot: dict[int, int], start: list[float],
                starts: list[tuple[float, float]], limits: tuple[int, float]) -> list[float]:
    """The lowest-cost solution from the X, Y ``starts`` (stopping at one within 3 σ an
    equation, or at the same minimum reached from two starts)."""
    best: tuple[float, list[float]] | None = None
    for sx, sy in starts:
        cost, p = _joint_descend([sx, sy, *start[2:]], eqs, slot, *limits)
        same = best is not None and math.hypot(p[0] - best[1][0], p[1] - best[1][1]) < 0.1
        if best is None or cost < best[0]:
            best = (cost, p)
        if best[0] <= 9.0 * len(eqs) or same:
            break
    assert best is not None
    return best[1]


def _pose_start(depths: list[Depth], yaws: list[Yaw], tide: float) -> tuple[list[float], float]:
    """The states' start (X, Y at 0: the caller's) from the readings, and the depth sensors'
    mean height: Z from the mean depth at the held tide, the heading the readings' mean."""
    lever_z = sum(d.lever[2] for d in depths) / len(depths) if depths else 0.0
    z0 = tide - sum(d.z for d in depths) / len(depths) - lever_z if depths else 0.0
    h0 = (math.atan2(sum(math.sin(y.z) for y in yaws), sum(math.cos(y.z) for y in yaws))
          if yaws else 0.0)
    return [0.0, 0.0, z0, h0, tide, 0.0], lever_z


def _equations(ranges: Sequence[Range], fixes: list[Position], depths: list[Depth],
               yaws: list[Yaw], beacons: dict[str, Beacon], tide: float,
               tide_sigma: float | None) -> list[_Eq]:
    """The window's equations: ranges first (the fast path counts on it), then the rest."""
    eqs: list[_Eq] = [(_RANGE, r.z - beacons[r.beacon].offset, 1.0 / max(r.sigma, 1e-6),
                       beacons[r.beacon].x, beacons[r.beacon].y, beacons[r.beacon].z ** 2,
                       r.lever[0], r.lever[1]) for r in ranges]
    for f in fixes:
        w = 1.0 / max(f.sigma, 1e-6)
        eqs += [(_FIX_X, f.x, w, 0.0, 0.0, 0.0, f.lever[0], f.lever[1]),
                (_FIX_Y, f.y, w, 0.0, 0.0, 0.0, f.lever[0], f.lever[1])]
    eqs += [(_DEPTH, d.z, 1.0 / max(d.sigma, 1e-6), d.lever[2], 0.0, 0.0, 0.0, 0.0)
            for d in depths]
    eqs += [(_YAW, y.z, 1.0 / max(y.sigma, 1e-6), 0.0, 0.0, 0.0, 0.0, 0.0) for y in yaws]
    if tide_sigma is not None:
        eqs.append((_TIDE, tide, 1.0 / max(tide_sigma, 1e-6), 0.0, 0.0, 0.0, 0.0, 0.0))
    return eqs


def _joint_starts(guess: tuple[float, float] | None, fixes: list[Position], names: list[str],
                  beacons: dict[str, Beacon]) -> list[tuple[float, float]]:
    """The guess; else the fixes' mean; else :func:`_starts` around the beacons heard."""
    if guess is not None:
        return [guess]
    if fixes:
        return [(sum(f.x for f in fixes) / len(fixes), sum(f.y for f in fixes) / len(fixes))]
    rows = [(beacons[n].x, beacons[n].y, 0.0, 0.0, 0.0) for n in names]
    return _starts(rows, (sum(b[0] for b in rows) / len(rows),
                          sum(b[1] for b in rows) / len(rows)))


def _joint_fix(p: list[float], eqs: list[_Eq], slot: dict[int, int], ranges: Sequence[Range],
               fixes: list[Position], names: list[str], lever_z: float) -> Fix | None:
    """The fix at the solution ``p``: the position's 1-σ from the normal equations, the
    residual test over the position equations only (a heading's readings spread over a
    window as the vehicle turns: the static model's error, not a bad range)."""
    normal, _ = _joint_normal(p, eqs, slot)
    cov = _inverse_small(normal) if len(normal) <= 3 else _inverse_gauss_jordan(normal)
    if cov is None:
        return None  # a degenerate net: the position is not determined
    half_sum, half_diff = (cov[0][0] + cov[1][1]) / 2, (cov[0][0] - cov[1][1]) / 2
    sigma = math.sqrt(max(half_sum + math.hypot(half_diff, cov[0][1]), 0.0))
    s, c = math.sin(p[_H]), math.cos(p[_H])
    residuals = [(_equation(p, s, c, eq)[0], eq[2]) for eq in eqs if eq[0] in _POSITION_KINDS]
    return Fix(t=max([r.t for r in ranges] + [f.t for f in fixes]), x=p[_X], y=p[_Y],
               sigma=sigma, rms=math.sqrt(sum(r * r for r, _ in residuals) / len(residuals)),
               n=len(ranges) + len(fixes), beacons=tuple(names), offset=p[_O],
               chi2=sum((w * r) ** 2 for r, w in residuals),
               dof=len(residuals) - (3 if _O in slot else 2), **_pose_fields(p, slot, lever_z))


def _pose_fields(p: list[float], slot: dict[int, int], lever_z: float) -> dict:
    """A fix's heading, Z, depth and tide where the solve observed them, and what it did not."""
    observed = _Z in slot
    return {"yaw": math.remainder(p[_H], 2 * math.pi) if _H in slot else None,
            "z": p[_Z] if observed else None,
            "depth": p[_T] - p[_Z] - lever_z if observed else None,
            "tide": p[_T] if _T in slot else None,
            "unobserved": tuple(name for state, name in enumerate(POSE_STATES[:_O])
                                if state not in slot)}


class LSQ:
    """Accrues ranges and publishes a :class:`Fix` whenever the window holds enough beacons.

    ``add(range)`` returns the new fix or None. Once the window holds ranges to
    ``min_beacons`` beacons a solution is tried, and the window starts afresh whether it
    succeeds or not (``failures`` counts the inconsistent windows, ``rejected`` the ranges
    dropped). ``window`` (s): ranges older than this, counted back from the newest, are
    forgotten. ``gate_probability``: the χ² test a solution's residuals must pass; if they
    fail, the worst range is dropped and the fix tried again, at most ``max_drops`` times (more
    bad ranges than that in one window: no fix).
    """

    def __init__(self, beacons: Iterable[Beacon], *, window: float = LSQ_WINDOW.default,
                 min_beacons: int = 3,
                 gate_probability: float = 0.999, max_drops: int = 2,
                 estimate_offset: bool = False) -> None:
        self.beacons = {b.name: b for b in beacons}
        if window <= 0:
            raise ValueError(f"LSQ window must be > 0 s, got {window}")
        self.window = window
        # beacons a fix needs at the least: a bad range may be dropped down to this many
        self.observable = 4 if estimate_offset else 3
        self.min_beacons = max(min_beacons, self.observable)
        self.gate_probability = gate_probability
        self.max_drops = max_drops
        self.estimate_offset = estimate_offset
        self._ranges: deque[Range] = deque()
        self._poses: deque[Yaw | Depth | Position] = deque()
        self.tide = 0.0
        """The tide (m): FIXEDTIDE's value, else the surface at 0 (held when unobserved)."""
        self.tide_sigma: float | None = None
        """FIXEDTIDE's σ (m): the tide is then an observation of the solve."""
        self.last_fix: Fix | None = None
        self.rejected = 0
        self.failures = 0
        self.last_attempt: float | None = None
        """When the window last held enough beacons to try a fix (observable), fix or not."""
        self._gates: dict[int, float] = {}

    def add_pose(self, obs: Yaw | Depth | Position) -> None:
        """An orientation, depth or XY fix: proportional to the pose, it joins the next fix's
        solve (the LSQ's static model: one pose for the window)."""
        values = (obs.x, obs.y) if isinstance(obs, Position) else (obs.z,)
        if all(math.isfinite(v) for v in values):
            self._poses.append(obs)
            while obs.t - self._poses[0].t > self.window:
                self._poses.popleft()

    def add(self, obs: Range) -> Fix | None:
        if obs.beacon not in self.beacons or not math.isfinite(obs.z):
            return None
        self._ranges.append(obs)
        while self._ranges and obs.t - self._ranges[0].t > self.window:
            self._ranges.popleft()
        if len({r.beacon for r in self._ranges}) < self.min_beacons:
            return None
        ranges = list(self._ranges)
        while self._poses and obs.t - self._poses[0].t > self.window:
            self._poses.popleft()
        poses = [p for p in self._poses if p.t <= obs.t]
        self.last_attempt = obs.t
        last = self.last_fix
        recent = last is not None and obs.t - last.t <= 10 * self.window
        guess = (last.x, last.y) if last is not None and recent else None
        fix = self._solve(ranges, poses, guess)
        drops = 0
        while fix is not None and not self._consistent(fix):
            if drops == self.max_drops:
                fix = None
                break
            fix = self._drop_worst(ranges, poses, fix)
            drops += 1
            self.rejected += 1
        self._ranges.clear()  # fix or no fix, the accumulation begins again
        self._poses = deque(p for p in self._poses if p.t > obs.t)
        if fix is None:
            self.failures += 1
            return None
        self.last_fix = fix
        return fix

    def _drop_worst(self, ranges: list[Range], poses: list[Yaw | Depth | Position],
                    fix: Fix) -> Fix | None:
        """Drop (in place) the range or XY fix whose absence leaves the most consistent
        solve, and return that solve (None: nothing can be dropped)."""
        trials = []
        for k in range(len(ranges)):
            rest = ranges[:k] + ranges[k + 1:]
            if len({r.beacon for r in rest}) >= self.observable:
                trial = self._solve(rest, poses, (fix.x, fix.y))
                if trial is not None:
                    trials.append((self._surprise(trial), k, trial))
        for k, pose in enumerate(poses):
            if isinstance(pose, Position):
                trial = self._solve(ranges, poses[:k] + poses[k + 1:], (fix.x, fix.y))
                if trial is not None:
                    trials.append((self._surprise(trial), len(ranges) + k, trial))
        if not trials:
            return None
        _, k, best = min(trials, key=lambda item: item[:2])
        if k < len(ranges):
            ranges.pop(k)
        else:
            poses.pop(k - len(ranges))
        return best

    def _solve(self, ranges: list[Range], poses: list[Yaw | Depth | Position],
               guess: tuple[float, float] | None) -> Fix | None:
        return solve_joint(ranges, poses, self.beacons, guess=guess,
                           estimate_offset=self.estimate_offset, tide=self.tide,
                           tide_sigma=self.tide_sigma)

    @staticmethod
    def _surprise(fix: Fix) -> float:
        """How surprising the fix's residuals are: −log of the χ² tail probability (which,
        unlike the CDF, does not saturate for grossly bad fits)."""
        return -chi2_logsf(fix.chi2, fix.dof) if fix.dof > 0 else 0.0

    def _consistent(self, fix: Fix) -> bool:
        if fix.dof == 0:
            return True
        gate = self._gates.get(fix.dof)
        if gate is None:
            gate = self._gates[fix.dof] = float(chi2_ppf(self.gate_probability, fix.dof))
        return fix.chi2 <= gate
