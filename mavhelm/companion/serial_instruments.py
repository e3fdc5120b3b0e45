"""Serial instruments on the companion's own ports: one app per instrument, NMEA in, bus out.

A boat's GPS, heading sensor, echo sounder, DVL and range receiver talk NMEA 0183 on serial
lines. Each one is configured by its own block, named ``iSerial`` or ``iSerial_<label>`` (the
way MOOS names a second copy of a process), and becomes one app posting ``<Name>_*`` variables
that pNav's priority queues then choose from (``X = SGPS @ 2, GPS @ 3``)::

    ProcessConfig = iSerial_GPS          // the label after iSerial_ is free text
    {
      Name      = SGPS                   // prefix of the bus variables: SGPS_X, SGPS_Y, ...
      Port      = /dev/serial/by-id/usb-u-blox_GNSS-if00
      Baud      = 9600
      Sentences = GGA,RMC
      Stale     = 3                      // say SGPS_WARNING after 3 s without a valid sentence
    }

    ProcessConfig = iSerial_Sounder
    {
      Name      = SND
      Port      = /dev/ttyUSB1           // Baud defaults to 4800, NMEA 0183's speed
      Sentences = DPT,DBT
    }

One block per device, because a device has several settings and a field engineer swaps or
disables one instrument by its block. Every setting is declared in ``INSTRUMENT_SCHEMA``; two
blocks may not share a ``Name`` or a ``Port`` (``instruments_from_mission``), and ``Name`` may
not be a prefix another app posts (``GPS_*`` and ``INS_*`` are the autopilot's).

Variables (``<N>`` is ``Name``; every value is stamped with the tick in which its line was read,
except the LBL travel times, stamped with their ping time):

=================  ===================================================================
GGA                ``<N>_FIX`` (quality 0-8); with quality 1-5 ``<N>_X``, ``<N>_Y`` (m, local
                   frame of the mission's origin), ``<N>_LAT``, ``<N>_LON`` (degrees)
RMC, status A      ``<N>_X``/``_Y``/``_LAT``/``_LON`` (unless GGA already posted the fix of
                   the same UTC time), ``<N>_SPEED`` (m/s over ground), ``<N>_COURSE`` (deg),
                   and ``<N>_HEADING`` = course when ``Sentences`` has no HDT; ``<N>_FIX``
                   from the mode indicator when it has no GGA (status V: ``<N>_FIX`` 0)
HDT                ``<N>_HEADING`` (deg true, [0, 360)), ``<N>_YAW`` (rad, yaw = −heading)
DPT                ``<N>_ALTITUDE`` = depth below the transducer (m above the bottom: what
                   LimitAltitude reads), ``<N>_DEPTH`` = that + the DPT offset (positive:
                   transducer to waterline, so the water depth; negative: transducer to keel,
                   so the water under the keel); an empty depth (bottom lost) posts nothing
DBT                the same two, from the metres (else feet, else fathoms) field, with the
                   offset of the last DPT from this port (0 until one is heard)
``$PMVHDVL``       status A: ``<N>_VX_BODY`` forward, ``<N>_VY_BODY`` starboard,
                   ``<N>_VZ_BODY`` down (m/s over ground, the sentence's frame); and
                   ``<N>_ALTITUDE`` (m above the bottom) whenever the field is given
``$PMVHLBL``       ``<N>_TWTT_<id>``: each beacon's two-way travel time (s, turn-around
                   included, as sent) for every beacon that replied, stamped with the
                   sentence's t0, the ping time: the line arrives only when the listen
                   window closes, seconds after the ping, and pNav's EKF_LAG needs to know
                   when the vehicle was where the travel times say. A t0 that is not a time
                   within ``LBL_MAX_AGE_S`` (30 s) before now, or is later than now (an
                   instrument not on the companion's clock), is not trusted: the travel
                   times are stamped with the read time, counted (``stats["lbl_read_time"]``)
                   and said once as ``<N>_WARNING`` (again after a good t0)
``$PMVHRNG``       ``<N>_RANGE_<id>`` (m)
health             ``<N>_OPEN`` 1/0 when the port opens or is lost; ``<N>_DROPPED`` (lines
                   dropped so far) and ``<N>_DROPS`` (``checksum=3,garbage=1``) when they
                   change, at most once a tick; ``<N>_WARNING`` (see below)
=================  ===================================================================

The proprietary sentences are documented in ``docs/sim-sensors.md``.

What is dropped and counted (``stats``, ``<N>_DROPPED``), never posted:

- ``overlong``: 1 KiB without a line end (the rest of it, up to the next line end, with it);
- ``garbage``: a line with no ``$``, bytes that are not ASCII, no readable address, junk
  after the checksum;
- ``truncated``: a sentence without its ``*hh`` checksum, or cut by the start of the next;
- ``checksum``: a checksum that does not match (pynmea2, ``check=True``);
- ``malformed``: a sentence with a good checksum whose fields do not parse or are out of
  range;
- ``unknown``: a well-formed sentence of a type not in ``Sentences`` (so a GPS's GSV lines
  are counted here; ``<N>_DROPS`` tells them apart from damage);
- ``backlog``: lines skipped because more than a tick's budget was waiting (below).

A line damaged before its last ``$`` still yields the sentence after it when that one checks
out; each line counts once. Line ends are CR, LF or both. The fragment read right after a
port opens usually starts mid-sentence: it is parsed if it can be, else skipped uncounted.

Timings: nothing is opened before the first tick (a mission is validated without touching a
port). A port that cannot be opened, or that fails on a read (an unplugged USB adapter, a pty
whose other end closed), is closed and retried 1 s later, the delay doubling to 8 s (a port
that failed within 8 s of opening keeps doubling, so a loose connector cannot flap every
second); it is said once per outage as ``<N>_WARNING``. ``Stale`` seconds with the port open
and no valid sentence of an accepted type is said once (re-armed by the next one), with a hint
when lines do arrive but are all dropped (wrong ``Baud`` or ``Sentences``). Reading never
blocks: the port is link.SerialTransport (pyserial, ``timeout=0``), reused as is; a tick
drains at most ``DRAIN_CAP`` bytes and parses at most ``budget`` of them (one second of the
line at ``Baud``, within 4-64 KiB), the newest ones: older whole lines are counted as
``backlog``, so a flood costs old lines, never the tick.
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import pynmea2

from mavhelm.companion.bridge import FAR_FROM_ORIGIN_M
from mavhelm.companion.link import RETRY_FIRST_S, RETRY_MAX_S, SerialTransport, Transport
from mavhelm.core.app import App
from mavhelm.core.backoff import Backoff
from mavhelm.core.bus import Bus
from mavhelm.core.geodesy import Origin, heading_to_yaw
from mavhelm.core.mission import Block, Entry, Mission
from mavhelm.core.moos import APP_PARAMS
from mavhelm.core.names import POSTED_FAMILIES, posted_family
from mavhelm.core.params import Choice, ChoiceList, Kind, Param, PathName, Schema, Seconds

BLOCK_NAME = "iSerial"
"""A serial instrument's ProcessConfig is ``iSerial`` or ``iSerial_<label>``."""

