"""Serial instruments (``iSerial`` blocks): NMEA lines in, ``<Name>_*`` bus variables out.

Unit tests feed bytes through a fake port (every sentence kind, checksums, garbage, a 2 KiB
line, truncation, a flood, a vanishing port on a simulated clock, every refusal of the block at
``file:line``). Then real pseudo-terminals: a device behind a symlink that disappears and comes
back, a flood the kernel buffers, and the real ``mavhelm sim --sensors`` read as a boat would.
The sentences come from the simulator's own encoders (``mavhelm.sitl.nmea``), so the reader is
pinned against exactly what the simulated instruments send.
"""

from __future__ import annotations

import contextlib
import math
import os
import time
import tty
from dataclasses import dataclass, field

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mavhelm.companion.link import SerialTransport
from mavhelm.companion.serial_instruments import (
    BUDGET_MIN,
    DROP_REASONS,
    INSTRUMENT_SCHEMA,
    MAX_LINE,
    InstrumentConfig,
    SerialInstrument,
    instruments_from_mission,
    is_instrument_block,
)
from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock
from mavhelm.core.geodesy import Origin
from mavhelm.core.mission import Block, Entry, MissionError, parse_mission
from mavhelm.sitl import nmea
from tests.support.nmea_read import read_sentence
from tests.support.waiting import wait_for

ORIGIN = Origin(50.1, -4.2)
T0 = 1000.0
ALL = "GGA,RMC,HDT,DPT,DBT,PMVHDVL,PMVHLBL,PMVHRNG"


@dataclass
class FakePort:
    """A link.Transport fed by the test: ``read_into`` hands out at most ``chunk`` bytes per
    call; ``open_error``/``read_error`` make the next open/read raise, as pyserial's do."""

    chunk: int = 1 << 30
    pending: bytearray = field(default_factory=bytearray)
    opened: bool = False
    open_error: OSError | None = None
    read_error: OSError | None = None
    opens: list[float] = field(default_factory=list)
    clock: SimClock | None = None

    def feed(self, data: bytes | str) -> None:
        self.pending += data.encode("ascii") if isinstance(data, str) else data

    def open(self) -> None:
        self.opens.append(self.clock.now() if self.clock else 0.0)
        if self.open_error is not None:
            raise self.open_error
        self.opened = True

    def ready(self) -> bool:
        return self.opened

    def read_into(self, buffer: memoryview) -> int:
        assert self.opened
        if self.read_error is not None:
            raise self.read_error
        n = min(len(buffer), len(self.pending), self.chunk)
        buffer[:n] = self.pending[:n]
        del self.pending[:n]
        return n

    def write(self, data: bytes) -> int:
        return 0

    def close(self) -> None:
        self.opened = False

    def fileno(self) -> int | None:
        return None


def block(*pairs: tuple[str, str], name: str = "iSerial_GPS", file: str = "t.moos",
          line: int = 10) -> Block:
    """A ProcessConfig block at file:line with its entries on the following lines."""
    entries = [Entry(k, v, file, line + 2 + i) for i, (k, v) in enumerate(pairs)]
    return Block("ProcessConfig", name, file, line, entries)


class Rig:
    """One reader on a fake port, the bus it posts on, and a simulated clock."""

    def __init__(self, sentences: str = ALL, name: str = "S", stale: str | None = None,
                 chunk: int = 1 << 30, baud: str | None = None) -> None:
        pairs = [("Name", name), ("Port", "/dev/ttyFAKE0"), ("Sentences", sentences)]
        if stale is not None:
            pairs.append(("Stale", stale))
        if baud is not None:
            pairs.append(("Baud", baud))
        self.clock = SimClock(T0)
        self.bus = Bus(self.clock)
        self.bus.subscribe("test", ["*"])
        self.port = FakePort(chunk=chunk, clock=self.clock)
        self.app = SerialInstrument.from_block(self.bus, block(*pairs), ORIGIN, self.port)
        self.mail: list[Message] = []
        self.tick()  # opens the port; what it reads first starts mid-sentence:
        self.feed("9.1,T*2B")
        self.tick()
        assert self.app.stats["sync"] == 1 and self.app.dropped == 0

    def feed(self, *lines: str | bytes, eol: bytes = b"\r\n") -> None:
        for line in lines:
            self.port.feed((line.encode("ascii") if isinstance(line, str) else line) + eol)

    def tick(self, dt: float = 0.0) -> list[Message]:
        self.clock.advance(dt)
        self.app.iterate(self.clock.now())
        new = self.bus.fetch("test")
        self.mail += new
        return new

    def values(self, mail: list[Message] | None = None) -> dict[str, float | str]:
        return {m.name: m.value for m in (self.mail if mail is None else mail)}

    def posted(self, name: str) -> list[float | str]:
        return [m.value for m in self.mail if m.name == name]

    def drops(self) -> dict[str, int]:
        return {r: self.app.stats[r] for r in DROP_REASONS if self.app.stats[r]}


def corrupt_checksum(sentence: str) -> str:
    good = sentence[-2:]
    return sentence[:-2] + f"{int(good, 16) ^ 0x5A:02X}"


# ----------------------------------------------------------------------- every sentence kind


