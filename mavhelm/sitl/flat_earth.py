"""The simulator's flat earth: latitude/longitude ↔ metres east/north of the home point.

A plane with WGS-84 radii of curvature at the origin, as a SITL's world is: simple and fast,
but not a geodesic (4.4 cm off in distance at 1 km and 4.4 m at 10 km, at 56° N). The
companion converts with ``mavhelm.core.geodesy`` instead; the two place a point 300 m from
the origin within 13 mm of each other (0.07 mm along a meridian), pinned by a test.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

_A = 6378137.0
_E2 = 6.69437999014e-3


@dataclass(frozen=True)
class Origin:
    lat: float
    lon: float

    @cached_property
    def _radii(self) -> tuple[float, float]:
        """(meridian, east) radii at the origin: worked out once, every conversion needs them."""
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
