"""Filter safety (spec 2.2.9, 2.2.11): the LSQ watching the EKF, and what the navigator decides.

The original navigator (MOOS's ``CMOOSNavigator::MonitorFilters`` and its ``CFilterSafety``)
keeps four settings, here under their original names:

- ``MaxLSQEKFDeviation`` (20 m): an LSQ fix further than this from the EKF is a disagreement;
  after ``DISAGREEMENTS`` in a row (both filters having moved on between them: one per LSQ
  fix) the EKF is taken off-line and re-initialised to the LSQ. A lone outlying fix never
  pulls the plug; agreement resets the count.
- ``LSQTimeOut`` (30 s): no LSQ fix for this long, counted from the start if none has come,
  is a navigation failure (the problem is, or has become, unobservable).
- ``MaxEKFPositionUncertainty`` (m): an EKF whose position 1-σ grows beyond this is lost.
  With the LSQ running it is taken off-line and boots again from the LSQ's next repeatable
  fixes (the original resets it and lets the LSQ boot it); without an LSQ nothing can
  re-initialise it, and it is a navigation failure (spec 2.2.11).
- ``MaxMedianLSQShift`` (20 m): the median jump between the last ``LSQ_SAMPLE_SIZE`` (8)
  consecutive LSQ fixes beyond this means the LSQ is "all over the shop". The original
  declares a navigation failure; here that happens only while the EKF is off-line (nothing
  else to navigate on). With the EKF running, the LSQ is no longer trusted to watch it — its
  disagreements are not counted and it re-initialises nothing — until its median shift is
  back under the limit: measured on Plaza1 with one beacon 5 m from its surveyed place, or
  5 % of the ranges wrong by 5–50 m, the LSQ jumps about while the EKF holds 0.5–1.3 m, and
  the original's rule ended a mission the EKF was navigating well.

Every decision is a :class:`Decision` (time, kind, why), which the owner logs and publishes:
``NAV_STATUS`` and ``NAV_WARNING`` on the bus (the console's line), a ``#`` line in the .olog
and the .xlog, and the replay's report. Pure logic: no bus, no clock.
"""

from __future__ import annotations

import math
import statistics
from collections import deque
from dataclasses import dataclass
from typing import Final

from mavhelm.nav.lsq import Fix

DISAGREEMENTS: Final = 6
"""LSQ fixes in a row that disagree with the EKF before it is re-initialised (the
original's ``DEFAULT_MAX_EKFLSQ_DISAGREEMENTS``)."""
LSQ_SAMPLE_SIZE: Final = 8
"""How many consecutive LSQ shifts the median is taken over (the original's sample size)."""

BOOTED: Final = "booted"
REINITIALISED: Final = "reinitialised"
LOST: Final = "lost"
FAILED: Final = "failed"
RESTARTED: Final = "restarted"
HEADING: Final = "heading"
LSQ_TRUST: Final = "lsq"
BEACON: Final = "beacon"
FIX: Final = "fix"
DECISION_KINDS: Final = (BOOTED, REINITIALISED, LOST, FAILED, RESTARTED, HEADING, LSQ_TRUST,
                         BEACON, FIX)
"""What the navigator decides: the EKF booted, re-initialised to the LSQ, lost (off-line,
waiting for the LSQ), the navigation failed, the EKF restarted after a numerical fault, what
it concluded about a heading sensor, whether the LSQ is trusted to watch the EKF, which
beacons are off their survey, and when a position sensor's refused fixes showed the filter
off."""


@dataclass(frozen=True)
class Decision:
    """One decision of the navigator at time ``t`` (s): its ``kind`` and why."""

    t: float
    kind: str
    why: str

    def __str__(self) -> str:
        return f"{self.kind}: {self.why}"


class DivergenceMonitor:
    """Spec 2.2.9: ``check(fix, ekf_x, ekf_y)`` is True when the EKF should be re-initialised
    to the LSQ fix, i.e. after ``count`` fixes in a row further than ``distance``
    from it. ``last`` is the latest separation (m)."""

    def __init__(self, distance: float = 20.0, count: int = DISAGREEMENTS) -> None:
        self.distance = distance
        self.count = count
        self.disagreements = 0
        self.last = 0.0

    def check(self, fix: Fix, ekf_x: float, ekf_y: float) -> bool:
        self.last = math.hypot(fix.x - ekf_x, fix.y - ekf_y)
        if self.last > self.distance:
            self.disagreements += 1
        else:
            self.disagreements = 0
        if self.disagreements >= self.count:
            self.disagreements = 0
            return True
        return False