def test_gga_and_rmc_give_the_local_position_once_per_fix_speed_and_course() -> None:
    rig = Rig("GGA,RMC")
    lat, lon = ORIGIN.to_global(30.0, -40.0)
    utc = 1_767_225_600.0 + 12.5
    rig.feed(nmea.gga(utc, lat, lon, talker="GN"), nmea.rmc(utc, lat, lon, 2.0, 123.4))
    mail = rig.tick(0.1)
    v = rig.values(mail)
    assert v["S_X"] == pytest.approx(30.0, abs=0.01) and v["S_Y"] == pytest.approx(-40.0, abs=0.01)
    assert v["S_LAT"] == pytest.approx(lat, abs=1e-7) and v["S_LON"] == pytest.approx(lon, abs=1e-7)
    assert v["S_FIX"] == 1.0
    assert v["S_SPEED"] == pytest.approx(2.0, abs=0.003)  # 3.89 knots, 2 decimals
    assert v["S_COURSE"] == pytest.approx(123.4) and v["S_HEADING"] == pytest.approx(123.4)
    assert rig.posted("S_X") == [v["S_X"]], "GGA and RMC of one fix: the position posted once"
    assert all(m.time == T0 + 0.1 for m in mail), "stamped with the tick that read them"
    assert all(m.source == "iSerial_GPS" for m in mail)
    rig.feed(nmea.rmc(utc + 1.0, lat, lon, 2.0, 123.4))  # a new fix time: posted again
    rig.tick(1.0)
    assert len(rig.posted("S_X")) == 2 and rig.drops() == {}


def test_no_fix_posts_fix_zero_and_no_position() -> None:
    rig = Rig("GGA,RMC")
    rig.feed(nmea.gga(T0, None, None, satellites=0), nmea.rmc(T0, None, None))
    rig.tick(0.1)
    assert rig.posted("S_FIX") == [0.0]
    assert not rig.posted("S_X") and not rig.posted("S_SPEED") and rig.drops() == {}
    rmc_only = Rig("RMC")  # FIX then comes from RMC: status V → 0, mode D → 2
    address, fields = read_sentence(nmea.rmc(T0 + 1, *ORIGIN.to_global(1.0, 2.0), 1.0, 10))
    fields[-1] = "D"
    rmc_only.feed(nmea.rmc(T0, None, None), nmea.sentence(address, fields))
    rmc_only.tick(0.1)
    assert rmc_only.posted("S_FIX") == [0.0, 2.0]
    assert rmc_only.values()["S_X"] == pytest.approx(1.0, abs=0.01)


def test_hdt_gives_heading_and_yaw_and_wins_over_the_rmc_course() -> None:
    rig = Rig("RMC,HDT")
    lat, lon = ORIGIN.to_global(0.0, 0.0)
    rig.feed(nmea.hdt(60.2), nmea.rmc(T0, lat, lon, 1.0, 75.0), nmea.hdt(350.0, talker="HC"))
    rig.tick(0.1)
    assert rig.posted("S_HEADING") == [pytest.approx(60.2), pytest.approx(350.0)]
    assert rig.posted("S_YAW") == [pytest.approx(-math.radians(60.2)),
                                   pytest.approx(math.radians(10.0))]
    assert rig.posted("S_COURSE") == [pytest.approx(75.0)], "RMC's course is COURSE only"


def test_dpt_and_dbt_give_depth_with_the_dpt_offset_and_altitude_below_the_transducer() -> None:
    rig = Rig("DPT,DBT")
    rig.feed(nmea.dbt(10.0))  # before any DPT: no offset known
    rig.tick(0.1)
    assert rig.values()["S_DEPTH"] == pytest.approx(10.0)
    rig.feed(nmea.dpt(17.87, 0.3, 100.0), nmea.dbt(17.87))
    new = rig.tick(0.5)
    assert [m.value for m in new if m.name == "S_ALTITUDE"] == [pytest.approx(17.87)] * 2
    assert [m.value for m in new if m.name == "S_DEPTH"] == [pytest.approx(18.17)] * 2
    rig.feed(nmea.dpt(5.0, -1.2))  # negative: transducer to keel → water under the keel
    assert rig.values(rig.tick(0.5))["S_DEPTH"] == pytest.approx(3.8)
    rig.feed(nmea.sentence("SDDBT", ["32.8", "f", "", "M", "", "F"]))  # feet only
    assert rig.values(rig.tick(0.5))["S_ALTITUDE"] == pytest.approx(32.8 * 0.3048)
    rig.feed(nmea.dpt(None, 0.3), nmea.dbt(None))  # bottom lost: nothing, and nothing dropped
    assert not [m for m in rig.tick(0.5) if m.name.startswith("S_")]
    assert rig.drops() == {}


def test_dvl_lbl_and_ranges() -> None:
    rig = Rig("PMVHDVL,PMVHLBL,PMVHRNG", name="ac")
    rig.feed(nmea.pmvhdvl(12.2, 1.501, -0.016, 0.004, 17.66),
             nmea.pmvhlbl(T0 - 3.0, [("1", 0.301211), ("2", None), ("B3", 0.5)]),
             nmea.pmvhrng(12.5, "2", 204.566))
    mail = rig.tick(0.1)
    v = rig.values(mail)
    assert (v["AC_VX_BODY"], v["AC_VY_BODY"], v["AC_VZ_BODY"]) == (1.501, -0.016, 0.004)
    assert v["AC_ALTITUDE"] == 17.66
    assert v["AC_TWTT_1"] == 0.301211 and v["AC_TWTT_B3"] == 0.5 and "AC_TWTT_2" not in v
    assert v["AC_RANGE_2"] == 204.566
    stamps = {m.name: m.time for m in mail}
    assert stamps["AC_TWTT_1"] == stamps["AC_TWTT_B3"] == T0 - 3.0  # the ping, not the read
    assert stamps["AC_RANGE_2"] == stamps["AC_VX_BODY"] == T0 + 0.1
    assert "AC_WARNING" not in v and rig.app.stats["lbl_read_time"] == 0
    rig.feed(nmea.pmvhdvl(12.4, None, None, None, None))  # no bottom lock: no velocity
    assert not [m for m in rig.tick(0.1) if m.name.startswith("AC_V")]
    assert rig.drops() == {} and rig.app.stats["sentences"] == 4


