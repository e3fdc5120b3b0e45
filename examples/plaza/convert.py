"""Convert the Plaza1 range-beacon data set (``Plaza1.mat``) to a MOOS ``.alog`` and a mission.

Usage: ``python examples/plaza/convert.py IN.mat OUT.alog [--mission OUT.moos]``

Variables written, named as pNav's sensor lines read them (times are the data set's own
clock; LOGSTART is its first time):

- ``ODOM_VX_BODY``  m/s, forward speed over each odometry interval (``DR``: distance / time)
- ``ODOM_VY_BODY``  0 m/s with every odometry row: a wheeled robot does not crab, which is
                    what odometry tells a filter about the sideways speed (the sensor line's
                    second noise says how strictly)
- ``ODOM_YAW_VEL``  rad/s, yaw rate over the same interval (counter-clockwise positive, as
                    mavhelm's yaw = −heading)
- ``ODOM_HEADING``  degrees clockwise from north: the vehicle's own heading (``DRp``, or
                    ``DR`` integrated when a recording has no ``DRp``)
- ``UWB_RANGE_<id>`` m, a range to beacon ``<id>`` as measured (offset included) (``TD``)
- ``TRUTH_X``, ``TRUTH_Y`` m, ``TRUTH_HEADING`` degrees: ground truth (``GT``)

The mission (``--mission``) is ``plaza.moos.in`` beside this script with the data set's
beacons (``TL``) and a start 5 m from the true one (1-σ 5 m): what a surveyor would know.
The data set's plane is taken as mavhelm's local frame (x east, y north); its angles are
counter-clockwise from x, so heading = 90° − angle. Ranges in the file are not time-ordered;
the log is.
"""

from __future__ import annotations

import argparse
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


START_ERROR = (3.0, 4.0)
"""m: how far from the true start the mission says the vehicle starts (5 m)."""
TEMPLATE = Path(__file__).with_name("plaza.moos.in")


def _finite_rows(array: np.ndarray) -> np.ndarray:
    """The rows of a data set's array whose every entry is a number (a recording may mark a
    missing sample with NaN)."""
    a = np.asarray(array, dtype=float)
    return a[np.isfinite(a).all(axis=1)]


def dead_reckoning(mat: dict[str, np.ndarray]) -> np.ndarray:
    """``DRp`` (t, x, y, angle): the odometry integrated, as the data set gives it; a recording
    without it gets it integrated here from ``DR``, from the ground truth's first pose, where
    Plaza1's own ``DRp`` starts, turned by the recording's ``init_heading_offset`` where it
    has one (the odometry's heading frame against the truth's, which the data set's own
    loaders add to the truth's first heading; 0 on Plaza1). Only its heading is used
    (``ODOM_HEADING``): on Plaza1 the integrated angle equals ``DRp``'s at every row (a
    test)."""
    if "DRp" in mat:
        return _finite_rows(mat["DRp"])
    dr, gt = _finite_rows(mat["DR"]), _finite_rows(mat["GT"])
    t0, x, y, angle = (float(v) for v in gt[0])
    offset = np.asarray(mat.get("init_heading_offset", 0.0), dtype=float).ravel()
    if offset.size == 1 and np.isfinite(offset[0]):
        angle += float(offset[0])
    rows = [(t0, x, y, angle)]
    for t, dist, dyaw in dr:
        if t <= rows[-1][0]:
            continue
        angle += float(dyaw)
        x += float(dist) * math.cos(angle)
        y += float(dist) * math.sin(angle)
        rows.append((float(t), x, y, angle))
    return np.array(rows)


def messages(mat: dict[str, np.ndarray]) -> list[Message]:
    """Every variable of the log, time-ordered (stable, so a time's rows keep their order)."""
    gt, dr, td = (_finite_rows(mat[k]) for k in ("GT", "DR", "TD"))
    drp = dead_reckoning(mat)
    out: list[Message] = []
    for (t_before, _d, _a), (t, dist, dyaw) in zip(dr, dr[1:], strict=False):
        dt = float(t - t_before)
        if dt <= 0:
            continue
        out.append(Message("ODOM_VX_BODY", float(dist) / dt, float(t), "iOdometry"))
        out.append(Message("ODOM_VY_BODY", 0.0, float(t), "iOdometry"))
        out.append(Message("ODOM_YAW_VEL", float(dyaw) / dt, float(t), "iOdometry"))
    for t, _x, _y, angle in drp:
        out.append(Message("ODOM_HEADING", heading_degrees(angle), float(t), "iOdometry"))
    for t, _receiver, beacon_id, rng in td:
        out.append(Message(f"UWB_RANGE_{int(beacon_id)}", float(rng), float(t), "iRange"))
    for t, x, y, angle in gt:
        out.append(Message("TRUTH_X", float(x), float(t), "truth"))
        out.append(Message("TRUTH_Y", float(y), float(t), "truth"))
        out.append(Message("TRUTH_HEADING", heading_degrees(angle), float(t), "truth"))
    out.sort(key=lambda m: m.time)
    return out


def mission_text(mat: dict[str, np.ndarray]) -> str:
    """The pNav mission for this recording: its beacons and a start known to 5 m."""
    gt, tl = _finite_rows(mat["GT"]), _finite_rows(mat["TL"])
    beacons = "\n".join(f"    BEACON = {int(i)} @ {x:.3f},{y:.3f},0" for i, x, y in tl[:, :3])
    return TEMPLATE.read_text().format(beacons=beacons, x=gt[0, 1] + START_ERROR[0],
                                       y=gt[0, 2] + START_ERROR[1])


def convert(mat_path: str | Path, alog_path: str | Path,
            mission_path: str | Path | None = None) -> int:
    """Write the .alog (and the mission); returns the number of messages written."""
    mat = scipy.io.loadmat(str(mat_path))
    if mission_path is not None:
        Path(mission_path).write_text(mission_text(mat))
    msgs = messages(mat)
    start = msgs[0].time
    logger = AlogLogger(Bus(SimClock(start)), alog_path, start_time=start, opened_on=0.0)
    try:
        logger.on_mail(msgs, msgs[-1].time)
    finally:
        logger.close()
    return len(msgs)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument("mat")
    parser.add_argument("alog")
    parser.add_argument("--mission", help="also write the pNav mission for this recording")
    args = parser.parse_args(argv)
    n = convert(args.mat, args.alog, args.mission)
    print(f"wrote {n} messages to {args.alog}"
          + (f" and the mission {args.mission}" if args.mission else ""))
    return 0


if __name__ == "__main__":
    sys.exit(main())
