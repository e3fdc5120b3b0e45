"""Convert the Plaza1 range-beacon data set (``Plaza1.mat``) to a MOOS ``.alog``.

Usage: ``python examples/plaza/convert.py IN.mat OUT.alog``

Variables written (times are the data set's own clock; LOGSTART is its first time):

- ``BEACON_<id>``  string ``x=…,y=…`` at the start: the surveyed beacon positions (m)
- ``ODOM_DIST``    m, distance travelled since the previous ``ODOM_DIST`` (``DR`` rows)
- ``ODOM_DYAW``    rad, yaw change over the same interval (counter-clockwise positive, as
                   mavhelm's yaw = −heading)
- ``ODOM_HEADING`` degrees clockwise from north: the vehicle's own heading (``DRp``)
- ``RANGE_<id>``   m, a range to beacon ``<id>`` as measured (offset included) (``TD``)
- ``GT_X``, ``GT_Y`` m, ``GT_HEADING`` degrees: ground truth (``GT``)

The data set's plane is taken as mavhelm's local frame (x east, y north); its angles are
counter-clockwise from x, so heading = 90° − angle. Ranges in the file are not time-ordered;
the log is.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import scipy.io

from mavhelm.companion.alog import AlogLogger
from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock


def heading_degrees(angle: float) -> float:
    """A counter-clockwise angle from x (rad) as a compass heading in [0, 360)."""
    return (90.0 - math.degrees(angle)) % 360.0


def messages(mat: dict[str, np.ndarray]) -> list[Message]:
    """Every variable of the log, time-ordered (stable, so a time's rows keep their order)."""
    gt, dr, drp, td, tl = (np.asarray(mat[k], dtype=float) for k in ("GT", "DR", "DRp", "TD", "TL"))
    t0 = float(min(gt[0, 0], drp[0, 0], dr[0, 0], td[:, 0].min()))
    out: list[Message] = []
    for beacon_id, x, y in tl:
        out.append(Message(f"BEACON_{int(beacon_id)}", f"x={x:.6f},y={y:.6f}", t0, "plaza"))
    for t, dist, dyaw in dr:
        out.append(Message("ODOM_DIST", float(dist), float(t), "iOdometry"))
        out.append(Message("ODOM_DYAW", float(dyaw), float(t), "iOdometry"))
    for t, _x, _y, angle in drp:
        out.append(Message("ODOM_HEADING", heading_degrees(angle), float(t), "iOdometry"))
    for t, _receiver, beacon_id, rng in td:
        out.append(Message(f"RANGE_{int(beacon_id)}", float(rng), float(t), "iRange"))
    for t, x, y, angle in gt:
        out.append(Message("GT_X", float(x), float(t), "truth"))
        out.append(Message("GT_Y", float(y), float(t), "truth"))
        out.append(Message("GT_HEADING", heading_degrees(angle), float(t), "truth"))
    out.sort(key=lambda m: m.time)
    return out


def convert(mat_path: str | Path, alog_path: str | Path) -> int:
    """Write the .alog; returns the number of messages written."""
    mat = scipy.io.loadmat(str(mat_path))
    msgs = messages(mat)
    start = msgs[0].time
    logger = AlogLogger(Bus(SimClock(start)), alog_path, start_time=start, opened_on=0.0)
    try:
        logger.on_mail(msgs, msgs[-1].time)
    finally:
        logger.close()
    return len(msgs)


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        print(__doc__.strip().splitlines()[2], file=sys.stderr)
        return 2
    n = convert(args[0], args[1])
    print(f"wrote {n} messages to {args[1]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