def test_an_lbl_ping_time_off_our_clock_is_not_trusted_counted_and_said_once() -> None:
    rig = Rig("PMVHLBL", name="lbl")
    now = T0 + 1.0
    rig.feed(nmea.pmvhlbl(now + 0.5, [("1", 0.3)]),  # from the future
             nmea.pmvhlbl(now - 30.5, [("1", 0.3)]))  # older than 30 s
    mail = rig.tick(1.0)
    assert [m.time for m in mail if m.name == "LBL_TWTT_1"] == [now, now]
    warnings = [m.value for m in mail if m.name == "LBL_WARNING"]
    assert len(warnings) == 1 and f"t0={now + 0.5:.3f}" in warnings[0]
    assert rig.app.stats["lbl_read_time"] == 2
    rig.feed(nmea.pmvhlbl(now - 30.0, [("1", 0.3)]))  # exactly 30 s old: trusted, re-arms
    mail = rig.tick(0.0)
    assert [m.time for m in mail if m.name == "LBL_TWTT_1"] == [now - 30.0]
    assert not [m for m in mail if m.name == "LBL_WARNING"]
    rig.feed(nmea.sentence("PMVHLBL", ["", "1", "0.300000"]),  # no t0, and t0 "nan"
             nmea.pmvhlbl(math.nan, [("2", 0.4)]))
    mail = rig.tick(0.5)
    assert [(m.name, m.time) for m in mail if m.name.startswith("LBL_TWTT")] == \
        [("LBL_TWTT_1", now + 0.5), ("LBL_TWTT_2", now + 0.5)]
    warnings = [m.value for m in mail if m.name == "LBL_WARNING"]
    assert len(warnings) == 1 and "t0=(empty)" in warnings[0]
    assert rig.app.stats["lbl_read_time"] == 4 and rig.app.stats["sentences"] == 5
    assert rig.drops() == {}


def test_doc_examples_parse_and_a_lower_case_checksum_is_accepted() -> None:
    rig = Rig()
    examples = [
        "$GPGGA,000000.00,5021.600688,N,00408.400257,W,1,10,0.90,0.0,M,0.0,M,,*78",
        "$GPRMC,000000.00,A,5021.600688,N,00408.400257,W,2.77,60.0,010126,,,A*42",
        "$HEHDT,60.2,T*1b", "$SDDPT,17.87,0.30,100.0*6E", "$SDDBT,58.6,f,17.87,M,9.8,F*35",
        "$PMVHDVL,0.200,1.501,0.016,0.016,A,17.66*33", "$PMVHLBL,0.000,1,0.301211,2,0.518620*48",
        "$PMVHRNG,0.500,2,204.566*40",
    ]
    rig.feed(*examples)
    v = rig.values(rig.tick(0.1))
    assert rig.app.stats["sentences"] == len(examples) and rig.drops() == {}
    assert v["S_LAT"] == pytest.approx(50 + 21.600688 / 60)
    assert v["S_LON"] == pytest.approx(-(4 + 8.400257 / 60))


# ------------------------------------------------------------------------------- what is dropped


def test_bad_checksums_are_counted_and_the_good_lines_around_them_kept() -> None:
    rig = Rig()
    lat, lon = ORIGIN.to_global(5.0, 5.0)
    good = [nmea.gga(T0, lat, lon), nmea.hdt(10.0), nmea.dpt(3.0, 0.0),
            nmea.pmvhdvl(1.0, 0.1, 0.2, 0.3, 4.0), nmea.pmvhrng(1.0, "1", 9.0)]
    for sentence in good:
        rig.feed(corrupt_checksum(sentence), sentence)
    rig.tick(0.1)
    assert rig.drops() == {"checksum": len(good)}
    assert rig.app.stats["sentences"] == len(good)
    assert rig.values()["S_HEADING"] == 10.0


def test_garbage_is_counted_and_a_sentence_after_it_is_salvaged() -> None:
    rig = Rig("HDT")
    rig.feed(b"\x00\xff\xfe binary noise", b"NO DOLLAR HERE*12", "$HEHDT,1.0,T*2C junk",
             nmea.sentence("HE\x07HDT", ["1.0", "T"]),  # no address: not a sentence
             b"\xfe\x01" + nmea.hdt(20.0).encode(),  # junk before a whole sentence
             "$HEH\xe9DT,1.0,T*00".encode("latin-1"), nmea.hdt(30.0))
    rig.tick(0.1)
    assert rig.drops() == {"garbage": 6}
    assert rig.posted("S_HEADING") == [20.0, 30.0]
    assert rig.posted("S_DROPPED") == [6.0] and rig.posted("S_DROPS") == ["garbage=6"]


def test_a_2_kib_line_is_dropped_once_and_the_next_line_read() -> None:
    rig = Rig("HDT", chunk=100)  # arrives 100 bytes a read, over several ticks
    rig.feed(b"$HEHDT," + b"1" * 2048, nmea.hdt(42.0))
    for _ in range(4):
        rig.tick(0.1)
    assert rig.drops() == {"overlong": 1} and rig.posted("S_HEADING") == [42.0]
    rig.feed(b"$" + b"9" * (MAX_LINE + 10))  # a complete overlong line in one read
    rig.feed(nmea.hdt(43.0))
    rig.tick(0.1)
    assert rig.drops() == {"overlong": 2} and rig.posted("S_HEADING") == [42.0, 43.0]
    assert len(rig.app._partial) <= MAX_LINE


