"""Run pNav offline over recorded bus variables and score it against truth (spec 2.2.5).

:func:`replay` drives the very navigator app the companion runs — same sensor lines, same
filters, same priority queues — on a simulated clock over a recorded log (an ``.alog`` read
back, or a MAVLink ``.tlog`` turned into the variables the bridge would have posted). The
clock ticks at the companion's period, and a tick with no data is skipped: the filter's
prediction over two periods is the same as over one and then another, so only the outputs of
empty ticks are lost, and a log replays many times faster than it was recorded.

:func:`accuracy` compares a track with the truth (``TRUTH_X``/``TRUTH_Y`` in the log: a
simulator's ground truth, or a data set's), the truth interpolated at the track's times.
Pure: no files and no wall clock (the caller times it).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Final

import numpy as np

from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock
from mavhelm.core.mission import Block
from mavhelm.nav.chi_square import chi2_ppf
from mavhelm.nav.ekf import EKF, Estimate
from mavhelm.nav.filter_safety import DECISION_KINDS
from mavhelm.nav.heading_watch import MOVING_NOTE, STILL_NOTE
from mavhelm.nav.navigator import Navigator

OWN_OUTPUTS = ("NAV_", "EKF_", "LSQ_")
"""What the navigator posts: in a recorded companion log these are the live run's, and the
replay makes its own (a recorded EKF_X fed back would be scored, and routed, twice)."""
TRUTH_X = "TRUTH_X"
TRUTH_Y = "TRUTH_Y"
SCORED = ("NAV", "EKF", "LSQ", "GPS")
"""Position sources the report scores when the log has them (NAV_* is what the helm used)."""
BEST_SOURCE_FLOOR: Final = 1.2
"""NAV's RMS over the best of its own sources' that the report holds it to: the navigator
should never do worse than a source it already had by more than 20 %."""


@dataclass(frozen=True)
class Accuracy:
    """Horizontal position error against truth: RMS, 95th percentile and maximum (m)."""

    rms: float
    p95: float
    max: float
    n: int

    def __str__(self) -> str:
        return f"RMS {self.rms:.2f} m, p95 {self.p95:.2f} m, max {self.max:.2f} m (n={self.n})"


@dataclass
class Track:
    """One source's positions over time."""

    t: list[float] = field(default_factory=list)
    x: list[float] = field(default_factory=list)
    y: list[float] = field(default_factory=list)


NEES_BAND: Final = (float(chi2_ppf(0.025, 2)), float(chi2_ppf(0.975, 2)))
"""The two-sided 95 % band of a 2-dof χ²: where a position error's NEES falls 95 % of the
time when the filter's covariance tells the truth about it."""


@dataclass(frozen=True)
class Consistency:
    """How honest the EKF's position covariance is against the truth: the mean NEES (2 when
    honest), the share of ticks whose NEES is inside :data:`NEES_BAND` (0.95 when honest),
    the share above it (over-confident) and the number of ticks."""

    mean: float
    inside: float
    above: float
    n: int

    def __str__(self) -> str:
        low, high = NEES_BAND
        return (f"mean {self.mean:.2f} (2 when honest), {100 * self.inside:.0f} % of ticks "
                f"inside the 95 % band [{low:.2f}, {high:.2f}], {100 * self.above:.0f} % "
                f"above (n={self.n})")


@dataclass
class CovarianceTrack:
    """The EKF's position and its 2×2 covariance at the filter's own times."""

    t: list[float] = field(default_factory=list)
    x: list[float] = field(default_factory=list)
    y: list[float] = field(default_factory=list)
    pxx: list[float] = field(default_factory=list)
    pxy: list[float] = field(default_factory=list)
    pyy: list[float] = field(default_factory=list)

    def take(self, ekf: EKF) -> None:
        if self.t and ekf.t <= self.t[-1]:
            return
        (pxx, pxy), (_pyx, pyy) = ekf.position_covariance_floats()
        x, y = ekf.x.item(0), ekf.x.item(1)
        self.t.append(ekf.t)
        self.x.append(x)
        self.y.append(y)
        self.pxx.append(pxx)
        self.pxy.append(pxy)
        self.pyy.append(pyy)


