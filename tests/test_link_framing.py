"""The link's one-pass framing against pymavlink's own parser: the same frames, the same
BAD_DATA, whatever the bytes and however they are split across reads."""

from __future__ import annotations

from hypothesis import given, settings
from hypothesis import strategies as st
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.link import Skimmed, SkimmingParser

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