SENTENCES = ("GGA", "RMC", "HDT", "DPT", "DBT", "PMVHDVL", "PMVHLBL", "PMVHRNG")
"""The sentence types a reader understands (any talker for the standard ones)."""

DROP_REASONS = ("overlong", "garbage", "truncated", "checksum", "malformed", "unknown",
                "backlog")

LBL_MAX_AGE_S = 30.0
"""An LBL ping time older than this (or later than now) is not the companion's clock."""

MAX_LINE = 1024
"""Bytes a line may reach without a line end before it is dropped (NMEA's own limit is 82)."""
DRAIN_CAP = 128 * 1024
"""Bytes taken from the port per tick at most; a tty's kernel buffer holds less than this."""
BUDGET_MIN = 4 * 1024
BUDGET_MAX = 64 * 1024

RESERVED_NAMES = POSTED_FAMILIES
"""Prefixes other apps post (the MAVLink bridge, pNav, the helm): a reader may not mix in."""

STANDARD_BAUDS = (300, 600, 1200, 1800, 2400, 4800, 9600, 19200, 38400, 57600, 115200, 230400,
                  460800, 500000, 576000, 921600, 1000000, 1152000, 1500000, 2000000, 2500000,
                  3000000, 3500000, 4000000)
"""The speeds a Linux serial driver knows (termios B* constants from 300 bit/s)."""