@dataclass
class ReplayResult:
    """What the navigator did over the log."""

    tracks: dict[str, Track]
    truth: Track
    navigator: Navigator
    ticks: int
    span: float
    warnings: list[str]
    failure: str | None
    covariance: CovarianceTrack = field(default_factory=CovarianceTrack)
    start: float = 0.0

    def consistency(self) -> Consistency:
        """The EKF position's NEES against the truth."""
        c, tr = self.covariance, self.truth
        return nees(c.t, c.x, c.y, c.pxx, c.pxy, c.pyy, tr.t, tr.x, tr.y)

    @property
    def final(self) -> Estimate | None:
        fusion = self.navigator.fusion
        return fusion.ekf.estimate() if fusion is not None and fusion.ekf is not None else None

    def accuracy(self, source: str = "NAV") -> Accuracy:
        track = self.tracks.get(source, Track())
        return accuracy(track.t, track.x, track.y, self.truth.t, self.truth.x, self.truth.y)

    def _against_sources(self) -> list[str]:
        """NAV's RMS against the best of its own sources' (issue floor: at most 1.2×)."""
        scores = {s: self.accuracy(s).rms for s in SCORED
                  if self.tracks.get(s) and self.tracks[s].t}
        nav = scores.pop("NAV", math.nan)
        scores = {s: v for s, v in scores.items() if math.isfinite(v)}
        if not scores or not math.isfinite(nav):
            return []
        best = min(scores, key=scores.__getitem__)
        ratio = nav / scores[best] if scores[best] > 0 else math.inf
        return [f"NAV against its best source ({best}, RMS {scores[best]:.2f} m): "
                f"{ratio:.2f}x (floor {BEST_SOURCE_FLOOR:g}x)"]

    def report(self) -> list[str]:
        """One line per scored source, plus the filter's own account."""
        lines = [f"replayed {self.span:.0f} s of log in {self.ticks} ticks"]
        if self.truth.t:
            for source in SCORED:
                if self.tracks.get(source) and self.tracks[source].t:
                    lines.append(f"{source:<4} position: {self.accuracy(source)}")
            lines += self._against_sources()
        else:
            lines.append("no truth in the log (TRUTH_X, TRUTH_Y): nothing to score")
        fusion = self.navigator.fusion
        if fusion is not None:
            if self.truth.t and self.covariance.t:
                lines.append(f"NEES (EKF position, 2 dof): {self.consistency()}")
            counts = ", ".join(f"{k} {v}" for k, v in fusion.counts.items() if v)
            lines.append(f"observations: {counts}; LSQ fixes {fusion.fixes}, "
                         f"re-initialisations {fusion.reinitialisations}")
            nis = [f"{name} {s.total / s.dof:.2f} ({_share(s.inside, s.n - s.rejected)} "
                   f"inside, {_share(s.below, s.n - s.rejected)} below, "
                   f"{_share(s.above, s.n - s.rejected)} above; {s.rejected} of {s.n} rejected)"
                   for name, s in fusion.nis.items() if s.dof]
            if nis:
                lines.append("NIS per dof by sensor (1 when its noise is told right; accepted "
                             "readings inside the 95 % χ² band, below and above it): "
                             + ", ".join(nis))
            made = [d.kind for d in fusion.decisions]
            lines.append("decisions: " + ", ".join(f"{kind} {made.count(kind)}"
                                                   for kind in DECISION_KINDS))
            first, later = fusion.decisions[:10], fusion.decisions[10:]
            # the vehicle's stops and starts crowd out the rarer decisions after the first ten
            shown = first + [d for d in later if not d.why.startswith((MOVING_NOTE,
                                                                       STILL_NOTE))][:10]
            lines += [f"  {d.t - self.start:8.1f} s  {d}" for d in shown]
            if len(fusion.decisions) > len(shown):
                lines.append(f"  … {len(fusion.decisions) - len(shown)} more in the .olog")
            if self.final is not None and fusion.ekf is not None:
                learned = _learned(self.final, fusion.ekf)
                lines.append("learned: " + (", ".join(learned) if learned
                                            else "nothing (the filter has no hidden states)"))
        if self.failure:
            lines.append(f"NAVIGATION FAILURE: {self.failure}")
        return lines


