"""Latitude/longitude ↔ the local navigation plane, and the angle conventions of the spec.

The local frame is X east, Y north, Z up, in metres from the mission's ``LatOrigin`` /
``LongOrigin``: pymap3d's WGS-84 geodetic ↔ ENU conversion. It round-trips to well under a
millimetre at 30 km, and the plane distance differs from the WGS-84 geodesic by only the
tangent plane's own s³/6R² (4 mm at 10 km); both are pinned by tests.
Heading is degrees clockwise from north; MOOS yaw is radians with yaw = −heading.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import pymap3d

from mavhelm.core.mission import Mission
from mavhelm.core.moos import GLOBAL_PARAMS
from mavhelm.core.params import Number, Param, Schema

WGS84 = pymap3d.Ellipsoid.from_name("wgs84")
"""pymap3d's default ellipsoid, built once (it builds one per call when none is given)."""


@dataclass(frozen=True)
class Origin:
    """The local frame's origin on the WGS-84 ellipsoid (height 0)."""

    lat: float
    lon: float

    @cached_property
    def _frame(self) -> tuple[float, float, float, float, float, float, float]:
        """The origin's ECEF position and its latitude's and longitude's sines and cosines."""
        x0, y0, z0 = pymap3d.geodetic2ecef(self.lat, self.lon, 0.0, WGS84)
        lat, lon = math.radians(self.lat), math.radians(self.lon)
        return (float(x0), float(y0), float(z0), math.sin(lat), math.cos(lat), math.sin(lon),
                math.cos(lon))

    def to_local(self, lat: float, lon: float) -> tuple[float, float]:
        """(x east, y north) in metres: pymap3d's geodetic2enu, worked out in ``math``.

        pymap3d takes numpy's ufuncs for its trigonometry whenever numpy is installed, and on
        a lone float they cost ten times ``math``'s; the bridge converts every GPS fix inside
        the control tick (two conversions a fix, ~25 µs of a 5 Hz fix's tick). The formulae
        are pymap3d's own (``geodetic2ecef``, ``uvw2enu``), the origin's part from pymap3d
        itself; a test pins the two within a micrometre out to 30 km."""
        x0, y0, z0, sin_lat0, cos_lat0, sin_lon0, cos_lon0 = self._frame
        phi, lam = math.radians(lat), math.radians(lon)
        sin_phi, cos_phi = math.sin(phi), math.cos(phi)
        a, b = WGS84.semimajor_axis, WGS84.semiminor_axis
        n = a * a / math.hypot(a * cos_phi, b * sin_phi)
        u = n * cos_phi * math.cos(lam) - x0
        v = n * cos_phi * math.sin(lam) - y0
        w = n * (b / a) ** 2 * sin_phi - z0
        t = cos_lon0 * u + sin_lon0 * v
        return -sin_lon0 * u + cos_lon0 * v, -sin_lat0 * t + cos_lat0 * w

    def to_global(self, x: float, y: float) -> tuple[float, float]:
        """(lat, lon) in degrees of the point on the ellipsoid's surface whose local position
        is (x east, y north): the inverse of ``to_local``.

        The surface falls below the tangent plane by about d²/2R; starting from that drop, two
        corrections by the height error put the point on the ellipsoid to well under 1 mm.
        """
        up = -(x * x + y * y) / (2.0 * 6371008.8)
        for _ in range(3):
            lat, lon, h = pymap3d.enu2geodetic(x, y, up, self.lat, self.lon, 0.0, WGS84)
            if abs(h) < 1e-6:
                break
            up -= float(h)
        return float(lat), float(lon)


E7 = 1e-7
"""MAVLink's integer latitudes and longitudes are degrees × 1e7."""


def lat_lon_e7(lat_e7: int, lon_e7: int) -> tuple[float, float]:
    """A MAVLink position (degrees × 1e7) in degrees; ValueError for a point not on the earth,
    so every message that carries one refuses it the same way."""
    if not (abs(lat_e7) <= 900_000_000 and abs(lon_e7) <= 1_800_000_000):
        raise ValueError(f"lat/lon {lat_e7}/{lon_e7} (1e-7 deg) is not on the earth")
    return lat_e7 * E7, lon_e7 * E7


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
    heading = (-math.degrees(yaw)) % 360.0
    return 0.0 if heading >= 360.0 else heading


GLOBAL_SCHEMA = Schema("the mission's global settings", (
    Param("LatOrigin", Number(-90.0, 90.0), unit="deg",
          doc="latitude of the local frame's origin (WGS-84)", attr="lat"),
    Param("LongOrigin", Number(-180.0, 180.0), unit="deg",
          doc="longitude of the local frame's origin (WGS-84)", attr="lon"),
), moos=GLOBAL_PARAMS)
"""Settings outside every block: the local frame's origin (X east, Y north of it)."""


def mission_origin(mission: Mission) -> Origin:
    """The mission's origin; a located MissionError for a missing, unknown or bad setting."""
    settings = GLOBAL_SCHEMA.read(mission.globals, owner="the mission")
    return Origin(settings["lat"], settings["lon"])