KNOT = 1852.0 / 3600.0
FOOT = 0.3048
FATHOM = 1.8288

_PREFIX = re.compile(r"[A-Za-z][A-Za-z0-9_]*")
_BEACON = re.compile(r"[A-Za-z0-9_]{1,16}")
_LINE_END = re.compile(rb"[\r\n]")
_LAT = re.compile(r"(\d{2})(\d{2}(?:\.\d+)?)")
_LON = re.compile(r"(\d{3})(\d{2}(?:\.\d+)?)")
_STANDARD = frozenset({"GGA", "RMC", "HDT", "DPT", "DBT"})
"""Talker sentences (handlers take pynmea2's sentence); the others take their fields."""
_RMC_MODE_FIX = {"N": 0, "A": 1, "D": 2, "P": 3, "R": 4, "F": 5, "E": 6, "M": 7, "S": 8}


# ------------------------------------------------------------------------------- settings


class VariablePrefix(Kind):
    """The prefix of an instrument's variables: a letter, then letters, digits or '_';
    upper-cased, as pNav upper-cases its sources."""

    def describe(self) -> str:
        return "a letter then letters, digits or '_' (upper-cased); not " + \
            ", ".join(RESERVED_NAMES)

    def check_value(self, value: Any) -> bool:
        return isinstance(value, str) and bool(_PREFIX.fullmatch(value)) \
            and value == value.upper() and posted_family(value) is None

    def parse(self, entry: Entry) -> str:
        text = entry.value.strip()
        if not _PREFIX.fullmatch(text):
            raise entry.error(f"{entry.key} must be a variable prefix: a letter then letters, "
                              f"digits or '_', got {text!r}")
        name = text.upper()
        family = posted_family(name)
        if family is not None:
            raise entry.error(f"{entry.key} = {text}: {family}_* variables are posted by "
                              f"another app (reserved: {', '.join(RESERVED_NAMES)}); choose "
                              f"another prefix, e.g. S{name}")
        return name


class DevicePath(PathName):
    """A serial device: an absolute path (``/dev/ttyUSB0``, ``/dev/serial/by-id/…``)."""

    def describe(self) -> str:
        return "a device path such as /dev/ttyUSB0"

    def check_value(self, value: Any) -> bool:
        return super().check_value(value) and value.startswith("/") and \
            not any(c.isspace() or c == "," for c in value)

    def parse(self, entry: Entry) -> str:
        text = super().parse(entry)
        if not self.check_value(text):
            raise entry.error(f"{entry.key} expects a device path such as /dev/ttyUSB0 (speed "
                              f"goes in Baud), got {text!r}")
        return text


class BaudRate(Kind):
    """A serial speed the Linux driver knows."""

    def describe(self) -> str:
        return "a standard rate: " + ", ".join(str(b) for b in STANDARD_BAUDS)

    def check_value(self, value: Any) -> bool:
        return value in STANDARD_BAUDS

    def parse(self, entry: Entry) -> int:
        text = entry.value.strip()
        try:
            baud = int(text)
        except ValueError:
            baud = -1
        if baud not in STANDARD_BAUDS:
            raise entry.error(f"{entry.key} must be a standard serial rate (4800 for NMEA 0183, "
                              f"38400 for NMEA 0183-HS, or another of "
                              f"{', '.join(str(b) for b in STANDARD_BAUDS)}), got {text!r}")
        return baud


BAUD = Param("Baud", BaudRate(), 4800, "bit/s", "serial speed (ignored by a pseudo-terminal)")
STALE = Param("Stale", Seconds(hi=3600.0), 5.0, "s", "no valid sentence for this long with "
              "the port open is said once as <Name>_WARNING; NEVER: not watched")