def _share(part: int, whole: int) -> str:
    return f"{100 * part / whole:.0f} %" if whole else "-"


def _learned(final: Estimate, ekf: EKF) -> list[str]:
    """The hidden states the filter ended with, those it has, as the report prints them."""
    learned = []
    if ekf.i_bias is not None:
        learned.append(f"heading bias {math.degrees(final.yaw_bias):+.2f} deg")
    if ekf.i_drift is not None:
        learned.append(f"drifting {60 * math.degrees(final.yaw_drift):+.2f} deg/min")
    if ekf.i_yaw_scale is not None:
        learned.append(f"yaw rate scale {final.yaw_scale:+.4f}")
    if ekf.i_speed is not None:
        learned.append(f"speed scale {final.speed_scale:+.4f}")
    if ekf.i_scale is not None:
        learned.append(f"range scale {final.range_scale:+.4f}")
    return learned + [f"offset {k} {v:+.2f} m" for k, v in final.offsets.items()]


def replay(block: Block, messages: Iterable[Message], *, period: float = 0.1,
           log: object | None = None) -> ReplayResult:
    """Run the navigator of a ``pNav`` block over ``messages`` (any order; sorted by time)."""
    ordered = sorted((m for m in messages if not m.name.startswith(OWN_OUTPUTS)),
                     key=lambda m: m.time)
    truth = _truth(ordered)
    start = ordered[0].time if ordered else 0.0
    clock = SimClock(start)
    bus = Bus(clock)
    nav = Navigator.from_block(bus, block, log)  # type: ignore[arg-type]
    bus.subscribe(nav.name, nav.subscriptions())
    wanted = {f"{s}_{k}" for s in SCORED for k in ("X", "Y")}
    bus.subscribe("replay", wanted | {"NAV_WARNING"})
    recorder = _Recorder()
    covariance = CovarianceTrack()
    subscribed = nav.subscriptions() | wanted
    ticks = 0
    i = 0
    now = start
    while i < len(ordered):
        # the first tick boundary at or after the next message: data are read in ticks
        k = math.ceil((ordered[i].time - start) / period - 1e-9)
        now = max(now, start + k * period)
        clock.set(now)
        while i < len(ordered) and ordered[i].time <= now + 1e-9:
            m = ordered[i]
            if m.name in subscribed:
                bus.notify(m.name, m.value, m.source or "log", m.time)
            i += 1
        nav.on_mail(bus.fetch(nav.name), now)
        nav.iterate(now)
        nav.write_logs()
        if nav.fusion is not None and nav.fusion.ekf is not None:
            covariance.take(nav.fusion.ekf)
        ticks += 1
        recorder.take(bus.fetch("replay"))
        now += period
    fusion = nav.fusion
    span = (ordered[-1].time - start) if ordered else 0.0
    return ReplayResult(recorder.tracks, truth, nav, ticks, span, recorder.warnings,
                        fusion.failure if fusion is not None else None, covariance, start)


@dataclass
class _Recorder:
    """The scored sources' positions (X and Y paired by time stamp) and the warnings."""

    tracks: dict[str, Track] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)
    pending: dict[tuple[str, float], float] = field(default_factory=dict)
    names: dict[str, tuple[str, str, str]] = field(default_factory=dict)
    """Per variable: its source, its axis and its partner's name (``EKF_X``: EKF, X,
    EKF_Y), split once."""

    def take(self, mail: list[Message]) -> None:
        for m in mail:
            if m.name == "NAV_WARNING":
                self.warnings.append(m.string)
                continue
            split = self.names.get(m.name)
            if split is None:
                source, _, axis = m.name.rpartition("_")
                split = self.names[m.name] = (source, axis,
                                              f"{source}_{'Y' if axis == 'X' else 'X'}")
            source, axis, other = split
            partner = self.pending.pop((other, m.time), None)
            if partner is None:
                self.pending[(m.name, m.time)] = m.double
                continue
            x, y = (m.double, partner) if axis == "X" else (partner, m.double)
            track = self.tracks.setdefault(source, Track())
            track.t.append(m.time)
            track.x.append(x)
            track.y.append(y)


