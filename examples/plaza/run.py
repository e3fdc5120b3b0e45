"""Run mavhelm's pNav EKF over the Plaza1 log and score it against the ground truth.

Usage: ``python examples/plaza/run.py PLAZA.alog [--boot] [--drift DEG_PER_MIN]``

The log is the one ``convert.py`` writes. By default the filter starts 5 m from the true start
(1-σ 5 m, yaw unknown); ``--boot`` gives it no start at all, so the LSQ boots it from the
ranges; ``--drift`` adds a slow drift to the orientation readings (the heading-bias state must
follow it). Nothing is tuned to this data set: the filter runs with its default settings.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mavhelm.companion.alog import read_alog
from mavhelm.nav.ekf import Beacon, EKFConfig, Observation, Yaw
from mavhelm.nav.replay import (
    Accuracy,
    Start,
    Track,
    observations_from_messages,
    replay,
    track_accuracy,
)

START_ERROR = (3.0, 4.0)
"""m: how far from the true start the filter is told it starts (5 m)."""

CONFIG = EKFConfig(estimate_yaw_bias=True)
"""The defaults, plus the heading-bias state, which spec 2.2.10 allows because this vehicle
has a body velocity sensor (odometry) and a position sensor (the ranges)."""


@dataclass
class PlazaLog:
    observations: list[Observation]
    beacons: list[Beacon]
    truth_t: np.ndarray
    truth_x: np.ndarray
    truth_y: np.ndarray


@dataclass
class Result:
    track: Track
    accuracy: Accuracy
    seconds: float

    def summary(self) -> str:
        final = self.track.final
        assert final is not None
        offsets = ", ".join(f"{k}: {v:+.2f} m" for k, v in final.offsets.items())
        return (f"{self.accuracy}; run {self.seconds:.1f} s\n"
                f"  learned: range scale {final.range_scale:+.4f}, offsets {offsets}, "
                f"heading bias {math.degrees(final.yaw_bias):+.2f} deg\n"
                f"  {self.track.accepted} observations used, {self.track.rejected} rejected, "
                f"{len(self.track.fixes)} LSQ fixes, {self.track.reinitialisations} "
                f"re-initialisations, {self.track.rate_resets} rate resets"
                + (f", FAILURE: {self.track.failure}" if self.track.failure else ""))


def load(alog: str | Path) -> PlazaLog:
    """Observations, beacons (from the ``BEACON_<id>`` strings) and truth of a converted log."""
    messages = read_alog(alog)
    beacons = []
    truth: dict[str, list[tuple[float, float]]] = {"GT_X": [], "GT_Y": []}
    for msg in messages:
        if msg.name.startswith("BEACON_"):
            fields = dict(part.split("=") for part in msg.string.split(","))
            beacons.append(Beacon(msg.name[len("BEACON_"):], float(fields["x"]),
                                  float(fields["y"])))
        elif msg.name in truth:
            truth[msg.name].append((msg.time, msg.double))
    tx = np.array(truth["GT_X"])
    ty = np.array(truth["GT_Y"])
    return PlazaLog(observations_from_messages(messages), beacons, tx[:, 0], tx[:, 1],
                    ty[:, 1])


def drift_heading(observations: list[Observation], deg_per_min: float) -> list[Observation]:
    """The orientation readings drifting away from the truth at ``deg_per_min``."""
    t0 = observations[0].t
    rate = math.radians(deg_per_min) / 60.0
    return [dataclasses.replace(o, z=math.remainder(o.z + rate * (o.t - t0), 2 * math.pi))
            if isinstance(o, Yaw) else o for o in observations]


def run(log: PlazaLog, *, boot: bool = False, drift: float = 0.0) -> Result:
    observations = drift_heading(log.observations, drift) if drift else log.observations
    start = None if boot else Start(log.truth_x[0] + START_ERROR[0],
                                    log.truth_y[0] + START_ERROR[1], yaw=0.0, sigma_xy=5.0)
    clock = time.perf_counter()
    track = replay(observations, log.beacons, start=start, config=CONFIG)
    seconds = time.perf_counter() - clock
    return Result(track, track_accuracy(track, log.truth_t, log.truth_x, log.truth_y), seconds)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument("alog")
    parser.add_argument("--boot", action="store_true", help="no start: boot from the LSQ")
    parser.add_argument("--drift", type=float, default=0.0,
                        help="drift the heading readings by this many degrees a minute")
    args = parser.parse_args(argv)
    result = run(load(args.alog), boot=args.boot, drift=args.drift)
    print(result.summary())
    return 0 if result.track.failure is None else 1


if __name__ == "__main__":
    sys.exit(main())
