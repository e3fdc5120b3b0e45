"""A MAVLink telemetry log (``.tlog``) read back as the bus variables the companion would have
posted: what ``mavhelm nav replay MISSION LOG`` runs the navigator over.

A ``.tlog`` is what MAVProxy, QGroundControl and Mission Planner record: for every frame an
8-byte big-endian time stamp (microseconds since the Unix epoch, the recorder's clock), then
the raw MAVLink 1 or 2 frame, repeated to the end of the file. The frames go through a
``MavlinkBridge`` built from the mission's own ``iMAVLink`` block and origin (``take``, the
bridge's per-message conversion), so a replay sees exactly the ``GPS_X``, ``INS_YAW``,
``AP_ALTITUDE``, ``WHEEL_VX_BODY``, ``TRUTH_X``, … a live link gives, each stamped with its
frame's tlog time. The bridge never opens its link here: nothing is sent anywhere.

Only frames from the mission's autopilot (``TargetSystem``/``TargetComponent``) become sensor
variables, as on a live link; the ground station's own frames, also in the log, do not. The
link's state (``AP_LINK``, ``HELM_ONLINE``, ``HELM_STATUS``) is not replayed: it depends on
the companion's clock and its own connection, which a tlog does not hold.

Damage is skipped and counted, never fatal: bytes that are not a record with a valid frame
(a cut or garbled write, a truncated last record) are scanned past one byte at a time until a
record decodes again, its checksum good and its time stamp within a day of the last good one;
each such stretch counts once in ``bad_frames``, and the bridge posts ``MAVLINK_BAD_PACKETS``
as it would live. A frame whose message id the ardupilotmega dialect does not know is skipped
uncounted (``unknown_frames``): it is someone else's message, not damage; having no checksum
that can be checked, it is only taken for a frame after a good record (its time stamp is then
the check), so one at the very start of a log counts as damage.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.bridge import BridgeConfig, MavlinkBridge
from mavhelm.companion.link import AutopilotLink
from mavhelm.core.bus import Bus, Message
from mavhelm.core.geodesy import mission_origin
from mavhelm.core.mission import Mission

STAMP = struct.Struct(">Q")
MAX_STAMP_JUMP_S = 86_400.0
"""A record whose time stamp jumps further than this from the last good one is not a record
(a CRC can match by chance in garbage; a plausible time as well is far less likely)."""

_V1, _V2 = 0xFE, 0xFD
_SIGNED = 0x01


@dataclass
class TlogReplay:
    """What a tlog gave: the bus messages in file order, and how much of it was not used."""

    messages: list[Message] = field(default_factory=list)
    frames: int = 0
    """Frames decoded (from any system)."""
    bad_frames: int = 0
    """Damaged stretches skipped."""
    unknown_frames: int = 0
    """Whole frames of message ids the dialect does not know."""
    refused: int = 0
    """Frames decoded but refused by the bridge (``MAVLINK_ERROR``: impossible values)."""


class _ReplayClock:
    """The bus's clock during a replay: the time stamp of the frame being read."""

    def __init__(self) -> None:
        self.t = 0.0

    def now(self) -> float:
        return self.t


class _Offline:
    """The replay bridge's transport: there is no autopilot to talk to, so it never opens."""

    def open(self) -> None:
        raise OSError("a telemetry log replay has no link")

    def ready(self) -> bool:
        return False

    def read_into(self, buffer: memoryview) -> int:
        return 0

    def write(self, data: bytes) -> int:
        return 0

    def close(self) -> None:
        pass

    def fileno(self) -> int | None:
        return None


def _frame_length(data: bytes, at: int) -> int | None:
    """Length of the MAVLink frame starting at ``data[at]``, or None if no frame starts there."""
    if at + 3 > len(data):
        return None
    magic, payload = data[at], data[at + 1]
    if magic == _V2:
        return 12 + payload + (13 if data[at + 2] & _SIGNED else 0)
    if magic == _V1:
        return 8 + payload
    return None


class _Frames:
    """(time stamp in seconds, message) for each good record of a tlog, damage counted."""

    def __init__(self, data: bytes) -> None:
        self.data = data
        self.parser = mavlink.MAVLink(None)
        self.bad = 0
        self.unknown = 0

    def _record(self, at: int, last: float | None
                ) -> tuple[int, float, mavlink.MAVLink_message | None] | None:
        """The record at ``at``: (its length, its time, its message or None for an unknown
        id), or None if no good record starts there."""
        data = self.data
        if at + STAMP.size >= len(data):
            return None
        length = _frame_length(data, at + STAMP.size)
        end = at + STAMP.size + (length or 0)
        if length is None or end > len(data):
            return None
        stamp = STAMP.unpack_from(data, at)[0] / 1e6
        if last is not None and abs(stamp - last) > MAX_STAMP_JUMP_S:
            return None
        frame = bytearray(data[at + STAMP.size:end])
        try:
            msg = self.parser.decode(frame)
        except (mavlink.MAVError, struct.error, ValueError, IndexError):
            return None
        if isinstance(msg, mavlink.MAVLink_unknown):
            # no checksum to check without the message's definition: only its time stamp,
            # next to a good record's, says it is a record at all
            return (end - at, stamp, None) if last is not None else None
        return end - at, stamp, msg

    def __iter__(self) -> Iterator[tuple[float, mavlink.MAVLink_message]]:
        at, last, damaged = 0, None, False
        while at < len(self.data):
            record = self._record(at, last)
            if record is None:
                if not damaged:
                    damaged = True
                    self.bad += 1
                at += 1
                continue
            damaged = False
            length, stamp, msg = record
            at += length
            last = stamp
            if msg is None:
                self.unknown += 1
                continue
            yield stamp, msg


def read_tlog(path: Path, mission: Mission) -> TlogReplay:
    """Every bus message the mission's MAVLink bridge posts for the log's frames, stamped with
    the tlog time (see the module docstring)."""
    clock = _ReplayClock()
    bus = Bus(clock)
    bus.subscribe("tlog", ["*"])
    # a log is read, not obeyed: its frames' signatures were checked when they were live
    config = BridgeConfig.from_block(mission.process("iMAVLink")).replace(
        signing_key_file=None, require_signing=False, setup_signing=False)
    link = AutopilotLink(f"tlog:{path}", system_id=config.system_id,
                         component_id=config.component_id,
                         target_system=config.target_system,
                         target_component=config.target_component, transport=_Offline())
    bridge = MavlinkBridge(bus, config, mission_origin(mission), link)
    frames = _Frames(Path(path).read_bytes())
    replay = TlogReplay()
    for stamp, msg in frames:
        clock.t = stamp
        bridge.bad_packets = before = frames.bad + replay.refused
        bridge.take(msg, stamp)
        replay.refused += bridge.bad_packets - before
        bridge.post_bad_packets()
        replay.frames += 1
    replay.bad_frames, replay.unknown_frames = frames.bad, frames.unknown
    bridge.bad_packets = frames.bad + replay.refused
    bridge.post_bad_packets()
    replay.messages = bus.fetch("tlog")
    return replay


def bus_messages_from_tlog(path: Path, mission: Mission) -> list[Message]:
    """The bus messages a tlog replays into (``read_tlog``), for the navigator's replay."""
    return read_tlog(path, mission).messages