def test_truncated_sentences_are_counted() -> None:
    rig = Rig("GGA,HDT")
    gga = nmea.gga(T0, *ORIGIN.to_global(1.0, 1.0))
    rig.feed(gga[: gga.index("*")],  # cut before the checksum (the simulator's truncation)
             gga[:-1],  # one checksum digit lost
             gga[:20] + nmea.hdt(7.0))  # cut by the next sentence: that one is kept
    rig.tick(0.1)
    assert rig.drops() == {"truncated": 3} and rig.posted("S_HEADING") == [7.0]
    assert not rig.posted("S_X")


def test_unknown_and_unaccepted_types_and_malformed_fields_are_counted() -> None:
    rig = Rig("GGA,HDT,PMVHDVL")
    rig.feed("$GPGSV,1,1,00*79",  # a type pynmea2 knows but Sentences does not list
             nmea.sentence("GPXYZ", ["1"]),  # a type nobody knows
             nmea.sentence("PGRME", ["1", "M"]),  # another maker's proprietary sentence
             nmea.dpt(3.0, 0.0))  # a type the reader knows, not asked for here
    rig.tick(0.1)
    assert rig.drops() == {"unknown": 4}
    bad = [nmea.sentence("HEHDT", ["400.0", "T"]), nmea.sentence("HEHDT", ["nan", "T"]),
           nmea.sentence("HEHDT", ["", "T"]), nmea.sentence("HEHDT", ["1.0", "M"]),
           nmea.sentence("GPGGA", ["000000.00", "5099.0", "N", "00400.0", "W", "1"]),
           nmea.sentence("GPGGA", ["000000.00", "", "", "", "", "1"]),  # fix without position
           nmea.sentence("GPGGA", ["000000.00", "5000.0", "X", "00400.0", "W", "1"]),
           nmea.sentence("PMVHDVL", ["1.0", "0.1", "0.1", "0.1", "X", ""]),
           nmea.sentence("PMVHDVL", ["1.0", "inf", "0.1", "0.1", "A", ""]),
           nmea.sentence("PMVHDVL", ["1.0"]),
           "$PUBX*1F", "$PTNL*06"]  # pynmea2 itself fails on these (IndexError)
    rig.feed(*bad)
    rig.tick(0.1)
    assert rig.drops() == {"unknown": 4, "malformed": len(bad)}
    assert rig.app.stats["sentences"] == 0 and not rig.posted("S_X")
    assert rig.posted("S_DROPPED") == [4.0, 16.0], "posted when it changes, once a tick"
    rig.tick(0.1)
    assert rig.posted("S_DROPPED") == [4.0, 16.0]
    assert rig.posted("S_DROPS")[-1] == "malformed=12,unknown=4"


@settings(max_examples=60, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow])
@given(junk=st.lists(st.binary(max_size=200), min_size=1, max_size=12),
       chunk=st.integers(1, 97), per_tick=st.integers(1, 5))
def test_every_good_sentence_survives_any_junk_before_it(junk, chunk, per_tick) -> None:
    """Whatever bytes come before a sentence on its line (line ends, '$', '*', binary), the
    sentence is read, in order, however the bytes are split across reads and ticks."""
    rig = Rig("HDT", chunk=chunk)
    headings = [float(k) for k in range(len(junk))]
    for j, h in zip(junk, headings, strict=True):
        rig.port.feed(j + nmea.hdt(h).encode() + b"\r\n")
    for _ in range(10_000):
        if not rig.port.pending:
            break
        for _ in range(per_tick):
            rig.tick(0.01)
    rig.tick(0.01)
    assert rig.posted("S_HEADING") == headings
    assert rig.app._partial == b"" and not rig.app._discarding


def test_lines_split_across_reads_and_bare_cr_or_lf_endings() -> None:
    rig = Rig("HDT", chunk=3)
    rig.feed(nmea.hdt(1.0), eol=b"\r")
    rig.feed(nmea.hdt(2.0), eol=b"\n")
    rig.feed(nmea.hdt(3.0), eol=b"\r\n\r\n")
    for _ in range(40):
        rig.tick(0.1)
    assert rig.posted("S_HEADING") == [1.0, 2.0, 3.0] and rig.drops() == {}


def test_the_fragment_read_after_opening_is_not_counted() -> None:
    clock = SimClock(T0)
    bus = Bus(clock)
    port = FakePort()
    app = SerialInstrument.from_block(bus, block(("Name", "S"), ("Port", "/dev/x"),
                                                 ("Sentences", "HDT")), ORIGIN, port)
    app.iterate(T0)
    port.feed(nmea.hdt(5.0)[9:] + "\r\n" + nmea.hdt(6.0) + "\r\n")  # opened mid-sentence
    app.iterate(T0 + 0.1)
    assert app.dropped == 0 and app.stats["sync"] == 1
    assert bus.latest("S_HEADING").value == 6.0
    port.feed(nmea.hdt(5.0)[9:] + "\r\n")  # the same later is damage
    app.iterate(T0 + 0.2)
    assert app.stats["truncated"] == 0 and app.stats["garbage"] == 1


def test_far_from_the_origin_is_said_once() -> None:
    rig = Rig("GGA")
    for k in range(3):
        rig.feed(nmea.gga(T0 + k, *ORIGIN.to_global(8000.0, 0.0)))
        rig.tick(1.0)
    warnings = rig.posted("S_WARNING")
    assert len(warnings) == 1 and "8.0 km from the mission's origin" in warnings[0]


# ------------------------------------------------------------------------- the port and time


