"""The χ² tail the filters' outlier tests rank by, without scipy.stats' per-call overhead.

``scipy.stats.chi2.logsf`` validates and broadcasts its arguments on every call (~300 µs
here), which the LSQ's and the EKF's drop-the-worst searches pay once per candidate. Its
value is scipy's generic ``_logsf`` of the χ² functions of scipy.special: above the median
``log(chdtrc)``, below it ``log1p(−chdtr)``. This computes the same, with the same functions,
so the same value to the bit (a test compares them). ``chi2_ppf`` is ``chi2.ppf`` the same
way; importing scipy.stats at all costs about a second of every command's start-up.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import chdtr, chdtrc, gammaincinv

_MEDIANS: dict[float, float] = {}


def _median(dof: float) -> float:
    median = _MEDIANS.get(dof)
    if median is None:
        median = _MEDIANS[dof] = float(2 * gammaincinv(dof / 2, 0.5))  # chi2._ppf(0.5)
    return median


def chi2_ppf(p: float, dof: float) -> float:
    """The χ² quantile: ``scipy.stats.chi2.ppf(p, dof)`` for 0 < p < 1 and a positive
    ``dof`` (scipy's ``chi2._ppf``)."""
    if not 0.0 < p < 1.0 or not dof > 0.0:
        raise ValueError(f"chi2_ppf wants 0 < p < 1 and dof > 0, not p={p!r}, dof={dof!r}")
    return float(2 * gammaincinv(dof / 2, p))


def chi2_logsf(x: float, dof: float) -> float:
    """log P(χ²_dof > x): ``scipy.stats.chi2.logsf(x, dof)`` for a positive ``dof``."""
    if math.isnan(x):
        return math.nan
    if x <= 0.0:
        return 0.0  # the support starts at 0: the whole mass lies above
    if x == math.inf:
        return -math.inf
    # a tail below the smallest double is −inf, as scipy's (which silences the warning)
    if x > _median(dof):
        tail = float(chdtrc(dof, x))
        return float(np.log(tail)) if tail > 0.0 else -math.inf
    below = float(chdtr(dof, x))
    return float(np.log1p(-below)) if below < 1.0 else -math.inf
