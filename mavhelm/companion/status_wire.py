"""Status events over MAVLink: each event, and the once-a-second snapshot, in one TUNNEL payload.

Ordinary ground stations read the companion's STATUSTEXT lines; a console that wants the facts
reads these instead, and never has to parse English. Both ends use this module: the companion
:func:`encode`\\ s, ``mavhelm remote`` :func:`decode`\\ s.

A payload is ``WIRE_VERSION``, the event's kind code, then its fields in declaration order:
a flag is one byte (0/1), an unknown-or-flag one byte (0 unknown, 1 no, 2 yes), a severity one
byte, a count four bytes (big-endian), a string one length byte and UTF-8, a list of names a
count byte and the names. It fits
``MAX_PAYLOAD`` bytes: control characters become ``?``, a name is cut to ``NAME_MAX`` bytes,
a snapshot names as many tasks as fit (and says so), and free text gets the room left, cut on
a character boundary. :func:`fit` is an event exactly as it will arrive. Anything else —
another version, an unknown kind, a bad length, invalid UTF-8, a control character, bytes left
over — is refused: :func:`decode` returns None and never raises.
"""

from __future__ import annotations

import dataclasses
import unicodedata
from typing import Literal

from mavhelm.companion.status import (
    Alert,
    Armed,
    AutopilotMode,
    AutopilotText,
    Event,
    Goal,
    HandedBack,
    HelmReloaded,
    HelmState,
    LinkNote,
    LinkUp,
    MissionEnded,
    NavFailure,
    NavSource,
    NavWarning,
    RemoteFlagPosted,
    SenderRefused,
    Severity,
    Snapshot,
    TaskEnded,
    TaskEvent,
    TaskStarted,
    ThirdPartyReply,
)

STATUS_PAYLOAD_TYPE = 32802
"""MAVLink TUNNEL payload_type of a status event or snapshot (private range 32768-65535; the
third-party channel is 32801)."""
MAX_PAYLOAD = 128
"""A TUNNEL payload's size."""
WIRE_VERSION = 1
NAME_MAX = 32
"""Bytes kept of a name (task, mode, source, flag): cut the same way everywhere, so a task's
end still matches its start."""
TASKS_RESERVE = 40
"""Bytes of a snapshot kept for its texts however many tasks run."""

Kind = Literal["flag", "maybe", "severity", "count", "name", "opt_name", "text", "names"]

LAYOUTS: dict[type, tuple[int, tuple[Kind, ...]]] = {
    LinkUp: (1, ("flag",)),
    LinkNote: (2, ("text",)),
    AutopilotMode: (3, ("name",)),
    Armed: (4, ("flag",)),
    HelmState: (5, ("flag", "text")),
    TaskStarted: (6, ("name",)),
    TaskEnded: (7, ("name", "name")),
    TaskEvent: (8, ("name", "text")),
    Goal: (9, ("name", "text")),
    Alert: (10, ("name", "text", "severity")),
    MissionEnded: (11, ("name",)),
    HelmReloaded: (12, ("text",)),
    HandedBack: (13, ("name",)),
    RemoteFlagPosted: (14, ("name",)),
    ThirdPartyReply: (15, ("text",)),
    AutopilotText: (16, ("text",)),
    NavSource: (17, ("name", "name")),
    NavWarning: (18, ("text",)),
    NavFailure: (19, ("text",)),
    Snapshot: (20, ("maybe", "text", "opt_name", "maybe", "names", "name", "text", "flag")),
    SenderRefused: (21, ("name", "name", "text", "count")),
}
"""Each event's kind code and how each of its fields (in declaration order) travels."""
_BY_CODE = {code: (cls, kinds) for cls, (code, kinds) in LAYOUTS.items()}
_HEADER = 2
_NONE = 0xFF
COUNT_MAX = 0xFFFFFFFF
"""A count travels as 4 bytes, big-endian; a larger one arrives as this."""
"""Length byte of an absent optional name."""


class WireError(ValueError):
    """A payload that is not a status event."""


def _clean(text: str) -> str:
    """Control characters (and lone surrogates) become ``?``: nothing can move a cursor."""
    if text.isprintable():  # no Cc/Cs character in it: the common case, at C speed
        return text
    return "".join("?" if unicodedata.category(c) in ("Cc", "Cs") else c for c in text)


def _cut(text: str, limit: int) -> str:
    """At most ``limit`` bytes of UTF-8, cut on a character boundary."""
    data = text.encode("utf-8")
    return text if len(data) <= limit else data[:max(0, limit)].decode("utf-8", "ignore")


def _name(value: str) -> str:
    return _cut(_clean(value), NAME_MAX)


def _size(kind: Kind, value: object) -> int:
    if kind in ("flag", "maybe", "severity"):
        return 1
    if kind == "count":
        return 4
    if kind == "names":
        assert isinstance(value, tuple)
        return 1 + sum(1 + len(v.encode("utf-8")) for v in value)
    return 1 + (0 if value is None else len(str(value).encode("utf-8")))


