"""Run :class:`~mavhelm.nav.fusion.Fusion` over bare observations (the EKF/LSQ tests' replay):
each observation wrapped as a reading of a sensor of its kind, one step per time stamp."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from mavhelm.nav.ekf import Beacon, EKFConfig, Estimate, Observation, Position, Range, Yaw
from mavhelm.nav.fusion import Fusion, FusionConfig, Start
from mavhelm.nav.lsq import Fix
from mavhelm.nav.replay import Accuracy, accuracy
from mavhelm.nav.sensors import Reading, SensorSpec

SENSORS = {Range: SensorSpec("RANGE", "R", "ranger"),
           Yaw: SensorSpec("ORIENTATION", "C", "compass"),
           Position: SensorSpec("XY", "G", "gps")}
BODY = SensorSpec("BODY_VEL", "O", "odometry")


@dataclass
class Track:
    t: np.ndarray
    x: np.ndarray
    y: np.ndarray
    final: Estimate | None
    failure: str | None
    accepted: int
    rejected: int
    reinitialisations: int
    boot_fix: Fix | None
    warnings: list[str] = field(default_factory=list)


def replay(observations: list[Observation], beacons: list[Beacon], *,
           config: EKFConfig | None = None, start: Start | None = None,
           speed_scale: bool = True) -> Track:
    """``speed_scale``: the odometry's scale learned (EKF_SPEED_SCALE, the default)."""
    fusion = Fusion(FusionConfig(ekf=config or EKFConfig(), beacons=tuple(beacons),
                                 start=start, lsq_timeout=None, speed_scale=speed_scale))
    rows, warnings = [], []
    ordered = sorted(observations, key=lambda o: o.t)
    i = 0
    while i < len(ordered):
        t = ordered[i].t
        while i < len(ordered) and ordered[i].t == t:
            obs = ordered[i]
            fusion.add(Reading(SENSORS.get(type(obs), BODY), obs), t)
            i += 1
        estimate = fusion.step(t)
        warnings.extend(fusion.warnings)
        fusion.warnings.clear()
        if estimate is not None:
            rows.append((estimate.t, estimate.x, estimate.y))
        if fusion.failure is not None:
            break
    arr = np.array(rows, dtype=float).reshape(-1, 3)
    ekf = fusion.ekf
    return Track(arr[:, 0], arr[:, 1], arr[:, 2],
                 ekf.estimate() if ekf is not None and ekf.online else None, fusion.failure,
                 fusion.counts["accepted"], fusion.counts["rejected"],
                 fusion.reinitialisations, fusion.boot_fix, warnings)


def track_accuracy(track: Track, truth_t, truth_x, truth_y) -> Accuracy:
    return accuracy(track.t, track.x, track.y, truth_t, truth_x, truth_y)