def test_a_vanished_port_is_said_once_and_reopened_with_backoff() -> None:
    rig = Rig("HDT", stale="NEVER")
    t_lost = rig.clock.now() + 10.0  # open for 10 s: the backoff starts again at 1 s
    rig.clock.set(t_lost)
    rig.port.read_error = OSError(5, "serial device failed: Input/output error")
    rig.port.open_error = OSError(2, "could not open port /dev/ttyFAKE0: No such file")
    rig.tick()
    assert rig.posted("S_OPEN") == [1.0, 0.0]
    assert rig.posted("S_WARNING") == ["/dev/ttyFAKE0 lost (serial device failed: Input/output "
                                       "error); retrying every 1-8 s"]
    rig.port.opens.clear()
    while rig.clock.now() < t_lost + 30.0:
        rig.tick(0.125)  # exact in binary: the retry times land on ticks
    attempts = [t - t_lost for t in rig.port.opens]
    assert attempts == [1.0, 3.0, 7.0, 15.0, 23.0], "1 s doubling to 8 s"
    assert len(rig.posted("S_WARNING")) == 1, "said once per outage"
    rig.port.open_error = rig.port.read_error = None
    while rig.port.opened is False:
        rig.tick(0.125)
    assert rig.clock.now() - t_lost == 31.0
    assert rig.posted("S_OPEN") == [1.0, 0.0, 1.0]
    rig.feed("", nmea.hdt(77.0))
    rig.tick(0.1)
    assert rig.posted("S_HEADING")[-1] == 77.0 and len(rig.posted("S_WARNING")) == 1


def test_a_port_that_cannot_be_opened_is_said_once_and_a_flapping_one_backs_off() -> None:
    clock = SimClock(T0)
    bus = Bus(clock)
    bus.subscribe("test", ["*"])
    port = FakePort(open_error=OSError(2, "no such device"), clock=clock)
    app = SerialInstrument(bus, InstrumentConfig("S", "/dev/x", ("HDT",)), ORIGIN, port)
    for _ in range(100):
        app.iterate(clock.now())
        clock.advance(0.1)
    warnings = [m.value for m in bus.fetch("test") if m.name == "S_WARNING"]
    assert warnings == ["cannot open /dev/x (no such device); retrying every 1-8 s"]
    assert [round(t - T0, 1) for t in port.opens] == [0.0, 1.0, 3.0, 7.0]
    port.open_error = None
    port.opens.clear()
    for _ in range(300):  # opens, fails at once, again and again: not every second
        app.iterate(clock.now())
        port.read_error = OSError(5, "gone") if port.opened else None
        clock.advance(0.1)
    gaps = [round(b - a, 1) for a, b in zip(port.opens, port.opens[1:], strict=False)]
    assert gaps and all(g >= 8.0 for g in gaps[1:]), gaps


def test_stale_is_said_once_with_a_hint_when_bytes_arrive_but_nothing_valid() -> None:
    rig = Rig("HDT", stale="2")
    for _ in range(30):
        rig.tick(0.1)
    assert rig.posted("S_WARNING") == ["/dev/ttyFAKE0: silent for 2 s: is the instrument "
                                       "powered and wired?"]
    rig.feed(nmea.hdt(1.0))  # data again: re-armed
    rig.tick(0.1)
    for _ in range(30):
        rig.feed(b"\x13\x37 wrong baud \xf0")
        rig.tick(0.1)
    warnings = rig.posted("S_WARNING")
    assert len(warnings) == 2 and "lines dropped and no valid HDT sentence for 2 s" in warnings[1]
    assert "dropped so far: garbage=" in warnings[1] and warnings[1].endswith(
        "wrong Baud, or wrong Sentences?")


def test_a_flood_is_parsed_within_the_budget_newest_first() -> None:
    rig = Rig("HDT")
    assert rig.app.budget == BUDGET_MIN  # 4800 bit/s: 480 B/s, so the 4 KiB floor
    lines = [nmea.hdt(k % 360) for k in range(20_000)] + [nmea.hdt(123.4)]
    rig.feed(*lines)  # ~330 KiB waiting
    start = time.perf_counter()
    rig.tick(0.1)
    took = time.perf_counter() - start
    assert rig.app.last_parsed_bytes <= rig.app.budget
    assert rig.app.stats["backlog"] > 0 and took < 0.25, took
    for _ in range(3):
        rig.tick(0.1)
        assert rig.app.last_parsed_bytes <= rig.app.budget
    assert rig.posted("S_HEADING")[-1] == 123.4, "the newest line is read within a few ticks"
    st = rig.app.stats
    assert st["sentences"] + st["backlog"] == len(lines) and rig.drops().keys() == {"backlog"}
    fast = Rig("HDT", baud="115200")
    assert fast.app.budget == 11520


# --------------------------------------------------------------------------------- the block