class LSQShifts:
    """The median jump between consecutive LSQ fixes over the last ``size`` of them."""

    def __init__(self, size: int = LSQ_SAMPLE_SIZE) -> None:
        self.size = size
        self._last: tuple[float, float] | None = None
        self._shifts: deque[float] = deque(maxlen=size)

    def add(self, x: float, y: float) -> None:
        if self._last is not None:
            self._shifts.append(math.hypot(x - self._last[0], y - self._last[1]))
        self._last = (x, y)

    def median(self) -> float:
        """0 until ``size`` shifts are known (the original's rule)."""
        return statistics.median(self._shifts) if len(self._shifts) == self.size else 0.0


class FilterSafety:
    """The navigator's checks of spec 2.2.9/2.2.11 over LSQ fixes and the EKF.

    ``on_fix(fix, ekf_xy)`` for each LSQ fix (``ekf_xy`` None while the EKF is off-line)
    returns a decision or None; ``timed_out(horizon)`` the failure of an LSQ silent too long.
    """

    def __init__(self, max_deviation: float, lsq_timeout: float | None,
                 max_median_shift: float) -> None:
        self.monitor = DivergenceMonitor(max_deviation)
        self.lsq_timeout = lsq_timeout
        self.max_median_shift = max_median_shift
        self.shifts = LSQShifts()
        self.last_fix_time: float | None = None
        self.lsq_trusted = True

    @property
    def disagreeing(self) -> bool:
        """A trusted LSQ's last fix lay beyond ``MaxLSQEKFDeviation`` from the EKF: a
        re-initialisation may be on its way."""
        return self.lsq_trusted and self.monitor.disagreements > 0

    def start(self, t: float) -> None:
        """The LSQ starts listening at ``t`` (its time-out counts from here until a fix)."""
        if self.last_fix_time is None:
            self.last_fix_time = t

    def on_fix(self, fix: Fix, ekf_xy: tuple[float, float] | None) -> Decision | None:
        t, x, y = fix.t, fix.x, fix.y
        self.last_fix_time = t if self.last_fix_time is None else max(self.last_fix_time, t)
        self.shifts.add(x, y)
        median = self.shifts.median()
        noisy = median > self.max_median_shift
        why = (f"the LSQ is all over the shop: median shift {median:.1f} m over "
               f"{self.shifts.size} fixes (MaxMedianLSQShift {self.max_median_shift:g} m)")
        if noisy and ekf_xy is None:
            return Decision(t, FAILED, why)
        if noisy == self.lsq_trusted:
            self.lsq_trusted = not noisy
            self.monitor.disagreements = 0
            return Decision(t, LSQ_TRUST, f"{why}: not trusted to watch the EKF" if noisy else
                            f"the LSQ settles (median shift {median:.1f} m): it watches the "
                            "EKF again")
        if ekf_xy is None or noisy:
            return None
        if self.monitor.check(fix, *ekf_xy):
            return Decision(t, REINITIALISED, f"EKF and LSQ disagreed for "
                            f"{self.monitor.count} fixes in a row, now by "
                            f"{self.monitor.last:.1f} m (MaxLSQEKFDeviation "
                            f"{self.monitor.distance:g} m): EKF re-initialised to the LSQ at "
                            f"({x:.1f}, {y:.1f})")
        return None

    def timed_out(self, horizon: float, observable: int, last_attempt: float | None,
                  ekf_running: bool, window: float | None = None) -> Decision | None:
        """No LSQ fix for ``lsq_timeout`` seconds: a failure (``observable``: the beacons a
        fix needs, ``window`` the LSQ's, for the message: ranges too sparse to reach them in
        one window never make a fix, however well the EKF navigates on them) — unless the
        LSQ did hear enough beacons within that time (``last_attempt``) and only its
        consistency test refused the fixes while the EKF runs: then the problem is
        observable, a beacon or the ranges are wrong, and the EKF (which learns each
        beacon's offset) carries on with the LSQ not trusted."""
        if self.lsq_timeout is None or self.last_fix_time is None:
            return None
        silent = horizon - self.last_fix_time
        if not silent > self.lsq_timeout:
            return None
        heard = last_attempt is not None and horizon - last_attempt <= self.lsq_timeout
        if heard and ekf_running:
            if not self.lsq_trusted:
                return None
            self.lsq_trusted = False
            self.monitor.disagreements = 0
            return Decision(horizon, LSQ_TRUST, f"no consistent LSQ fix for {silent:.0f} s "
                            f"though {observable} beacons are heard: a beacon or its ranges "
                            "are wrong; the LSQ is not trusted to watch the EKF")
        within = "" if window is None else f" within one LSQ_WINDOW ({window:g} s)"
        remedy = "" if window is None else (
            " (ranges sparser than that: a longer LSQ_WINDOW, or LSQTimeOut = NEVER where the "
            "EKF may navigate on them alone)")
        return Decision(horizon, FAILED, f"no LSQ fix for {silent:.0f} s (LSQTimeOut "
                        f"{self.lsq_timeout:g} s): ranges to {observable} beacons{within} are "
                        f"needed; navigation is unobservable{remedy}")
