"""Run the EKF (booted and watched by the LSQ) over recorded observations; score it against truth.

:func:`replay` is what the navigator does each tick, done offline: observations are taken in
time order; those sharing a time stamp form one slice, tested and applied together; before each
slice the filter predicts to its time. Ranges also feed the LSQ, which boots the EKF when no
start is given and re-initialises it after a sustained disagreement (spec 2.2.9). A navigation
failure stops the run, as it takes the filters off-line on the vehicle.

:func:`accuracy` compares an estimate track with a truth track, the truth interpolated in time.
:func:`observations_from_messages` turns logged variables (an ``.alog`` read back) into
observations. Pure functions: no files, no clock.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from mavhelm.core.bus import Message
from mavhelm.core.geodesy import heading_to_yaw
from mavhelm.nav.ekf import (
    EKF,
    RANGE_SIGMA,
    YAW_SIGMA,
    Beacon,
    EKFConfig,
    Estimate,
    NavigationFailure,
    Observation,
    Position,
    Range,
    Yaw,
    odometry,
)
from mavhelm.nav.lsq import LSQ, DivergenceMonitor, Fix

BOOT_FIXES = 3
"""LSQ fixes in a row, each within ``BOOT_AGREEMENT`` of the one before, that boot the EKF
(spec 2.2.9: "once a stable/repeatable stream of solutions begins to flow")."""
BOOT_AGREEMENT = 10.0
"""m: how close consecutive boot fixes must be (a boat moves a few metres between fixes)."""
BOOT_SIGMA = 5.0
"""m: the least 1-σ given to an LSQ fix that boots or resets the EKF. A fix's formal σ only
counts the ranges' noise; their unknown offsets and scale (the EKF's hidden states, not yet
learned at boot) move it by metres (Plaza: 4.5 m, from ranges 7 % long)."""


@dataclass(frozen=True)
class Start:
    """A start pose known roughly: position (m) and yaw (rad) with their 1-σ."""

    x: float
    y: float
    yaw: float = 0.0
    sigma_xy: float = 5.0
    sigma_yaw: float | None = None


@dataclass
class Track:
    """The estimate after each slice, as arrays, and what happened on the way."""

    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    yaw: np.ndarray
    sigma_x: np.ndarray
    sigma_y: np.ndarray
    final: Estimate | None
    accepted: int = 0
    rejected: int = 0
    boot_fix: Fix | None = None
    fixes: list[Fix] = field(default_factory=list)
    reinitialisations: int = 0
    rate_resets: int = 0
    warnings: list[str] = field(default_factory=list)
    failure: str | None = None


@dataclass(frozen=True)
class Accuracy:
    """Horizontal position error against truth: RMS, 95th percentile and maximum (m)."""

    rms: float
    p95: float
    max: float
    n: int

    def __str__(self) -> str:
        return f"RMS {self.rms:.2f} m, p95 {self.p95:.2f} m, max {self.max:.2f} m (n={self.n})"


def observations_from_messages(
    messages: Iterable[Message], *, range_prefix: str | None = "RANGE_",
    odometry_vars: tuple[str, str] | None = ("ODOM_DIST", "ODOM_DYAW"),
    heading_var: str | None = "ODOM_HEADING", yaw_var: str | None = None,
    position_vars: tuple[str, str] | None = None, range_sigma: float = RANGE_SIGMA,
    yaw_sigma: float = YAW_SIGMA,
) -> list[Observation]:
    """Observations from bus messages, time-ordered:

    - ``<range_prefix><beacon>``: a :class:`Range` to that beacon (m);
    - ``odometry_vars`` (distance m, yaw change rad) posted at the same time: one
      :func:`odometry` body velocity over the interval since the previous pair (the first pair
      only starts the clock);
    - ``heading_var`` (degrees clockwise from north) or ``yaw_var`` (rad): a :class:`Yaw`;
    - ``position_vars`` (x, y in m, posted at the same time): a :class:`Position`.
    Non-numeric and non-finite values are skipped.
    """
    out: list[Observation] = []
    pending: dict[str, dict[float, float]] = {}
    paired = [v for pair in (odometry_vars, position_vars) if pair for v in pair]
    for msg in messages:
        if not msg.is_double or not math.isfinite(msg.double):
            continue
        name, value, t = msg.name, msg.double, msg.time
        if range_prefix and name.startswith(range_prefix) and len(name) > len(range_prefix):
            out.append(Range(t, name[len(range_prefix):], value, range_sigma))
        elif heading_var is not None and name == heading_var:
            out.append(Yaw(t, heading_to_yaw(value), yaw_sigma))
        elif yaw_var is not None and name == yaw_var:
            out.append(Yaw(t, value, yaw_sigma))
        elif name in paired:
            pending.setdefault(name, {})[t] = value
    if odometry_vars:
        dist, dyaw = (pending.get(v, {}) for v in odometry_vars)
        times = sorted(set(dist) & set(dyaw))
        for before, t in zip(times, times[1:], strict=False):
            out.append(odometry(t, t - before, dist[t], dyaw[t]))
    if position_vars:
        xs, ys = (pending.get(v, {}) for v in position_vars)
        out.extend(Position(t, xs[t], ys[t]) for t in sorted(set(xs) & set(ys)))
    out.sort(key=lambda o: o.t)
    return out


def _slices(observations: list[Observation]) -> Iterable[list[Observation]]:
    batch: list[Observation] = []
    for obs in observations:
        if batch and obs.t != batch[0].t:
            yield batch
            batch = []
        batch.append(obs)
    if batch:
        yield batch


def replay(observations: Iterable[Observation], beacons: Iterable[Beacon], *,
           config: EKFConfig | None = None, start: Start | None = None,
           lsq: LSQ | None = None, monitor: DivergenceMonitor | None = None,
           boot_sigma: float = BOOT_SIGMA) -> Track:
    """Run the EKF over ``observations`` (any order; sorted by time, stably).

    With ``start`` the EKF starts there at the first observation's time; without, it boots at
    the last of ``BOOT_FIXES`` consistent LSQ fixes in a row (yaw from the latest orientation
    reading, if any), with a 1-σ of at least ``boot_sigma``. ``lsq`` defaults to an
    :class:`LSQ` over the beacons and ``monitor`` to a :class:`DivergenceMonitor`.
    """
    beacons = list(beacons)
    config = config or EKFConfig()
    obs_list = sorted(observations, key=lambda o: o.t)
    lsq = lsq if lsq is not None else LSQ(beacons)
    monitor = monitor if monitor is not None else DivergenceMonitor()
    rows: list[tuple[float, ...]] = []
    track_fixes: list[Fix] = []
    ekf: EKF | None = None
    boot_fix: Fix | None = None
    stream: list[Fix] = []
    last_yaw: float | None = None
    accepted = rejected = reinitialisations = 0
    warnings: list[str] = []
    failure: str | None = None

    if start is not None and obs_list:
        ekf = EKF(obs_list[0].t, start.x, start.y, start.yaw, beacons=beacons, config=config,
                  sigma_xy=start.sigma_xy, sigma_yaw=start.sigma_yaw)

    try:
        for batch in _slices(obs_list):
            t = batch[0].t
            fixes = [f for f in (lsq.add(o) for o in batch if isinstance(o, Range)) if f]
            track_fixes.extend(fixes)
            for o in batch:
                if isinstance(o, Yaw):
                    last_yaw = o.z
            if ekf is None:
                for fix in fixes:
                    if stream and math.hypot(fix.x - stream[-1].x,
                                             fix.y - stream[-1].y) > BOOT_AGREEMENT:
                        stream.clear()
                    stream.append(fix)
                if len(stream) < BOOT_FIXES:
                    continue
                boot_fix = stream[-1]
                beacons_now = beacons
                if lsq.estimate_offset:
                    beacons_now = [Beacon(b.name, b.x, b.y, b.z, b.offset + boot_fix.offset)
                                   for b in beacons]
                ekf = EKF(t, boot_fix.x, boot_fix.y, last_yaw if last_yaw is not None else 0.0,
                          beacons=beacons_now, config=config,
                          sigma_xy=max(boot_fix.sigma, boot_fix.rms, boot_sigma))
            ekf.advance(t)
            for fix in fixes:
                if monitor.check(fix, ekf.x[0, 0], ekf.x[1, 0]):
                    ekf.reinitialise(fix.x, fix.y, max(fix.sigma, fix.rms, boot_sigma),
                                     yaw=last_yaw)
                    reinitialisations += 1
            result = ekf.update(batch)
            accepted += len(result.accepted)
            rejected += len(result.rejected)
            e = ekf.estimate()
            rows.append((e.t, e.x, e.y, e.yaw, e.sigma_x, e.sigma_y))
    except NavigationFailure as exc:
        failure = str(exc)
    if ekf is not None:
        warnings.extend(ekf.warnings)
    arr = np.array(rows, dtype=float).reshape(-1, 6)
    return Track(
        t=arr[:, 0], x=arr[:, 1], y=arr[:, 2], yaw=arr[:, 3], sigma_x=arr[:, 4],
        sigma_y=arr[:, 5], final=ekf.estimate() if ekf is not None else None,
        accepted=accepted, rejected=rejected, boot_fix=boot_fix, fixes=track_fixes,
        reinitialisations=reinitialisations,
        rate_resets=ekf.rate_resets if ekf is not None else 0, warnings=warnings,
        failure=failure,
    )


def accuracy(t: np.ndarray, x: np.ndarray, y: np.ndarray, truth_t: np.ndarray,
             truth_x: np.ndarray, truth_y: np.ndarray) -> Accuracy:
    """Position error of the estimates (t, x, y) against the truth interpolated at their
    times; estimates outside the truth's time span are not scored."""
    t, x, y = (np.asarray(a, dtype=float) for a in (t, x, y))
    order = np.argsort(truth_t, kind="stable")
    tt = np.asarray(truth_t, dtype=float)[order]
    tx = np.asarray(truth_x, dtype=float)[order]
    ty = np.asarray(truth_y, dtype=float)[order]
    inside = (t >= tt[0]) & (t <= tt[-1]) if len(tt) else np.zeros(len(t), dtype=bool)
    if not inside.any():
        return Accuracy(math.nan, math.nan, math.nan, 0)
    err = np.hypot(x[inside] - np.interp(t[inside], tt, tx),
                   y[inside] - np.interp(t[inside], tt, ty))
    return Accuracy(float(np.sqrt(np.mean(err**2))), float(np.percentile(err, 95)),
                    float(err.max()), int(err.size))


def track_accuracy(track: Track, truth_t: np.ndarray, truth_x: np.ndarray,
                   truth_y: np.ndarray) -> Accuracy:
    """:func:`accuracy` of a replayed track."""
    return accuracy(track.t, track.x, track.y, truth_t, truth_x, truth_y)
