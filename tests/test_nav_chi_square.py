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
