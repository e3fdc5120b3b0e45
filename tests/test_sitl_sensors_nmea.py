"""NMEA and proprietary sentence encoders: checksums, field values, cross-checked with pynmea2."""

from __future__ import annotations

import pynmea2
import pytest

from mavhelm.sitl import nmea
from tests.support.nmea_read import ParseError, latlon, read_sentence

T0 = 1_767_225_600.0 + 13 * 3600 + 45 * 60 + 7.25  # 2026-01-01 13:45:07.25 UTC


def test_checksum_of_the_textbook_gga() -> None:
    body = "GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,"
    assert nmea.checksum(body) == "47"
    address, fields = read_sentence(f"${body}*47\r\n")
    assert address == "GPGGA" and fields[1] == "4807.038" and len(fields) == 14


@pytest.mark.parametrize("lat,lon", [(50.3712345, -4.1423456), (-33.8567844, 151.2152967)])
def test_gga_round_trip(lat: float, lon: float) -> None:
    line = nmea.gga(T0, lat, lon, satellites=9, hdop=1.2, altitude=3.4)
    address, f = read_sentence(line)
    assert address == "GPGGA" and len(f) == 14
    assert f[0] == "134507.25"
    assert latlon(f[1], f[2]) == pytest.approx(lat, abs=2e-8)
    assert latlon(f[3], f[4]) == pytest.approx(lon, abs=2e-8)
    assert (f[5], f[6], f[7], f[8]) == ("1", "09", "1.20", "3.4")
    msg = pynmea2.parse(line, check=True)
    assert msg.latitude == pytest.approx(lat, abs=2e-8)
    assert msg.longitude == pytest.approx(lon, abs=2e-8)
    assert msg.gps_qual == 1 and int(msg.num_sats) == 9


def test_gga_no_fix_has_empty_position() -> None:
    line = nmea.gga(T0, None, None)
    _, f = read_sentence(line)
    assert f[1:5] == ["", "", "", ""] and f[5] == "0"
    assert pynmea2.parse(line, check=True).gps_qual == 0


def test_rmc_round_trip() -> None:
    line = nmea.rmc(T0, 50.5, -4.25, sog_mps=2.0, cog_deg=-10.0)
    address, f = read_sentence(line)
    assert address == "GPRMC" and len(f) == 12
    assert f[1] == "A" and f[8] == "010126" and f[11] == "A"
    assert float(f[6]) == pytest.approx(2.0 * 3600 / 1852, abs=0.005)
    assert float(f[7]) == pytest.approx(350.0)
    msg = pynmea2.parse(line, check=True)
    assert msg.latitude == pytest.approx(50.5) and msg.longitude == pytest.approx(-4.25)
    assert msg.datestamp.isoformat() == "2026-01-01"
    # a course that rounds up to 360.0 is written 0.0
    assert read_sentence(nmea.rmc(T0, 1, 1, 1, 359.99))[1][7] == "0.0"
    _, lost = read_sentence(nmea.rmc(T0, None, None))
    assert lost[1] == "V" and lost[2] == ""


def test_time_and_angle_rounding_carry() -> None:
    assert nmea.nmea_time(1_767_225_600.0 + 59.999) == "000100.00"
    assert nmea.nmea_lat(10.9999999999) == ("1100.000000", "N")
    assert nmea.nmea_lon(-0.5) == ("00030.000000", "W")
    assert nmea.nmea_date(1_767_225_600.0 - 0.001) == "010126"  # rounds up to midnight


def test_hdt_dpt_dbt() -> None:
    assert read_sentence(nmea.hdt(123.44)) == ("HEHDT", ["123.4", "T"])
    assert read_sentence(nmea.hdt(-0.02)) == ("HEHDT", ["0.0", "T"])
    assert read_sentence(nmea.hdt(370.0))[1][0] == "10.0"
    assert float(pynmea2.parse(nmea.hdt(271.25), check=True).heading) == pytest.approx(271.2, 0.1)
    d = pynmea2.parse(nmea.dpt(12.345, 0.3, 100.0), check=True)
    assert float(d.depth) == pytest.approx(12.35, abs=0.006) and float(d.offset) == 0.3
    assert read_sentence(nmea.dpt(None, 0.3))[1][0] == ""
    _, f = read_sentence(nmea.dbt(10.0))
    assert f == ["32.8", "f", "10.00", "M", "5.5", "F"]
    assert pynmea2.parse(nmea.dbt(None), check=True).depth_meters is None


def test_proprietary_sentences() -> None:
    line = nmea.pmvhdvl(12.5, 1.2345, -0.0004, 0.01, 8.2)
    assert read_sentence(line) == (
        "PMVHDVL",
        ["12.500", "1.234", "0.000", "0.010", "A", "8.20"],
    )
    msg = pynmea2.parse(line, check=True)  # a valid NMEA proprietary sentence: maker "MVH"
    assert msg.manufacturer == "MVH" and msg.data[0] == "DVL"
    assert read_sentence(nmea.pmvhdvl(1.0, None, None, None, None))[1] == [
        "1.000",
        "",
        "",
        "",
        "V",
        "",
    ]
    assert read_sentence(nmea.pmvhlbl(10.0, [("1", 0.1234567), ("B2", None)])) == (
        "PMVHLBL",
        ["10.000", "1", "0.123457", "B2", ""],
    )
    assert read_sentence(nmea.pmvhrng(3.25, "4", 45.6789)) == (
        "PMVHRNG",
        ["3.250", "4", "45.679"],
    )


@pytest.mark.parametrize(
    "bad",
    [
        "GPGGA,1,2*00",
        "$HEHDT,123.4,T",
        "$HEHDT,123.4,T*00",
        "$HEHDT,123.4,T*2",
        "$HEHDT,12$3.4,T*2B",
        b"$HEHDT,\xff23.4,T*2B",
        "$,123*00",
    ],
)
def test_parse_rejects_bad_lines(bad: str | bytes) -> None:
    with pytest.raises(ParseError):
        read_sentence(bad)


def test_sentence_refuses_reserved_characters() -> None:
    with pytest.raises(ValueError):
        nmea.sentence("PMVHRNG", ["1*2"])
