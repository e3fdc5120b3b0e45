"""The link's one-pass framing against pymavlink's own parser: the same frames, the same
BAD_DATA, whatever the bytes and however they are split across reads."""

from __future__ import annotations

import struct
from collections.abc import Callable

from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.link import _PLAIN, Skimmed, SkimmingParser

_ENCODER = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
FRAMES = [bytes(m.pack(_ENCODER)) for m in (
    mavlink.MAVLink_heartbeat_message(10, 3, 129, 15, 4, 3),
    mavlink.MAVLink_attitude_message(1, 0.1, -0.2, 3.0, 0.01, 0.02, -0.03),
    mavlink.MAVLink_gps_raw_int_message(5, 3, 564120000, -54760000, 30, 100, 120, 200, 9000, 11),
    mavlink.MAVLink_raw_imu_message(1, 1, 2, 3, 4, 5, 6, 7, 8, 9),
    mavlink.MAVLink_statustext_message(4, b"Mode GUIDED"),
)]
FRAMES.append(bytes(mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3)
                    .pack(_ENCODER, force_mavlink1=True)))
WANTED = frozenset({mavlink.MAVLINK_MSG_ID_HEARTBEAT, mavlink.MAVLINK_MSG_ID_ATTITUDE,
                    mavlink.MAVLINK_MSG_ID_GPS_RAW_INT})


def _corrupt(frame: bytes, at: int) -> bytes:
    b = bytearray(frame)
    b[at % len(b)] ^= 0x5A
    return bytes(b)


pieces = st.one_of(
    st.sampled_from(FRAMES),
    st.binary(min_size=1, max_size=12),
    st.tuples(st.sampled_from(FRAMES), st.integers(0, 60)).map(lambda fa: _corrupt(*fa)),
    st.sampled_from([b"\xfd", b"\xfe", b"\xfd\x09\x04", b"\xfd\x09\x01\x00"]),
)


def _stock(data: bytes, cuts: list[int]) -> list[tuple[str, bytes]]:
    parser = mavlink.MAVLink(None)
    parser.robust_parsing = True
    out = []
    for chunk in _chunks(data, cuts):
        for m in parser.parse_buffer(chunk) or []:
            out.append((m.get_type(), bytes(m.get_msgbuf())))
    return out


def _ours(data: bytes, cuts: list[int], decoded: frozenset[int] | None
          ) -> list[tuple[str, bytes]]:
    parser = SkimmingParser(None)
    parser.robust_parsing = True
    parser.decoded = decoded
    out = []
    for chunk in _chunks(data, cuts):
        for m in parser.parse_buffer(chunk):
            out.append((m.get_type(), bytes(m.get_msgbuf())))
    return out


def _chunks(data: bytes, cuts: list[int]) -> list[bytes]:
    edges = sorted({0, len(data), *(c % (len(data) + 1) for c in cuts)})
    return [data[a:b] for a, b in zip(edges, edges[1:], strict=False)]


@settings(max_examples=300, deadline=None)
@given(st.lists(pieces, max_size=25), st.lists(st.integers(0, 10_000), max_size=6))
def test_every_frame_and_every_bad_run_as_pymavlink_frames_them(parts, cuts) -> None:
    data = b"".join(parts)
    assert _ours(data, cuts, None) == _stock(data, cuts)


@settings(max_examples=200, deadline=None)
@given(st.lists(pieces, max_size=25), st.lists(st.integers(0, 10_000), max_size=6))
def test_skimming_changes_only_what_unread_frames_become(parts, cuts) -> None:
    """A frame of an unread message is passed on whole as ``Skimmed`` (its CRC unchecked,
    whatever pymavlink would have made of it); every read frame and every bad run is as
    pymavlink has it, in the same place."""
    data = b"".join(parts)
    stock = _stock(data, cuts)
    ours = _ours(data, cuts, WANTED)
    assert [raw for _, raw in ours] == [raw for _, raw in stock]
    for (kind, raw), (stock_kind, _) in zip(ours, stock, strict=True):
        assert kind.startswith("UNKNOWN_") if _unread_frame(raw) else kind == stock_kind


@settings(max_examples=200, deadline=None)
@given(st.lists(pieces, max_size=25), st.lists(st.integers(0, 10_000), max_size=6))
def test_without_a_recorder_unread_frames_are_only_counted(parts, cuts) -> None:
    """A link with nothing to record unread frames into drops them while framing (no object
    made, no decode called): what it returns is the rest, in order; the count is theirs."""
    data = b"".join(parts)
    kept = _ours(data, cuts, WANTED)
    parser = SkimmingParser(None)
    parser.robust_parsing = True
    parser.decoded = WANTED
    parser.keep_skimmed = False
    dropped = [(m.get_type(), bytes(m.get_msgbuf()))
               for chunk in _chunks(data, cuts) for m in parser.parse_buffer(chunk)]
    assert dropped == [frame for frame in kept if not frame[0].startswith("UNKNOWN_")]
    assert parser.skimmed == len(kept) - len(dropped)
    assert parser.total_packets_received == len(kept)