@pytest.mark.parametrize("pairs, reason", [
    ((("Name", "S"), ("Port", "/dev/x"), ("Sentences", "GGA"), ("Prot", "/dev/y")),
     "t.moos:15: unknown setting 'Prot' for iSerial (did you mean Port? known: Name, Port, "
     "Baud, Sentences, Stale)"),
    ((("Port", "/dev/x"), ("Sentences", "GGA")),
     "t.moos:10: ProcessConfig = iSerial_GPS needs Name (a letter then letters, digits or '_' "
     "(upper-cased); not GPS, INS, AP, NAV, DESIRED, HELM, MAVLINK, TASK, EKF, LSQ, WHEEL, "
     "TRUTH, NAVIGATION, MISSION, THIRDPARTY, RESTART)"),
    ((("Name", "S"), ("Sentences", "GGA")),
     "t.moos:10: ProcessConfig = iSerial_GPS needs Port (a device path such as /dev/ttyUSB0)"),
    ((("Name", "S"), ("Port", "/dev/x")),
     "t.moos:10: ProcessConfig = iSerial_GPS needs Sentences (comma-separated, each one of "
     "GGA, RMC, HDT, DPT, DBT, PMVHDVL, PMVHLBL, PMVHRNG)"),
    ((("Name", "gps"), ("Port", "/dev/x"), ("Sentences", "GGA")),
     "t.moos:12: Name = gps: GPS_* variables are posted by another app (reserved: GPS, INS, "
     "AP, NAV, DESIRED, HELM, MAVLINK, TASK, EKF, LSQ, WHEEL, TRUTH, NAVIGATION, MISSION, "
     "THIRDPARTY, RESTART); choose another prefix, e.g. SGPS"),
    ((("Name", "S-GPS"), ("Port", "/dev/x"), ("Sentences", "GGA")),
     "t.moos:12: Name must be a variable prefix: a letter then letters, digits or '_', "
     "got 'S-GPS'"),
    ((("Name", "S"), ("Port", "/dev/x,4800"), ("Sentences", "GGA")),
     "t.moos:13: Port expects a device path such as /dev/ttyUSB0 (speed goes in Baud), got "
     "'/dev/x,4800'"),
    ((("Name", "S"), ("Port", "tcp:127.0.0.1:10110"), ("Sentences", "GGA")),
     "t.moos:13: Port expects a device path such as /dev/ttyUSB0 (speed goes in Baud), got "
     "'tcp:127.0.0.1:10110'"),
    ((("Name", "S"), ("Port", "/dev/x"), ("Sentences", "GGA"), ("Baud", "4600")),
     "t.moos:15: Baud must be a standard serial rate (4800 for NMEA 0183, 38400 for NMEA "
     "0183-HS, or another of 300, 600, 1200, 1800, 2400, 4800, 9600, 19200, 38400, 57600, "
     "115200, 230400, 460800, 500000, 576000, 921600, 1000000, 1152000, 1500000, 2000000, "
     "2500000, 3000000, 3500000, 4000000), got '4600'"),
    ((("Name", "S"), ("Port", "/dev/x"), ("Sentences", "GGA,GSV")),
     "t.moos:14: Sentences expects one of GGA, RMC, HDT, DPT, DBT, PMVHDVL, PMVHLBL, PMVHRNG, "
     "got 'GSV'"),
    ((("Name", "S"), ("Port", "/dev/x"), ("Sentences", "GGA,,RMC")),
     "t.moos:14: Sentences expects a comma-separated list, each one of GGA, RMC, HDT, DPT, "
     "DBT, PMVHDVL, PMVHLBL, PMVHRNG, got 'GGA,,RMC'"),
    ((("Name", "S"), ("Port", "/dev/x"), ("Sentences", "GGA, rmc ,gga")),
     "t.moos:14: Sentences lists GGA twice"),
    ((("Name", "S"), ("Port", "/dev/x"), ("Sentences", "GGA"), ("Stale", "0")),
     "t.moos:15: Stale must be a number in (0, 3600], got 0"),
    ((("Name", "S"), ("Port", "/dev/x"), ("Sentences", "GGA"), ("Stale", "nan")),
     "t.moos:15: Stale must be a finite number, got 'nan'"),
    ((("Name", "S"), ("Port", "/dev/x"), ("Sentences", "GGA"), ("port", "/dev/y")),
     "t.moos:15: port is already set at line 13; give each setting once"),
])
def test_the_block_refuses_at_file_and_line(pairs, reason) -> None:
    with pytest.raises(MissionError) as err:
        SerialInstrument.from_block(Bus(SimClock()), block(*pairs), ORIGIN, FakePort())
    assert str(err.value) == reason


def test_the_block_reads_every_setting_and_opens_nothing() -> None:
    config = InstrumentConfig.from_block(block(
        ("name", "sgps"), ("PORT", "/dev/serial/by-id/usb-gps"), ("Sentences", "gga, rmc"),
        ("Baud", "38400"), ("Stale", "NEVER")))
    assert config == InstrumentConfig("SGPS", "/dev/serial/by-id/usb-gps", ("GGA", "RMC"),
                                      38400, None, "iSerial_GPS")
    defaults = InstrumentConfig.from_block(block(("Name", "X1"), ("Port", "/dev/x"),
                                                 ("Sentences", "HDT")))
    assert (defaults.baud, defaults.stale) == (4800, 5.0)
    for p in INSTRUMENT_SCHEMA.params:
        assert p.required or p.accepts(p.default), p.name
    app = SerialInstrument(Bus(SimClock()), config, ORIGIN)  # a real SerialTransport
    assert isinstance(app.transport, SerialTransport) and app.transport.port is None
    assert app.name == "iSerial_GPS"
    assert "### ProcessConfig = iSerial" in INSTRUMENT_SCHEMA.reference("ProcessConfig = iSerial")


def test_several_instruments_from_a_mission_and_their_clashes() -> None:
    text = """LatOrigin = 50.1
LongOrigin = -4.2
ProcessConfig = iSerial_GPS
{
  Name      = SGPS
  Port      = /dev/ttyUSB0
  Sentences = GGA,RMC
}
ProcessConfig = iSerial_Sounder
{
  Name      = SND
  Port      = /dev/ttyUSB1
  Sentences = DPT,DBT
}
ProcessConfig = pNav
{
  X = SGPS @ 2
}
"""
    apps = instruments_from_mission(Bus(SimClock()), parse_mission(text, "m.moos"), ORIGIN,
                                    transport=lambda config: FakePort())
    assert [(a.name, a.prefix, a.config.port) for a in apps] == [
        ("iSerial_GPS", "SGPS", "/dev/ttyUSB0"), ("iSerial_Sounder", "SND", "/dev/ttyUSB1")]
    same_name = text.replace("Name      = SND", "Name      = sgps")
    with pytest.raises(MissionError) as err:
        instruments_from_mission(Bus(SimClock()), parse_mission(same_name, "m.moos"), ORIGIN)
    assert str(err.value) == ("m.moos:11: Name SGPS is already used by ProcessConfig = "
                              "iSerial_GPS at line 3: each instrument needs its own prefix")
    same_port = text.replace("/dev/ttyUSB1", "/dev/ttyUSB0")
    with pytest.raises(MissionError) as err:
        instruments_from_mission(Bus(SimClock()), parse_mission(same_port, "m.moos"), ORIGIN)
    assert str(err.value) == ("m.moos:12: Port /dev/ttyUSB0 is already read by ProcessConfig = "
                              "iSerial_GPS at line 3: one reader per device")
    assert is_instrument_block("iSerial") and is_instrument_block("ISERIAL_gps2")
    assert not is_instrument_block("iSerial_") and not is_instrument_block("iSerialGPS")
    assert not is_instrument_block("iMAVLink")


