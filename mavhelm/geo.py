"""Latitude/longitude ↔ the local navigation plane (X east, Y north, metres from an origin).

A local tangent plane with WGS-84 radii of curvature at the origin: error below 1 cm per km
over the few kilometres a boat or rover mission covers, and no extra dependency.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

_A = 6378137.0
_E2 = 6.69437999014e-3


@dataclass(frozen=True)
class Origin:
    lat: float
    lon: float

    @property
    def _radii(self) -> tuple[float, float]:
        s = math.sin(math.radians(self.lat))
        w = math.sqrt(1.0 - _E2 * s * s)
        meridian = _A * (1.0 - _E2) / (w**3)
        normal = _A / w
        return meridian, normal * math.cos(math.radians(self.lat))

    def to_local(self, lat: float, lon: float) -> tuple[float, float]:
        """(x east, y north) in metres."""
        north_r, east_r = self._radii
        return (
            math.radians(lon - self.lon) * east_r,
            math.radians(lat - self.lat) * north_r,
        )

    def to_global(self, x: float, y: float) -> tuple[float, float]:
        """(lat, lon) in degrees."""
        north_r, east_r = self._radii
        return self.lat + math.degrees(y / north_r), self.lon + math.degrees(x / east_r)


def wrap_degrees(angle: float) -> float:
    """Wrap to (-180, 180]."""
    a = math.fmod(angle + 180.0, 360.0)
    if a <= 0:
        a += 360.0
    return a - 180.0


def heading_to_yaw(heading_deg: float) -> float:
    """Compass heading (degrees clockwise from north) to MOOS yaw (radians, yaw = -heading)."""
    return -math.radians(wrap_degrees(heading_deg))


def yaw_to_heading(yaw: float) -> float:
    """MOOS yaw (radians) to compass heading in [0, 360)."""
    return (-math.degrees(yaw)) % 360.0