INSTRUMENT_SCHEMA = Schema(BLOCK_NAME, (
    Param("Name", VariablePrefix(), doc="prefix of the instrument's bus variables "
          "(Name = SGPS posts SGPS_X, SGPS_Y, ...): the source name pNav's queues list"),
    Param("Port", DevicePath(), doc="the serial device, e.g. /dev/ttyUSB0; prefer a "
          "/dev/serial/by-id/ path, which survives re-plugging"),
    BAUD,
    Param("Sentences", ChoiceList(Choice(SENTENCES)),
          doc="the sentence types to use; any other well-formed sentence is counted as "
              "dropped (unknown)"),
    STALE,
), moos=APP_PARAMS)
"""Every setting of an ``iSerial`` block, for the reader and for the parameter reference."""

INSTRUMENT_INTRO = ("A serial NMEA instrument (GPS, heading, echo sounder, DVL, range "
                    "beacons); one block per device, named iSerial or iSerial_<label>.")
"""The parameter reference's line about the block."""


def is_instrument_block(name: str) -> bool:
    """Whether a ProcessConfig name is a serial instrument's: ``iSerial``, ``iSerial_<label>``."""
    lowered = name.lower()
    prefix = BLOCK_NAME.lower()
    return lowered == prefix or (lowered.startswith(prefix + "_") and len(lowered) > len(prefix)
                                 + 1)


