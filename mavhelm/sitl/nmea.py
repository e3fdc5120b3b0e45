"""NMEA 0183 sentences and mavhelm's proprietary sensor lines: encoders only.

The simulator's serial sensors speak exactly what real instruments on a boat speak, so the
companion's serial readers are tested against the real thing: standard NMEA for GPS (GGA, RMC),
heading (HDT) and echo sounder (DPT, DBT), and NMEA-framed proprietary sentences (``$P`` +
manufacturer code ``MVH`` for mavhelm) for the instruments that have no standard sentence:

- ``$PMVHDVL,t,fwd,stbd,down,status,alt*CS`` — DVL / wheel odometry body velocity over ground;
- ``$PMVHLBL,t0,id,twtt,id,twtt,...*CS`` — acoustic LBL two-way travel times of one ping;
- ``$PMVHRNG,t,id,range*CS`` — one radio range.

Encoders return a sentence **without** the line ending; the serial port adds ``\\r\\n``.
Every field layout is documented in docs/sim-sensors.md. The simulator only writes sentences;
whatever reads them (the companion, the tests) uses the project's parser, ``pynmea2``.
"""

from __future__ import annotations

from collections.abc import Sequence
from datetime import UTC, datetime

KNOTS_PER_MPS = 3600.0 / 1852.0
FEET_PER_M = 1.0 / 0.3048
FATHOMS_PER_M = 1.0 / 1.8288


def checksum(body: str) -> str:
    """XOR of every character between ``$`` and ``*``, as two upper-case hex digits."""
    value = 0
    for byte in body.encode("ascii"):
        value ^= byte
    return f"{value:02X}"


def sentence(address: str, fields: Sequence[str]) -> str:
    """Frame ``address`` (talker + type, e.g. ``GPGGA``) and fields as ``$...*CS``."""
    body = ",".join([address, *fields])
    if any(c in body for c in "$*\r\n!"):
        raise ValueError(f"reserved character in sentence body {body!r}")
    return f"${body}*{checksum(body)}"


# ---------------------------------------------------------------------------- field helpers


def _utc(unix_time: float) -> datetime:
    return datetime.fromtimestamp(unix_time, tz=UTC)