# ---------------------------------------------------------------------- real pseudo-terminals


class Pty:
    """A pty pair made by the test: the instrument writes into the master."""

    def __init__(self) -> None:
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        os.set_blocking(self.master, False)
        self.path = os.ttyname(self.slave)

    def write(self, *lines: str) -> int:
        data = b"".join(line.encode("ascii") + b"\r\n" for line in lines)
        try:
            return os.write(self.master, data)
        except BlockingIOError:
            return 0

    def close(self) -> None:
        for fd in (self.master, self.slave):
            try:
                os.close(fd)
            except OSError:
                pass


def pump(app: SerialInstrument, clock: SimClock, until, timeout: float = 3.0,
         step: float = 0.05) -> None:
    """Tick (simulated time, real pty I/O) until ``until()`` or fail after timeout wall s."""
    def tick() -> None:
        clock.advance(step)
        app.iterate(clock.now())
        time.sleep(0.01)

    wait_for(until, timeout, "the instrument's condition", pause=tick)


def test_a_device_behind_a_symlink_vanishes_and_returns(tmp_path) -> None:
    link = tmp_path / "gps"
    first = Pty()
    os.symlink(first.path, link)
    clock = SimClock(T0)
    bus = Bus(clock)
    bus.subscribe("test", ["*"])
    app = SerialInstrument.from_block(bus, block(("Name", "SH"), ("Port", str(link)),
                                                 ("Sentences", "HDT"), ("Stale", "NEVER")),
                                      ORIGIN)
    mail: list[Message] = []

    def seen(name: str) -> list:
        mail.extend(bus.fetch("test"))
        return [m.value for m in mail if m.name == name]

    second = None
    try:
        app.iterate(clock.now())
        assert app.is_open and seen("SH_OPEN") == [1.0]
        first.write(nmea.hdt(11.0))
        pump(app, clock, lambda: seen("SH_HEADING"))
        assert seen("SH_HEADING") == [11.0]
        clock.advance(20.0)  # it worked for a while
        first.close()  # the instrument goes away: its pty hangs up
        link.unlink()
        app.iterate(clock.now())
        lost = clock.now()
        assert not app.is_open and seen("SH_OPEN") == [1.0, 0.0]
        warnings = seen("SH_WARNING")
        assert len(warnings) == 1 and warnings[0].startswith(f"{link} lost (")
        for _ in range(100):  # 10 s without the device: retried, never said again
            clock.advance(0.1)
            app.iterate(clock.now())
        assert len(seen("SH_WARNING")) == 1 and app.stats["failures"] >= 4
        second = Pty()  # it comes back, on another pty
        os.symlink(second.path, link)
        pump(app, clock, lambda: app.is_open, timeout=2.0, step=0.1)
        assert clock.now() - lost <= 10.0 + 8.0 + 0.1, "reopened within the 8 s backoff"
        assert seen("SH_OPEN") == [1.0, 0.0, 1.0]
        second.write(nmea.hdt(22.0))
        pump(app, clock, lambda: 22.0 in seen("SH_HEADING"))
        assert len(seen("SH_WARNING")) == 1 and app.dropped == 0
    finally:
        app.close()
        first.close()
        if second is not None:
            second.close()


def _heading_on(pty: Pty, name: str) -> tuple[SimClock, Bus, SerialInstrument]:
    """An HDT instrument called ``name`` reading ``pty``, opened by its first tick."""
    clock = SimClock(T0)
    bus = Bus(clock)
    app = SerialInstrument.from_block(bus, block(("Name", name), ("Port", pty.path),
                                                 ("Sentences", "HDT")), ORIGIN)
    app.iterate(clock.now())
    assert app.is_open
    return clock, bus, app


def test_a_flooded_pty_never_holds_up_the_tick() -> None:
    pty = Pty()
    clock, bus, app = _heading_on(pty, "F")
    try:
        written = 0
        k = 0
        for _ in range(200):  # fill the kernel's buffer: as much as the pty takes
            n = pty.write(*[nmea.hdt(float(k % 360)) for k in range(k, k + 100)])
            k += 100
            written += n
            if n == 0:
                break
        assert written > app.budget, written
        worst = 0.0

        def tick() -> None:
            nonlocal worst
            clock.advance(0.1)
            start = time.perf_counter()
            app.iterate(clock.now())
            worst = max(worst, time.perf_counter() - start)
            assert app.last_parsed_bytes <= app.budget

        for _ in range(20):
            tick()
            pty.write(nmea.hdt(float(k % 360)))
            k += 1
        # The newest line gets through once the kernel has room for it (on a loaded machine
        # its pty worker may still be moving the flood): write it whole, then tick till read.
        rest = nmea.hdt(99.9).encode("ascii") + b"\r\n"
        deadline = time.monotonic() + 10.0
        while rest:
            with contextlib.suppress(BlockingIOError):
                rest = rest[os.write(pty.master, rest):]
            assert time.monotonic() < deadline, "the pty never took the last line"
            tick()
        while bus.latest("F_HEADING").value != 99.9:
            assert time.monotonic() < deadline, "the newest line was never read"
            tick()
            time.sleep(0.01)
        assert worst < 0.1, worst
        assert app.stats["sentences"] > 0 and app.stats["bytes"] >= written
    finally:
        app.close()
        pty.close()


