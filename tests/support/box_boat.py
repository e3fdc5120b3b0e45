"""A boat on a GPS and a compass round a box, as a recording: the replay tests of a compass
gone wrong (read the wrong way round, jumping) against a GPS that should hold the filter."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from mavhelm.core.bus import Message

MISSION = """
LatOrigin = 56.412
LongOrigin = -5.476
ProcessConfig = pNav
{
    X       = EKF @ 2
    Y       = EKF @ 2
    Heading = EKF @ 2
    SENSOR_XY          = GPS -> gps ~ 2
    SENSOR_ORIENTATION = HDG -> compass ~ 1
    FIXEDSIDESLIP      = 0 @ 0.3
    EKF_YAW_BIAS       = true
}
"""


def box(compass: Callable[[float, float], float], seed: int, seconds: float = 300.0,
        outlier_every: int | None = None) -> list[Message]:
    """At 3 m/s round a box (legs of 33 s, quarter turns of 10 s): a 10 Hz compass reading
    ``compass(seconds in, true heading)`` (degrees), a 5 Hz GPS with 2 m of noise (every
    ``outlier_every``-th fix 20 m out: multipath), and the truth."""
    rng = np.random.default_rng(seed)
    out = []
    x = y = 0.0
    heading = 90.0
    for k in range(int(seconds * 10)):
        t = 3000.0 + 0.1 * k
        rate = 9.0 if (0.1 * k) % 43.0 >= 33.0 else 0.0  # deg/s clockwise
        heading = (heading + rate * 0.1) % 360.0
        x += 3.0 * math.sin(math.radians(heading)) * 0.1
        y += 3.0 * math.cos(math.radians(heading)) * 0.1
        out.append(Message("HDG_HEADING", compass(0.1 * k, heading) % 360.0, t, "log"))
        if k % 2 == 0:
            outlier = 20.0 if outlier_every and (k // 2) % outlier_every == 2 else 0.0
            out += [Message("GPS_X", x + rng.normal(0, 2.0), t, "log"),
                    Message("GPS_Y", y + outlier + rng.normal(0, 2.0), t, "log"),
                    Message("TRUTH_X", x, t, "log"), Message("TRUTH_Y", y, t, "log")]
    return out
