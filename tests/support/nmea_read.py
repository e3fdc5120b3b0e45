"""Reading the simulator's serial sentences in tests, with the project's NMEA parser (pynmea2).

The simulator only writes NMEA (``mavhelm.sitl.nmea``); the companion reads it with pynmea2
(``companion/serial_instruments.py``), and so do the tests, through the two helpers here.

A plain helper module (not a test module).
"""

from __future__ import annotations

import pynmea2
from pynmea2 import ParseError
from pynmea2.nmea_utils import dm_to_sd

__all__ = ["ParseError", "latlon", "read_sentence"]


def read_sentence(line: str | bytes) -> tuple[str, list[str]]:
    """(address, fields) of one whole sentence: ``$``-framed, checksum checked by pynmea2.
    The address is talker + type (``GPGGA``) or the proprietary name (``PMVHDVL``); a
    trailing ``\\r\\n`` is accepted. ParseError on anything else."""
    if isinstance(line, bytes):
        try:
            line = line.decode("ascii")
        except UnicodeDecodeError:
            raise ParseError("non-ASCII bytes in sentence", line) from None
    text = line.rstrip("\r\n")
    if not text.startswith("$"):
        raise ParseError("no '$' start", text)
    msg = pynmea2.parse(text, check=True)
    if isinstance(msg, pynmea2.ProprietarySentence):
        return f"P{msg.manufacturer}{msg.data[0]}", list(msg.data[1:])
    return msg.talker + msg.sentence_type, list(msg.data)


def latlon(value: str, hemisphere: str) -> float:
    """``ddmm.mmmm`` / ``dddmm.mmmm`` and its hemisphere → signed degrees."""
    if not value or hemisphere not in "NSEW" or len(hemisphere) != 1:
        raise ParseError("empty position field or bad hemisphere", (value, hemisphere))
    degrees = dm_to_sd(value)
    return -degrees if hemisphere in "SW" else degrees
