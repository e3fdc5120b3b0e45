"""The χ² tail the outlier searches rank by is scipy.stats' own, to the bit."""

import math

import numpy as np
from scipy.stats import chi2

from mavhelm.nav.chi_square import chi2_logsf


def test_the_tail_is_scipys_to_the_bit() -> None:
    rng = np.random.default_rng(0)
    for dof in [*range(1, 13), 20, 0.5]:
        xs = [*rng.exponential(3.0 * dof, 300).tolist(), *rng.uniform(0, 3000, 50).tolist(),
              0.0, -1.0, 1e-300, float(chi2.ppf(0.5, dof)), 1e6, math.inf]
        for x in xs:
            assert chi2_logsf(x, dof) == float(chi2.logsf(x, dof)), (x, dof)
    assert math.isnan(chi2_logsf(math.nan, 2))


def test_the_quantile_is_scipys_to_the_bit() -> None:
    import pytest

    from mavhelm.nav.chi_square import chi2_ppf

    for dof in [*range(1, 13), 20, 0.5]:
        for p in (0.025, 0.5, 0.9, 0.975, 0.99, 0.999, 0.999999, 1e-9):
            assert chi2_ppf(p, dof) == float(chi2.ppf(p, dof)), (p, dof)
    for p, dof in ((0.0, 2), (1.0, 2), (math.nan, 2), (0.5, 0)):
        with pytest.raises(ValueError):
            chi2_ppf(p, dof)


def test_the_navigator_starts_without_scipy_stats_or_filterpy() -> None:
    """Every command imports the navigator's modules (the CLI's parser does); scipy.stats and
    filterpy cost about a second of start-up and are loaded only when a filter is built."""
    import subprocess
    import sys

    probe = ("import sys, mavhelm.cli, mavhelm.nav.replay; mavhelm.cli.build_parser(); "
             "print(sorted(m for m in ('scipy.stats', 'filterpy') if m in sys.modules))")
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          check=True)
    assert done.stdout.strip() == "[]", done.stdout + done.stderr