def _fit_names(names: tuple[str, ...], room: int) -> tuple[tuple[str, ...], bool]:
    kept: list[str] = []
    used = 1
    for name in map(_name, names):
        if used + 1 + len(name.encode("utf-8")) > room:
            return tuple(kept), True
        kept.append(name)
        used += 1 + len(name.encode("utf-8"))
    return tuple(kept), False


def fit(event: Event) -> Event:
    """The event as it will arrive: cleaned, its names cut, its texts cut to the room left."""
    _, kinds = LAYOUTS[type(event)]
    fields = dataclasses.fields(event)
    values: list[object] = [getattr(event, f.name) for f in fields]
    cut = False
    for i, kind in enumerate(kinds):
        if kind in ("name", "opt_name") and values[i] is not None:
            values[i] = _name(str(values[i]))
        if kind == "count":
            values[i] = max(0, min(COUNT_MAX, int(values[i])))  # type: ignore[call-overload]
    room = MAX_PAYLOAD - _HEADER - sum(_size(k, v) for k, v in zip(kinds, values, strict=True)
                                       if k not in ("text", "names"))
    room -= sum(1 for k in kinds if k == "text")
    for i, kind in enumerate(kinds):
        if kind == "names":
            assert isinstance(values[i], tuple)
            values[i], cut = _fit_names(values[i], room - TASKS_RESERVE)  # type: ignore[arg-type]
            room -= _size(kind, values[i])
    for i, kind in enumerate(kinds):
        if kind == "text":
            values[i] = _cut(_clean(str(values[i])), room)
            room -= len(str(values[i]).encode("utf-8"))
    fitted = event.__class__(*values)  # type: ignore[arg-type]
    if cut and isinstance(fitted, Snapshot):
        fitted = dataclasses.replace(fitted, tasks_cut=True)
    return fitted


def _pack_string(value: str) -> bytes:
    data = value.encode("utf-8")
    return bytes([len(data)]) + data


def _pack(kind: Kind, value: object) -> bytes:
    if kind == "flag":
        return bytes([1 if value else 0])
    if kind == "maybe":
        return bytes([0 if value is None else 2 if value else 1])
    if kind == "severity":
        return bytes([int(value)])  # type: ignore[call-overload]
    if kind == "count":
        return max(0, min(COUNT_MAX, int(value))).to_bytes(4, "big")  # type: ignore[call-overload]
    if kind == "names":
        assert isinstance(value, tuple)
        return bytes([len(value)]) + b"".join(_pack_string(v) for v in value)
    if value is None:
        return bytes([_NONE])
    return _pack_string(str(value))


def encode(event: Event) -> bytes:
    """The TUNNEL payload of an event (at most ``MAX_PAYLOAD`` bytes)."""
    fitted = fit(event)
    code, kinds = LAYOUTS[type(fitted)]
    body = b"".join(_pack(kind, getattr(fitted, f.name))
                    for kind, f in zip(kinds, dataclasses.fields(fitted), strict=True))
    data = bytes([WIRE_VERSION, code]) + body
    assert len(data) <= MAX_PAYLOAD, (event, len(data))
    return data


class _Reader:
    def __init__(self, data: bytes) -> None:
        self.data = data
        self.at = 0

    def byte(self) -> int:
        if self.at >= len(self.data):
            raise WireError("payload ends early")
        self.at += 1
        return self.data[self.at - 1]

    def string(self, limit: int, length: int | None = None) -> str:
        n = self.byte() if length is None else length
        if n > limit or self.at + n > len(self.data):
            raise WireError("string too long")
        text = self.data[self.at:self.at + n].decode("utf-8")
        self.at += n
        if _clean(text) != text:
            raise WireError("control character")
        return text

    def field(self, kind: Kind) -> object:
        if kind in ("flag", "maybe"):
            value = self.byte()
            if value > (1 if kind == "flag" else 2):
                raise WireError(f"bad {kind} {value}")
            return bool(value) if kind == "flag" else (None if value == 0 else value == 2)
        if kind == "severity":
            return Severity(self.byte())
        if kind == "count":
            return int.from_bytes(bytes(self.byte() for _ in range(4)), "big")
        if kind == "names":
            return tuple(self.string(NAME_MAX) for _ in range(self.byte()))
        if kind == "opt_name":
            n = self.byte()
            return None if n == _NONE else self.string(NAME_MAX, n)
        return self.string(NAME_MAX if kind == "name" else MAX_PAYLOAD)


def _unpack(data: bytes) -> Event:
    if len(data) > MAX_PAYLOAD or len(data) < _HEADER or data[0] != WIRE_VERSION:
        raise WireError("not a status payload of this version")
    layout = _BY_CODE.get(data[1])
    if layout is None:
        raise WireError(f"unknown kind {data[1]}")
    cls, kinds = layout
    reader = _Reader(data)
    reader.at = _HEADER
    values = [reader.field(kind) for kind in kinds]
    if reader.at != len(data):
        raise WireError("bytes left over")
    return cls(*values)  # type: ignore[no-any-return]


def decode(payload: bytes | bytearray | list[int]) -> Event | None:
    """The event in a TUNNEL payload (``payload[:payload_length]``), or None if it is not one."""
    try:
        return _unpack(bytes(payload))
    except (WireError, ValueError, TypeError):
        return None