def _truth(ordered: list[Message]) -> Track:
    """TRUTH_X/TRUTH_Y as one track: in order when they alternate, else paired by time."""
    truth = Track()
    for m in ordered:
        if m.name in (TRUTH_X, TRUTH_Y) and m.is_double:
            if m.name == TRUTH_X:
                truth.t.append(m.time)
                truth.x.append(m.double)
            else:
                truth.y.append(m.double)
    return truth if len(truth.x) == len(truth.y) else _paired_truth(ordered)


def _paired_truth(messages: list[Message]) -> Track:
    xs = {m.time: m.double for m in messages if m.name == TRUTH_X and m.is_double}
    ys = {m.time: m.double for m in messages if m.name == TRUTH_Y and m.is_double}
    track = Track()
    for t in sorted(set(xs) & set(ys)):
        track.t.append(t)
        track.x.append(xs[t])
        track.y.append(ys[t])
    return track


def accuracy(t: Iterable[float], x: Iterable[float], y: Iterable[float],
             truth_t: Iterable[float], truth_x: Iterable[float],
             truth_y: Iterable[float]) -> Accuracy:
    """Position error of the estimates (t, x, y) against the truth interpolated at their
    times; estimates outside the truth's time span are not scored."""
    t, x, y = (np.asarray(list(a), dtype=float) for a in (t, x, y))
    tt, tx, ty = (np.asarray(list(a), dtype=float) for a in (truth_t, truth_x, truth_y))
    order = np.argsort(tt, kind="stable")
    tt, tx, ty = tt[order], tx[order], ty[order]
    inside = (t >= tt[0]) & (t <= tt[-1]) if len(tt) else np.zeros(len(t), dtype=bool)
    if not inside.any():
        return Accuracy(math.nan, math.nan, math.nan, 0)
    err = np.hypot(x[inside] - np.interp(t[inside], tt, tx),
                   y[inside] - np.interp(t[inside], tt, ty))
    return Accuracy(float(np.sqrt(np.mean(err**2))), float(np.percentile(err, 95)),
                    float(err.max()), int(err.size))


def nees(t: Iterable[float], x: Iterable[float], y: Iterable[float], pxx: Iterable[float],
         pxy: Iterable[float], pyy: Iterable[float], truth_t: Iterable[float],
         truth_x: Iterable[float], truth_y: Iterable[float]) -> Consistency:
    """The normalised estimation error squared of positions with covariances against the
    truth interpolated at their times (outside the truth's span: not scored)."""
    t, x, y, a, b, d = (np.asarray(list(v), dtype=float) for v in (t, x, y, pxx, pxy, pyy))
    tt, tx, ty = (np.asarray(list(v), dtype=float) for v in (truth_t, truth_x, truth_y))
    order = np.argsort(tt, kind="stable")
    tt, tx, ty = tt[order], tx[order], ty[order]
    inside = (t >= tt[0]) & (t <= tt[-1]) if len(tt) else np.zeros(len(t), dtype=bool)
    det = a * d - b * b
    inside &= det > 0
    if not inside.any():
        return Consistency(math.nan, math.nan, math.nan, 0)
    ex = x[inside] - np.interp(t[inside], tt, tx)
    ey = y[inside] - np.interp(t[inside], tt, ty)
    a, b, d, det = a[inside], b[inside], d[inside], det[inside]
    value = (d * ex * ex - 2 * b * ex * ey + a * ey * ey) / det
    low, high = NEES_BAND
    return Consistency(float(value.mean()), float(((value >= low) & (value <= high)).mean()),
                       float((value > high).mean()), int(value.size))