# ------------------------------------------------------------------------- mavhelm sim --sensors


def test_mavhelm_sim_sensors_read_by_the_instruments(tmp_path) -> None:
    """The real command: its printed ptys read by four readers configured as a boat's would
    be; values near the simulator's truth (at home, heading 90°, 20 m of water, still)."""
    from tests.support.interop_helpers import SimProcess

    scenario = tmp_path / "noisy.scn"
    scenario.write_text("seed = 3\n"
                        "serial_garbage  always port=heading prob=0.2\n"
                        "serial_truncate always port=heading prob=0.2\n")
    with SimProcess("--fast-start", "--sensors", "--home", "50.1,-4.2,90",
                    "--beacons", "1:100,0,-10;2:0,-150,-10", "--scenario", str(scenario)) as sim:
        paths = sim.sensor_paths("nmea_gps", "heading", "depth", "dvl", "lbl")
        assert set(paths) == {"nmea_gps", "heading", "depth", "dvl", "lbl"}
        clock = SimClock(time.monotonic())
        bus = Bus(clock)
        bus.subscribe("test", ["*"])
        kit = [("SGPS", "nmea_gps", "GGA,RMC"), ("HDG", "heading", "HDT"),
               ("SND", "depth", "DPT,DBT"), ("DVL", "dvl", "PMVHDVL"), ("LBL", "lbl", "PMVHLBL")]
        apps = [SerialInstrument.from_block(bus, block(("Name", name), ("Port", paths[port]),
                                                       ("Sentences", sentences),
                                                       name=f"iSerial_{name}"), ORIGIN)
                for name, port, sentences in kit]
        wanted = {"SGPS_X", "SGPS_Y", "SGPS_FIX", "SGPS_SPEED", "HDG_HEADING", "HDG_YAW",
                  "SND_DEPTH", "SND_ALTITUDE", "DVL_VX_BODY", "DVL_ALTITUDE", "LBL_TWTT_1",
                  "LBL_TWTT_2"}
        mail: list[Message] = []
        try:
            deadline = time.monotonic() + 15
            while not (wanted <= {m.name for m in mail} and apps[1].dropped >= 3):
                assert time.monotonic() < deadline, (
                    f"missing {wanted - {m.name for m in mail}}; dropped "
                    f"{[a.stats for a in apps]}\n{sim.output.text()}")
                clock.set(time.monotonic())
                for app in apps:
                    app.iterate(clock.now())
                mail += bus.fetch("test")
                time.sleep(0.05)
        finally:
            for app in apps:
                app.close()

    def values(name: str) -> list[float]:
        return [float(m.value) for m in mail if m.name == name]

    assert all(math.hypot(x, y) < 10.0 for x, y in zip(values("SGPS_X"), values("SGPS_Y"),
                                                        strict=True))
    assert set(values("SGPS_FIX")) == {1.0} and max(values("SGPS_SPEED")) < 0.5
    assert all(abs(h - 90.0) < 3.0 for h in values("HDG_HEADING"))
    assert all(abs(y + math.pi / 2) < math.radians(3.0) for y in values("HDG_YAW"))
    assert all(abs(d - 20.0) < 0.6 for d in values("SND_DEPTH"))  # 19.7 below + 0.3 offset
    assert all(abs(a - 19.7) < 0.6 for a in values("SND_ALTITUDE") + values("DVL_ALTITUDE"))
    assert all(abs(v) < 0.1 for v in values("DVL_VX_BODY"))
    for beacon, x, y in (("1", 100.0, 0.0), ("2", 0.0, -150.0)):
        expected = 2.0 * math.dist((0.0, 0.0, -0.5), (x, y, -10.0)) / 1500.0
        assert all(abs(t - expected) < 0.01 for t in values(f"LBL_TWTT_{beacon}")), beacon
    heading = apps[1]
    assert set(heading.stats) >= set(DROP_REASONS)
    assert heading.stats["sentences"] > 10 and heading.dropped >= 3, heading.stats
    assert values("HDG_DROPPED")[-1] == heading.dropped
    assert sum(a.dropped for a in apps if a is not heading) == 0, [a.stats for a in apps]


def test_a_port_read_whole_is_not_asked_again_in_the_tick() -> None:
    """pyserial reports what the port holds; a read that took it all ends the tick's reading
    (a second ask is a system call that answers nothing, two instruments every tick), and
    nothing waiting is left behind."""
    pty = Pty()
    clock, bus, app = _heading_on(pty, "D")
    try:
        transport = app.transport
        calls = []
        read_into = transport.read_into

        def counted(buffer: memoryview) -> int:
            calls.append(read_into(buffer))
            return calls[-1]

        transport.read_into = counted  # type: ignore[method-assign]
        written = pty.write(*[nmea.hdt(float(k)) for k in range(5)])
        deadline = time.monotonic() + 3.0
        while transport.port.in_waiting < written:  # type: ignore[attr-defined]
            assert time.monotonic() < deadline, "the pty never passed the lines on"
            time.sleep(0.01)
        clock.advance(0.1)
        app.iterate(clock.now())
        assert len(calls) == 1 and calls[0] > 0, calls
        assert bus.latest("D_HEADING").value == 4.0
    finally:
        app.close()
        pty.close()
