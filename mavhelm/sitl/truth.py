"""The simulated vehicle's true state: what the vehicle models produce and the sensors observe."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Truth:
    """Ground truth at time t, in the simulator's local frame (X east, Y north, Z up, metres).

    heading is degrees clockwise from true north in [0, 360); yaw_rate is degrees per second,
    positive turning clockwise (starboard). surge/sway are body-frame speeds through the water
    (forward, starboard); vx/vy are earth-frame velocity over the ground (east, north), which
    include any water current. water_depth is the seabed's depth below the surface here.
    """

    t: float
    x: float
    y: float
    heading: float
    yaw_rate: float = 0.0
    surge: float = 0.0
    sway: float = 0.0
    vx: float = 0.0
    vy: float = 0.0
    z: float = 0.0
    water_depth: float = 20.0
    pitch: float = 0.0
    roll: float = 0.0
