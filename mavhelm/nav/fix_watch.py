"""Watching a position sensor's refused fixes (spec 2.2.6, 2.2.9): the filter off, not the fix.

The EKF's χ² gate refuses a fix far from where the filter puts the vehicle, which is right
for a GPS glitch and wrong when it is the filter that went astray. A heading turned by a
fault carries the dead reckoning away within seconds, the filter's position σ stays small,
and from then on every fix is refused: the filter keeps the fixes that would correct it out
(the real ArduPilot SITL's boat at 4 m/s, its compass read 176° out: 4 s of refused GPS fixes,
30 m off, until three beacons' ranges had been refused three times each; its gyro's sign
reversed at the first corner: 26 m). The filter safety's LSQ (spec 2.2.9) needs a
disagreement sustained over several of its fixes, which come seconds apart.

What tells the two apart is the fixes themselves. A glitch jumps: its first fix lies tens of
metres from the sensor's fix before, further than the vehicle could have gone. A fix refused
because the filter is off follows on from the one before as the vehicle moves. So
:class:`FixWatch` counts, per sensor, the fixes refused in a row since its last accepted
one, each within the distance the filter's speed covers since the fix before it (plus
``REACH_SIGMAS`` of the fix's σ); at ``REFUSED_RUN`` of them it says the filter is off, and
its owner widens the position by the last innovation and doubts the heading, so that the
next fix is taken. A fix beyond that reach (a jump) starts the count again and holds the
judgement for ``GLITCH_TIME``: every fix of a 5 s glitch lies within reach of the one before
it but the first, and the glitch jumps back before then. Fixes still refused after it, still
following on from one another, are no glitch: the filter is off. (Until then a jump stopped
the count until a fix was accepted, which never came once the filter was off: one noisy fix
beyond reach shut the watch for good: the real SITL's boat on a 5 Hz GPS with its compass
read the wrong way round ran 200 m off for 90 s, 77 m RMS; now 4.4 m.)

Pure logic: the navigator (:mod:`mavhelm.nav.fusion`) tells it each fix's verdict.
"""

from __future__ import annotations

import math
from typing import Final

from mavhelm.nav.filter_safety import FIX, Decision

REFUSED_RUN: Final = 3
"""Fixes refused in a row, each within reach, before the filter is judged off (one or two
are a noisy fix: the gate refuses one honest fix in a thousand, ``EKF_GATE`` 0.999, so three
in a row from an honest filter are one in 10⁹ if independent)."""
REACH_SIGMAS: Final = 4.0
"""The fix's σ (per axis, both axes) allowed beyond the distance the speed covers: two honest
fixes lie further apart one time in three thousand (at 3 σ one in a hundred, a false jump
every 20 s of a 5 Hz GPS refused). A glitch of tens of metres still jumps."""
GLITCH_TIME: Final = 7.0
"""s after a jump that refused fixes following on from one another must last before the
filter, not a glitch, is judged off: a glitch jumps back sooner. ArduPilot's EKF resets its
position to a GPS whose fixes it has refused for as long (``gpsRetryTimeNoTAS_ms``)."""


class FixWatch:
    """``heard(t, sensor, x, y, sigma, accepted, speed, innovation)`` for each position fix the
    EKF judged; returns a decision when the filter, not the sensor, is off."""

    def __init__(self) -> None:
        self._last: dict[str, tuple[float, float, float]] = {}
        """Per sensor, its last fix heard (t, x, y)."""
        self._run: dict[str, int] = {}
        """Per sensor, its fixes refused in a row, each within reach; absent until one of its
        fixes is accepted (a filter that never took the sensor is not judged by it)."""
        self._jumped: dict[str, float] = {}
        """Per sensor, when the run of refused fixes last jumped (absent: it has not)."""

    def heard(self, t: float, sensor: str, x: float, y: float, sigma: float, accepted: bool,
              speed: float, innovation: float) -> Decision | None:
        last = self._last.get(sensor)
        self._last[sensor] = (t, x, y)
        if accepted:
            self._run[sensor] = 0
            self._jumped.pop(sensor, None)
            return None
        run = self._run.get(sensor)
        if last is None or run is None:
            return None
        t0, x0, y0 = last
        reach = abs(speed) * max(t - t0, 0.0) + REACH_SIGMAS * math.sqrt(2.0) * sigma
        if math.hypot(x - x0, y - y0) > reach:
            self._run[sensor] = 0  # a jump: the sensor's, unless it lasts
            self._jumped[sensor] = t
            return None
        run += 1
        jumped = self._jumped.get(sensor)
        if run < REFUSED_RUN or (jumped is not None and t - jumped < GLITCH_TIME):
            self._run[sensor] = run
            return None
        self._run[sensor] = 0
        self._jumped.pop(sensor, None)
        lasted = ("" if jumped is None else
                  f", for {t - jumped:.0f} s since they jumped (longer than a glitch lasts)")
        return Decision(t, FIX, (
            f"the last {run} fixes of position sensor {sensor} were refused, "
            f"{innovation:.1f} m from the filter, each following on from the one before as "
            f"the vehicle moves{lasted}: the filter is off, not the sensor: its position "
            f"widened and its heading doubted"))
