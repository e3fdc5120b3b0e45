"""The one MAVLink lat/lon check and the one ``time_boot_ms`` conversion."""

from __future__ import annotations

import pytest

from mavhelm.core.clock import BOOT_MS_WRAP, boot_ms, boot_seconds
from mavhelm.core.geodesy import lat_lon_e7


def test_lat_lon_e7_is_degrees():
    lat, lon = lat_lon_e7(564_120_000, -54_760_000)
    assert lat == pytest.approx(56.412) and lon == pytest.approx(-5.476)
    assert lat_lon_e7(900_000_000, -1_800_000_000) == pytest.approx((90.0, -180.0))


@pytest.mark.parametrize("lat, lon", [(900_000_001, 0), (-900_000_001, 0),
                                      (0, 1_800_000_001), (0, -2_147_483_648)])
def test_a_point_off_the_earth_is_refused(lat, lon):
    with pytest.raises(ValueError, match="is not on the earth"):
        lat_lon_e7(lat, lon)


def test_boot_ms_is_whole_milliseconds_never_negative_and_wraps_like_uint32():
    assert boot_ms(1.2345) == 1234
    assert boot_ms(-3.0) == 0
    assert boot_ms(BOOT_MS_WRAP / 1000 + 0.5) == 500
    assert 0 <= boot_ms(1e12) < BOOT_MS_WRAP
    assert boot_seconds(1500) == 1.5
