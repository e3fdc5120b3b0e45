"""The PID's derivative ignores samples stamped (nearly) at the same instant
(mavhelm.tasks.pid.MIN_DT): two headings microseconds apart are not a turn rate."""

from __future__ import annotations

import pytest

from mavhelm.tasks.pid import MIN_DT, ScalarPID


def test_a_near_simultaneous_sample_moves_the_p_term_only() -> None:
    pid = ScalarPID(0.75, 0.2, 0.0, 2.0, 20.0, angular=True)
    for k in range(5):
        pid.run(1.0, 10.0 + 0.1 * k)
    assert pid.d == pytest.approx(0.0)
    # a second heading of the same instant, 10 µs later, 0.5° different
    out = pid.run(0.5, 10.4 + 1e-5)
    assert pid.d == pytest.approx(0.0) and out == pytest.approx(0.75 * 0.5)
    # a sample 2 MIN_DT later is differentiated over the time since the last one taken
    pid.run(0.5, 10.4 + 2 * MIN_DT)
    assert pid.d == pytest.approx(0.2 * (-0.5 / (2 * MIN_DT)) / 5)