@dataclass(frozen=True)
class InstrumentConfig:
    """One ``iSerial`` block, read and checked."""

    name: str
    port: str
    sentences: tuple[str, ...]
    baud: int = BAUD.default
    stale: float | None = STALE.default
    process: str = BLOCK_NAME

    @classmethod
    def from_block(cls, block: Block) -> InstrumentConfig:
        settings = INSTRUMENT_SCHEMA.read(block, owner=f"ProcessConfig = {block.name}")
        sentences = settings["sentences"]
        if len(set(sentences)) != len(sentences):
            twice = next(s for s in sentences if sentences.count(s) > 1)
            raise block.require("Sentences").error(f"Sentences lists {twice} twice")
        return cls(process=block.name, **settings)

    @property
    def budget(self) -> int:
        """Bytes parsed per tick at most: a second of the line at Baud, within 4-64 KiB."""
        return max(BUDGET_MIN, min(BUDGET_MAX, self.baud // 10))


# ------------------------------------------------------------------------------ the reader


class _Drop(Exception):
    """A line that is not used, and why (one of DROP_REASONS)."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def _raw(msg: pynmea2.NMEASentence, attr: str) -> str:
    """A field of a standard sentence by pynmea2's name for it, as sent ('' when absent)."""
    index = type(msg).name_to_idx[attr]
    return msg.data[index].strip() if index < len(msg.data) else ""


def _number(text: str, lo: float = -math.inf, hi: float = math.inf) -> float:
    """A finite number in [lo, hi]; anything else is a malformed sentence."""
    try:
        value = float(text)
    except ValueError:
        raise _Drop("malformed") from None
    if not (math.isfinite(value) and lo <= value <= hi):
        raise _Drop("malformed")
    return value


def _optional(text: str, lo: float = -math.inf, hi: float = math.inf) -> float | None:
    return None if text == "" else _number(text, lo, hi)


def _angle(text: str, hemisphere: str, pattern: re.Pattern[str], limit: float,
           signs: str) -> float:
    """``ddmm.mmmm`` / ``dddmm.mmmm`` and its hemisphere → signed degrees, strictly (pynmea2's
    own ``latitude`` reads an empty field or a missing hemisphere as 0°)."""
    match = pattern.fullmatch(text)
    if match is None or hemisphere not in signs:
        raise _Drop("malformed")
    minutes = float(match.group(2))
    value = int(match.group(1)) + minutes / 60.0
    if minutes >= 60.0 or value > limit:
        raise _Drop("malformed")
    return value if hemisphere == signs[0] else -value


class SerialInstrument(App):
    """Reads one serial NMEA instrument each tick and posts what it says (module docstring)."""

    def __init__(self, bus: Bus, config: InstrumentConfig, origin: Origin,
                 transport: Transport | None = None) -> None:
        super().__init__(bus)
        self.name = config.process
        self.config = config
        self.origin = origin
        self.transport: Transport = transport if transport is not None else \
            SerialTransport(config.port, config.baud)
        self.prefix = config.name
        self.accepted = frozenset(config.sentences)
        self.budget = config.budget
        self.is_open = False
        self.stats: dict[str, int] = dict.fromkeys(
            ("bytes", "parsed_bytes", "lines", "sentences", "opens", "failures", "sync",
             "lbl_read_time", *DROP_REASONS), 0)
        self._dropped = 0
        self.last_parsed_bytes = 0
        """Bytes parsed in the last tick (at most ``budget``)."""
        self._buffer = bytearray(DRAIN_CAP)
        self._partial = b""
        self._discarding = False
        self._fresh = False
        self._backoff = Backoff(RETRY_FIRST_S, RETRY_MAX_S)
        self._opened_at = -math.inf
        self._said_down = False
        self._last_valid = 0.0
        self._dropped_at_valid = 0
        self._said_stale = False
        self._said_far = False
        self._said_ping_time = False
        self._posted_dropped = 0
        self._fix_time: str | None = None
        self._dpt_offset = 0.0
        self._handlers: dict[str, Callable[[Any, float], None]] = {
            "GGA": self._gga, "RMC": self._rmc, "HDT": self._hdt, "DPT": self._dpt,
            "DBT": self._dbt, "PMVHDVL": self._dvl, "PMVHLBL": self._lbl,
            "PMVHRNG": self._rng,
        }

    @classmethod
    def from_block(cls, bus: Bus, block: Block, origin: Origin,
                   transport: Transport | None = None) -> SerialInstrument:
        """Build from an ``iSerial`` block; every refusal is a located MissionError. Opens
        nothing: the port is opened on the first tick."""
        return cls(bus, InstrumentConfig.from_block(block), origin, transport)

    @property
    def dropped(self) -> int:
        """Lines dropped for any of ``DROP_REASONS``."""
        return self._dropped

    def _post(self, suffix: str, value: float | str, now: float) -> None:
        self.notify(f"{self.prefix}_{suffix}", value, now)

    # -- the port --------------------------------------------------------------------------

    def _open(self, now: float) -> None:
        if not self._backoff.due(now):
            return
        try:
            self.transport.open()
        except OSError as exc:
            self._fail(now, exc)
            return
        self.is_open = True
        self.stats["opens"] += 1
        self._opened_at = now
        self._said_down = False
        self._partial, self._discarding, self._fresh = b"", False, True
        self._last_valid, self._dropped_at_valid, self._said_stale = now, self.dropped, False
        self._post("OPEN", 1.0, now)

    def _fail(self, now: float, exc: OSError) -> None:
        self.transport.close()
        was_open, self.is_open = self.is_open, False
        self.stats["failures"] += 1
        why = exc.strerror or str(exc)
        if was_open:
            self._post("OPEN", 0.0, now)
            if now - self._opened_at >= self._backoff.max_s:
                self._backoff.succeeded()  # it had worked: try again soon
        if not self._said_down:
            self._said_down = True
            what = f"{self.config.port} lost" if was_open else \
                f"cannot open {self.config.port}"
            self._post("WARNING", f"{what} ({why}); {self._backoff.describe()}", now)
        self._backoff.failed(now)

    def _read(self, now: float) -> bytes:
        """Everything waiting, up to DRAIN_CAP bytes; never blocks (a port that says it
        gave all it held is not asked again)."""
        view = memoryview(self._buffer)
        got = 0
        transport = self.transport
        try:
            while got < DRAIN_CAP:
                n = transport.read_into(view[got:])
                if n <= 0:
                    break
                got += n
                if getattr(transport, "drained", False):
                    break
        except OSError as exc:
            self._fail(now, exc)
        return bytes(view[:got])

    # -- ticking ---------------------------------------------------------------------------

    def iterate(self, now: float) -> None:
        self.last_parsed_bytes = 0
        if not self.is_open:
            self._open(now)
        if self.is_open:
            data = self._read(now)
            if data:
                self.stats["bytes"] += len(data)
                self._feed(data, now)
        if self.is_open:
            self._watch_stale(now)
        if self.dropped != self._posted_dropped:
            self._posted_dropped = self.dropped
            self._post("DROPPED", float(self._posted_dropped), now)
            self._post("DROPS", ",".join(f"{r}={self.stats[r]}" for r in DROP_REASONS
                                         if self.stats[r]), now)

    def close(self) -> None:
        self.transport.close()
        self.is_open = False

    def _watch_stale(self, now: float) -> None:
        stale = self.config.stale
        if stale is None or self._said_stale or now - self._last_valid < stale:
            return
        self._said_stale = True
        lines = self.dropped - self._dropped_at_valid
        if lines:
            drops = ",".join(f"{r}={self.stats[r]}" for r in DROP_REASONS if self.stats[r])
            self._post("WARNING", f"{self.config.port}: {lines} lines dropped and no valid "
                       f"{'/'.join(self.config.sentences)} sentence for {stale:g} s (dropped "
                       f"so far: {drops}): wrong Baud, or wrong Sentences?", now)
        else:
            self._post("WARNING", f"{self.config.port}: silent for {stale:g} s: is the "
                       "instrument powered and wired?", now)

    # -- lines -----------------------------------------------------------------------------

    def _drop(self, reason: str) -> None:
        self.stats[reason] += 1
        self._dropped += 1

    def _feed(self, data: bytes, now: float) -> None:
        """Parse at most ``budget`` bytes, the newest: older complete lines are only counted."""
        waiting = len(self._partial) + len(data)
        if waiting > self.budget:
            joined, self._partial = self._partial + data, b""
            end = _LINE_END.search(joined, waiting - self.budget)
            if end is None:  # no line end in the newest budget bytes: an overlong line
                self._assemble(joined, now, backlog=True)
                return
            self._assemble(joined[:end.start()] + b"\n", now, backlog=True)
            data = joined[end.start():]
        self.last_parsed_bytes = len(self._partial) + len(data)
        self.stats["parsed_bytes"] += self.last_parsed_bytes
        self._assemble(data, now)

    def _assemble(self, data: bytes, now: float, backlog: bool = False) -> None:
        """Split into lines (the bytes after the last line end wait for the next read), drop
        overlong ones, and parse the rest (or, for a ``backlog``, count them as skipped)."""
        segments = _LINE_END.split(self._partial + data)
        self._partial = b""
        tail = segments.pop()
        for segment in segments:
            if self._discarding:
                self._discarding = False  # the end of an overlong line, counted already
                continue
            if not segment.strip():
                continue
            self.stats["lines"] += 1
            if len(segment) > MAX_LINE or backlog:
                self._fresh = False
                self._drop("overlong" if len(segment) > MAX_LINE else "backlog")
                continue
            self._line(segment, now)
        if self._discarding:
            return
        if len(tail) > MAX_LINE:
            self.stats["lines"] += 1
            self._drop("overlong")
            self._discarding = True
        else:
            self._partial = tail

    def _line(self, line: bytes, now: float) -> None:
        """One line: at most one sentence posted, at most one drop counted."""
        fresh, self._fresh = self._fresh, False
        start = line.rfind(b"$")
        try:
            if start < 0:
                raise _Drop("garbage")
            self._sentence(line[start:], now)
        except _Drop as drop:
            if fresh:
                self.stats["sync"] += 1  # the first bytes after opening: mid-sentence
            else:
                self._drop(drop.reason)
            return
        if line[:start].strip() and not fresh:
            self._drop("truncated" if b"$" in line[:start] else "garbage")

    def _sentence(self, raw: bytes, now: float) -> None:
        try:
            text = raw.decode("ascii").strip()
        except UnicodeDecodeError:
            raise _Drop("garbage") from None
        star = text.rfind("*")
        if star < 0:
            raise _Drop("truncated")
        given = text[star + 1:]
        if any(c not in "0123456789ABCDEFabcdef" for c in given) or len(given) > 2:
            raise _Drop("garbage")
        if len(given) < 2:
            raise _Drop("truncated")
        try:
            msg = pynmea2.parse(text, check=True)
        except pynmea2.ChecksumError:
            raise _Drop("checksum") from None
        except pynmea2.SentenceTypeError:
            raise _Drop("unknown") from None
        except pynmea2.ParseError:  # no address pynmea2 can read: not a sentence
            raise _Drop("garbage") from None
        except Exception:  # pynmea2 raises IndexError on some short proprietary sentences
            raise _Drop("malformed") from None
        if isinstance(msg, pynmea2.ProprietarySentence):
            kind = f"P{msg.manufacturer}{msg.data[0] if msg.data else ''}".upper()
            fields = [f.strip() for f in msg.data[1:]]
        elif isinstance(msg, pynmea2.TalkerSentence):
            kind, fields = msg.sentence_type.upper(), []
        else:
            raise _Drop("unknown")
        if kind not in self.accepted:
            raise _Drop("unknown")
        try:
            self._handlers[kind](msg if kind in _STANDARD else fields, now)
        except (ValueError, ArithmeticError, IndexError, TypeError, AttributeError):
            raise _Drop("malformed") from None
        self.stats["sentences"] += 1
        self._last_valid, self._said_stale = now, False
        self._dropped_at_valid = self.dropped

    # -- sentences -------------------------------------------------------------------------

    def _position(self, msg: Any, fix_time: str, now: float) -> None:
        lat = _angle(_raw(msg, "lat"), _raw(msg, "lat_dir"), _LAT, 90.0, "NS")
        lon = _angle(_raw(msg, "lon"), _raw(msg, "lon_dir"), _LON, 180.0, "EW")
        if fix_time and fix_time == self._fix_time:
            return  # GGA and RMC of one fix: posted once
        self._fix_time = fix_time or None
        x, y = self.origin.to_local(lat, lon)
        self._post("X", x, now)
        self._post("Y", y, now)
        self._post("LAT", lat, now)
        self._post("LON", lon, now)
        distance = math.hypot(x, y)
        if distance > FAR_FROM_ORIGIN_M and not self._said_far:
            self._said_far = True
            self._post("WARNING", f"the fix is {distance / 1000:.1f} km from the mission's "
                       "origin (LatOrigin/LongOrigin): wrong mission, or a wrong origin?", now)

    def _gga(self, msg: Any, now: float) -> None:
        quality = int(_number(_raw(msg, "gps_qual"), 0, 8))
        if 1 <= quality <= 5:
            self._position(msg, _raw(msg, "timestamp"), now)
        self._post("FIX", float(quality), now)

    def _rmc(self, msg: Any, now: float) -> None:
        status = _raw(msg, "status")
        if status not in ("A", "V"):
            raise _Drop("malformed")
        mode = _raw(msg, "mode_indicator")[:1] or "A"  # NMEA 2.3 added it; before: A is a fix
        fix = _RMC_MODE_FIX.get(mode, 1) if status == "A" else 0
        if fix:
            speed = _optional(_raw(msg, "spd_over_grnd"), 0.0, 1000.0)
            course = _optional(_raw(msg, "true_course"), 0.0, 360.0)
            self._position(msg, _raw(msg, "timestamp"), now)
            if speed is not None:
                self._post("SPEED", speed * KNOT, now)
            if course is not None:
                course %= 360.0
                self._post("COURSE", course, now)
                if "HDT" not in self.accepted:
                    self._post("HEADING", course, now)
        if "GGA" not in self.accepted:
            self._post("FIX", float(fix), now)

    def _hdt(self, msg: Any, now: float) -> None:
        if _raw(msg, "hdg_true") not in ("T", ""):
            raise _Drop("malformed")
        heading = _number(_raw(msg, "heading"), 0.0, 360.0) % 360.0
        self._post("HEADING", heading, now)
        self._post("YAW", heading_to_yaw(heading), now)

    def _depth(self, below_transducer: float, now: float) -> None:
        self._post("ALTITUDE", below_transducer, now)
        self._post("DEPTH", max(0.0, below_transducer + self._dpt_offset), now)

    def _dpt(self, msg: Any, now: float) -> None:
        depth = _optional(_raw(msg, "depth"), 0.0, 11_000.0)
        offset = _optional(_raw(msg, "offset"), -100.0, 100.0)
        self._dpt_offset = offset or 0.0
        if depth is not None:
            self._depth(depth, now)

    def _dbt(self, msg: Any, now: float) -> None:
        for value, unit, letter, scale in (("depth_meters", "unit_meters", "M", 1.0),
                                           ("depth_feet", "unit_feet", "f", FOOT),
                                           ("depth_fathoms", "unit_fathoms", "F", FATHOM)):
            text = _raw(msg, value)
            if text:
                if _raw(msg, unit) not in (letter, ""):
                    raise _Drop("malformed")
                self._depth(_number(text, 0.0, 36_000.0) * scale, now)
                return

    def _dvl(self, fields: list[str], now: float) -> None:
        if len(fields) < 5 or fields[4] not in ("A", "V"):
            raise _Drop("malformed")
        altitude = _optional(fields[5], 0.0, 11_000.0) if len(fields) > 5 else None
        if fields[4] == "A":
            fwd, stbd, down = (_number(f, -50.0, 50.0) for f in fields[1:4])
            self._post("VX_BODY", fwd, now)
            self._post("VY_BODY", stbd, now)
            self._post("VZ_BODY", down, now)
        if altitude is not None:
            self._post("ALTITUDE", altitude, now)

    def _lbl(self, fields: list[str], now: float) -> None:
        if not fields or len(fields) % 2 != 1:
            raise _Drop("malformed")
        replies = []
        for beacon, twtt in zip(fields[1::2], fields[2::2], strict=True):
            if not _BEACON.fullmatch(beacon):
                raise _Drop("malformed")
            replies.append((beacon, _optional(twtt, 0.0, 60.0)))
        stamp = self._ping_time(fields[0], now)
        for beacon, travel in replies:
            if travel is not None:
                self._post(f"TWTT_{beacon}", travel, stamp)

    def _ping_time(self, text: str, now: float) -> float:
        """The LBL ping time t0 when it is a time on our clock within LBL_MAX_AGE_S before now;
        otherwise ``now``, counted and said once (until a good one re-arms the warning)."""
        try:
            ping = float(text)
        except ValueError:
            ping = math.nan
        if math.isfinite(ping) and now - LBL_MAX_AGE_S <= ping <= now:
            self._said_ping_time = False
            return ping
        self.stats["lbl_read_time"] += 1
        if not self._said_ping_time:
            self._said_ping_time = True
            self._post("WARNING", f"$PMVHLBL ping time t0={text or '(empty)'} is not within "
                       f"{LBL_MAX_AGE_S:g} s before now ({now:.3f}): travel times stamped with "
                       "the time they were read instead; is the instrument on the companion's "
                       "clock?", now)
        return now

    def _rng(self, fields: list[str], now: float) -> None:
        if len(fields) < 3 or not _BEACON.fullmatch(fields[1]):
            raise _Drop("malformed")
        self._post(f"RANGE_{fields[1]}", _number(fields[2], 0.0, 100_000.0), now)


# ------------------------------------------------------------------------- many of them


def instrument_blocks(mission: Mission) -> list[Block]:
    """The mission's ``iSerial`` / ``iSerial_<label>`` blocks, in file order."""
    return [b for name, b in mission.processes.items() if is_instrument_block(name)]


def instruments_from_mission(bus: Bus, mission: Mission, origin: Origin,
                             transport: Callable[[InstrumentConfig], Transport] | None = None,
                             ) -> list[SerialInstrument]:
    """One reader per ``iSerial`` block; two blocks may not share a Name or a Port (the second
    is refused at its line). ``transport`` builds a port for a config (tests)."""
    apps: list[SerialInstrument] = []
    names: dict[str, Block] = {}
    ports: dict[str, Block] = {}
    for block in instrument_blocks(mission):
        config = InstrumentConfig.from_block(block)
        other = names.get(config.name)
        if other is not None:
            raise block.require("Name").error(
                f"Name {config.name} is already used by ProcessConfig = {other.name} at line "
                f"{other.line}: each instrument needs its own prefix")
        for key in {config.port, os.path.realpath(config.port)}:
            other = ports.get(key)
            if other is not None:
                raise block.require("Port").error(
                    f"Port {config.port} is already read by ProcessConfig = {other.name} at "
                    f"line {other.line}: one reader per device")
        names[config.name] = block
        ports[config.port] = ports[os.path.realpath(config.port)] = block
        apps.append(SerialInstrument(bus, config, origin,
                                     transport(config) if transport is not None else None))
    return apps