def _unread_frame(raw: bytes) -> bool:
    if raw[0] == 0xFD:
        if len(raw) < 10 or raw[2] & ~1:
            return False
        msgid = raw[7] | raw[8] << 8 | raw[9] << 16
    elif raw[0] == 0xFE and len(raw) >= 6:
        msgid = raw[5]
    else:
        return False
    return msgid not in WANTED


def test_a_partial_frame_waits_for_its_end() -> None:
    parser = SkimmingParser(None)
    parser.robust_parsing = True
    frame = FRAMES[1]
    assert parser.parse_buffer(frame[:7]) == []
    (msg,) = parser.parse_buffer(frame[7:])
    assert msg.get_type() == "ATTITUDE" and abs(msg.yaw - 3.0) < 1e-6
    parser.decoded = WANTED
    (skimmed,) = parser.parse_buffer(FRAMES[3])
    assert isinstance(skimmed, Skimmed) and bytes(skimmed.get_msgbuf()) == FRAMES[3]


PLAIN_IDS = sorted(_PLAIN)


def _frame(msgid: int, payload: bytes, seq: int, src: tuple[int, int], compat: int,
           crc_extra: int) -> bytearray:
    """A MAVLink 2 frame as an autopilot sends it, whatever its payload's bytes."""
    body = bytes([len(payload), 0, compat, seq, *src, msgid & 0xFF, msgid >> 8 & 0xFF,
                  msgid >> 16]) + payload
    crc = mavlink.x25crc(body + bytes([crc_extra])).crc
    return bytearray(b"\xfd" + body + bytes([crc & 0xFF, crc >> 8]))


def _as_decoded(make: Callable[[], mavlink.MAVLink_message]) -> object:
    """Everything a reader can see of a decoded message (floats by their bits: NaN is NaN),
    or the error pymavlink raised."""
    try:
        msg = make()
    except mavlink.MAVError as exc:
        return ("MAVError", str(exc))
    fields = {k: struct.pack("<d", v) if isinstance(v, float) else v
              for k, v in vars(msg).items() if k != "_header"}
    return type(msg), fields, vars(msg.get_header()), msg.get_fieldnames(), msg.get_signed()


@settings(max_examples=600, deadline=None)
@given(st.sampled_from(PLAIN_IDS), st.data(), st.integers(0, 255), st.integers(1, 255),
       st.integers(0, 255), st.integers(0, 255), st.integers(0, 3))
def test_a_message_of_numbers_is_decoded_as_pymavlink_decodes_it(
        msgid, data, seq, system, component, compat, damage) -> None:
    """Any payload (random bytes: NaNs, extremes; shorter than the message, as MAVLink 2
    sends it with its trailing zeros cut, or longer, from a newer dialect), a damaged CRC or
    length: the link's decoder and pymavlink's give the same message, or the same error."""
    cls = mavlink.mavlink_map[msgid]
    size = cls.unpacker.size
    payload = data.draw(st.binary(min_size=0, max_size=min(size + 8, 255)))
    frame = _frame(msgid, payload, seq, (system, component), compat, cls.crc_extra)
    if damage == 1:
        frame[-1] ^= 0x01
    elif damage == 2 and frame[1]:
        frame[1] -= 1
    ours = SkimmingParser(None)
    assert _as_decoded(lambda: ours.decode(bytearray(frame))) == \
        _as_decoded(lambda: mavlink.MAVLink(None).decode(bytearray(frame)))


def test_the_fast_decode_is_the_one_taken_and_signed_links_keep_pymavlinks() -> None:
    """The autopilot's streamed messages take the numbers' path (a change to the dialect
    that made them leave it would go unnoticed otherwise); a parser with a signing key
    leaves every frame to pymavlink, which checks the signature."""
    for name in ("HEARTBEAT", "ATTITUDE", "GPS_RAW_INT", "GLOBAL_POSITION_INT", "RC_CHANNELS",
                 "SYS_STATUS", "SIMSTATE", "EKF_STATUS_REPORT", "VFR_HUD", "DISTANCE_SENSOR"):
        assert getattr(mavlink, f"MAVLINK_MSG_ID_{name}") in _PLAIN, name
    frame = bytearray(FRAMES[1])
    calls = []
    original = mavlink.MAVLink.decode

    def stock(self, msgbuf):  # type: ignore[no-untyped-def]
        calls.append(bytes(msgbuf))
        return original(self, msgbuf)

    mavlink.MAVLink.decode = stock  # type: ignore[method-assign]
    try:
        assert SkimmingParser(None).decode(bytearray(frame)).get_type() == "ATTITUDE"
        assert calls == []
        signing = SkimmingParser(None)
        signing.signing.secret_key = bytes(32)
        signing.signing.allow_unsigned_callback = lambda *_: True
        assert signing.decode(bytearray(frame)).get_type() == "ATTITUDE"
        assert calls == [bytes(frame)]
    finally:
        mavlink.MAVLink.decode = original  # type: ignore[method-assign]