def nmea_time(unix_time: float) -> str:
    """``hhmmss.ss`` UTC, rounded to the centisecond (carrying into the second correctly)."""
    centis = round(unix_time * 100.0)
    dt = _utc(centis // 100)
    return f"{dt:%H%M%S}.{centis % 100:02d}"


def nmea_date(unix_time: float) -> str:
    """``ddmmyy`` UTC (of the same centisecond-rounded instant as nmea_time)."""
    return f"{_utc(round(unix_time * 100.0) // 100):%d%m%y}"


def _angle(value: float, deg_digits: int, hemis: str, decimals: int) -> tuple[str, str]:
    """Degrees → (``dddmm.mmmmmm``, hemisphere) with integer rounding so 59.9999995' carries."""
    scale = 10**decimals
    total = round(abs(value) * 60.0 * scale)  # minutes × scale
    degrees, minutes = divmod(total, 60 * scale)
    whole, frac = divmod(minutes, scale)
    text = f"{degrees:0{deg_digits}d}{whole:02d}.{frac:0{decimals}d}"
    return text, hemis[0] if value >= 0 else hemis[1]


def nmea_lat(lat: float, decimals: int = 6) -> tuple[str, str]:
    """Latitude degrees → (``ddmm.mmmmmm``, ``N``/``S``)."""
    return _angle(lat, 2, "NS", decimals)


def nmea_lon(lon: float, decimals: int = 6) -> tuple[str, str]:
    """Longitude degrees → (``dddmm.mmmmmm``, ``E``/``W``)."""
    return _angle(lon, 3, "EW", decimals)


def _f(value: float, decimals: int) -> str:
    text = f"{value:.{decimals}f}"
    return "0." + "0" * decimals if text.lstrip("-").strip("0.") == "" else text  # no "-0.0"


# --------------------------------------------------------------------- standard sentences


def gga(
    unix_time: float,
    lat: float | None,
    lon: float | None,
    *,
    quality: int = 1,
    satellites: int = 10,
    hdop: float = 0.9,
    altitude: float = 0.0,
    geoid_sep: float = 0.0,
    talker: str = "GP",
) -> str:
    """GGA fix data. ``lat``/``lon`` None (or quality 0) gives a no-fix sentence with empty
    position fields and HDOP 99.99, the way u-blox style receivers report a lost fix."""
    if lat is None or lon is None or quality == 0:
        pos = ["", "", "", ""]
        tail = ["0", f"{satellites:02d}", "99.99", "", "", "", "", "", ""]
    else:
        la, ns = nmea_lat(lat)
        lo, ew = nmea_lon(lon)
        pos = [la, ns, lo, ew]
        tail = [
            str(quality),
            f"{satellites:02d}",
            _f(hdop, 2),
            _f(altitude, 1),
            "M",
            _f(geoid_sep, 1),
            "M",
            "",
            "",
        ]
    return sentence(f"{talker}GGA", [nmea_time(unix_time), *pos, *tail])


def rmc(
    unix_time: float,
    lat: float | None,
    lon: float | None,
    sog_mps: float = 0.0,
    cog_deg: float = 0.0,
    *,
    talker: str = "GP",
) -> str:
    """RMC recommended minimum (NMEA 2.3, with mode indicator). No position → status ``V``."""
    date = nmea_date(unix_time)
    if lat is None or lon is None:
        fields = [nmea_time(unix_time), "V", "", "", "", "", "", "", date, "", "", "N"]
    else:
        la, ns = nmea_lat(lat)
        lo, ew = nmea_lon(lon)
        fields = [
            nmea_time(unix_time),
            "A",
            la,
            ns,
            lo,
            ew,
            _f(sog_mps * KNOTS_PER_MPS, 2),
            _f(round(cog_deg % 360.0, 1) % 360.0, 1),
            date,
            "",
            "",
            "A",
        ]
    return sentence(f"{talker}RMC", fields)


def hdt(heading_deg: float, *, talker: str = "HE") -> str:
    """HDT true heading, degrees in [0, 360)."""
    h = round(heading_deg % 360.0, 1)
    return sentence(f"{talker}HDT", [_f(0.0 if h >= 360.0 else h, 1), "T"])


def dpt(
    depth_m: float | None,
    offset_m: float = 0.0,
    max_range_m: float | None = None,
    *,
    talker: str = "SD",
) -> str:
    """DPT: depth below the transducer, and the transducer offset (+ to waterline, − to keel).

    ``depth_m`` None means the sounder has lost the bottom: the depth field is empty.
    """
    fields = ["" if depth_m is None else _f(depth_m, 2), _f(offset_m, 2)]
    if max_range_m is not None:
        fields.append(_f(max_range_m, 1))
    return sentence(f"{talker}DPT", fields)


def dbt(depth_m: float | None, *, talker: str = "SD") -> str:
    """DBT: depth below the transducer in feet, metres and fathoms (empty when lost)."""
    if depth_m is None:
        return sentence(f"{talker}DBT", ["", "f", "", "M", "", "F"])
    return sentence(
        f"{talker}DBT",
        [
            _f(depth_m * FEET_PER_M, 1),
            "f",
            _f(depth_m, 2),
            "M",
            _f(depth_m * FATHOMS_PER_M, 1),
            "F",
        ],
    )


# ------------------------------------------------------------------ proprietary sentences


def pmvhdvl(
    t: float, fwd: float | None, stbd: float | None, down: float | None, altitude: float | None
) -> str:
    """``$PMVHDVL,t,fwd,stbd,down,status,alt`` body velocity over ground (m/s, forward,
    starboard, down) valid at sensor time ``t`` (s); status ``A`` valid / ``V`` no lock
    (velocity fields empty); ``alt`` is the height above the bottom (m), empty if unknown."""
    valid = fwd is not None and stbd is not None and down is not None
    vel = [_f(v, 3) for v in (fwd, stbd, down)] if valid else ["", "", ""]  # type: ignore[arg-type]
    alt = "" if altitude is None else _f(altitude, 2)
    return sentence("PMVHDVL", [_f(t, 3), *vel, "A" if valid else "V", alt])


def pmvhlbl(t0: float, replies: Sequence[tuple[str, float | None]]) -> str:
    """``$PMVHLBL,t0,id,twtt,id,twtt,...`` one acoustic ping interrogated at ``t0`` (s): for
    each beacon its id and the two-way travel time in seconds **including** that beacon's
    turn-around delay (empty if no reply in the listen window)."""
    fields = [_f(t0, 3)]
    for beacon, twtt in replies:
        fields += [beacon, "" if twtt is None else _f(twtt, 6)]
    return sentence("PMVHLBL", fields)


def pmvhrng(t: float, beacon: str, range_m: float) -> str:
    """``$PMVHRNG,t,id,range`` one radio range (m) to beacon ``id`` measured at ``t`` (s)."""
    return sentence("PMVHRNG", [_f(t, 3), beacon, _f(range_m, 3)])
