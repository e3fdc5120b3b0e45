"""Benchmark: pNav's LSQ fix (hand-written Gauss–Newton, ``mavhelm.nav.lsq.solve``) against
``scipy.optimize.least_squares`` on the same problems.

Both are given the same ranges and the same starts (the beacons' centroid, then six points
around the net until a fit within 3 σ a range is found), both with and without the common
range offset. Prints µs per fix for each and the largest position difference between them,
then the LSQ's joint solve (``solve_joint``, what the navigator runs) on the same ranges, alone
and with a window's headings and depths (10 and 5 readings) beside them.
Asserts nothing (a shared machine's speed is not a test result).
Run: ``.venv/bin/python benchmarks/bench_lsq.py``.
"""

from __future__ import annotations

import math
import time

import numpy as np
from scipy.optimize import least_squares

from mavhelm.nav.ekf import Beacon, Depth, Range, Yaw
from mavhelm.nav.lsq import solve, solve_joint

PROBLEMS = 400


def problems(seed: int = 1) -> list[tuple[list[Range], dict[str, Beacon]]]:
    """Plaza-like: 3 to 6 beacons 20–120 m out, slant ranges with 0.3 m noise and an offset."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(PROBLEMS):
        n = int(rng.integers(4, 7))
        beacons = {str(k): Beacon(str(k), *rng.uniform(-120, 120, 2), float(rng.uniform(-5, 0)))
                   for k in range(n)}
        px, py = rng.uniform(-60, 60, 2)
        offset = 1.5
        ranges = [Range(0.1 * k, b.name,
                        math.dist((px, py, 0.0), (b.x, b.y, b.z)) + offset
                        + float(rng.normal(0, 0.3)), 0.3)
                  for k, b in enumerate(beacons.values())]
        out.append((ranges, beacons))
    return out


def scipy_solve(ranges: list[Range], beacons: dict[str, Beacon], estimate_offset: bool
                ) -> tuple[float, float] | None:
    """The same fix with scipy's trust-region least squares (analytic Jacobian)."""
    b = np.array([[beacons[r.beacon].x, beacons[r.beacon].y, beacons[r.beacon].z]
                  for r in ranges])
    z = np.array([r.z - beacons[r.beacon].offset for r in ranges])
    w = np.array([1.0 / r.sigma for r in ranges])
    k = 3 if estimate_offset else 2

    def residual(p: np.ndarray) -> np.ndarray:
        d = np.sqrt((p[0] - b[:, 0]) ** 2 + (p[1] - b[:, 1]) ** 2 + b[:, 2] ** 2)
        return w * (z - d - (p[2] if k == 3 else 0.0))

    def jacobian(p: np.ndarray) -> np.ndarray:
        d = np.maximum(np.sqrt((p[0] - b[:, 0]) ** 2 + (p[1] - b[:, 1]) ** 2 + b[:, 2] ** 2),
                       1e-6)
        cols = [-(p[0] - b[:, 0]) / d, -(p[1] - b[:, 1]) / d]
        if k == 3:
            cols.append(-np.ones(len(d)))
        return w[:, None] * np.column_stack(cols)

    cx, cy = b[:, 0].mean(), b[:, 1].mean()
    spread = max(float(np.hypot(b[:, 0] - cx, b[:, 1] - cy).max()), 1.0)
    starts = [(cx, cy)] + [(cx + spread * math.cos(a), cy + spread * math.sin(a))
                           for a in (2 * math.pi * j / 6 for j in range(6))]
    best = None
    for sx, sy in starts:
        p0 = np.array([sx, sy, 0.0][:k])
        fit = least_squares(residual, p0, jac=jacobian, method="lm")
        cost = 2.0 * fit.cost
        same = best is not None and math.hypot(fit.x[0] - best[1][0], fit.x[1] - best[1][1]) < 0.1
        if best is None or cost < best[0]:
            best = (cost, fit.x)
        if best[0] <= 9.0 * len(ranges) or same:
            break  # the same stopping rule as solve's
    return None if best is None else (float(best[1][0]), float(best[1][1]))


def main() -> None:
    cases = problems()
    for offset in (False, True):
        t0 = time.perf_counter()
        ours = [solve(r, b, estimate_offset=offset) for r, b in cases]
        t_ours = (time.perf_counter() - t0) / len(cases)
        t0 = time.perf_counter()
        theirs = [scipy_solve(r, b, offset) for r, b in cases]
        t_scipy = (time.perf_counter() - t0) / len(cases)
        diffs = [math.hypot(a.x - c[0], a.y - c[1]) for a, c in zip(ours, theirs, strict=True)
                 if a is not None and c is not None]
        label = "with offset" if offset else "x, y only  "
        print(f"LSQ {label}: Gauss-Newton {t_ours * 1e6:7.1f} us/fix, "
              f"scipy least_squares {t_scipy * 1e6:7.1f} us/fix "
              f"({t_scipy / t_ours:.1f}x); position difference median {np.median(diffs):.1e} m, "
              f"max {max(diffs):.1e} m, {sum(d > 0.01 for d in diffs)} of {len(diffs)} "
              "fixes > 1 cm apart")

    poses: list[Yaw | Depth] = [Yaw(0.1 * k, 0.3 + 0.001 * k, 0.02) for k in range(10)]
    poses += [Depth(0.2 * k, 3.0 + 0.01 * k, 0.05) for k in range(5)]
    for offset in (False, True):
        timings = []
        for window in ([], poses):
            t0 = time.perf_counter()
            joint = [solve_joint(r, window, b, estimate_offset=offset) for r, b in cases]
            timings.append((time.perf_counter() - t0) / len(cases))
        alone = [solve(r, b, estimate_offset=offset) for r, b in cases]
        apart = max(math.hypot(a.x - j.x, a.y - j.y) for a, j in zip(alone, joint, strict=True)
                    if a is not None and j is not None)
        label = "with offset" if offset else "x, y only  "
        print(f"joint LSQ {label}: ranges alone {timings[0] * 1e6:7.1f} us/fix, with 10 "
              f"headings and 5 depths {timings[1] * 1e6:7.1f} us/fix; position against "
              f"solve's at most {apart:.1e} m apart")


if __name__ == "__main__":
    main()
