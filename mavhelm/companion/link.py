"""The autopilot link: MAVLink 2 over TCP, UDP or a serial line, that never stalls the helm.

pymavlink does the protocol (framing, CRC, encoding; ``MAVLink`` objects of the
ardupilotmega v2 dialect, so every frame we send is MAVLink 2). The transport is ours, because
pymavlink's connections reconnect with blocking sleeps and print to stdout: a helm that ticks
at 10 Hz must never wait on a socket. Here

- connecting is non-blocking and retried with backoff (1 s doubling to 8 s), so the companion
  may start before the autopilot (real ArduPilot SITL opens its SERIAL1 port late, a serial
  autopilot may boot after the companion) and survives the autopilot restarting;
- reading is bounded per tick (``budget`` bytes): when more is waiting, the oldest bytes are
  dropped, except that the newest HEARTBEAT from the autopilot in them is always kept, so a
  flood neither silences the helm nor grows memory, and the mode is never lost;
- every (re)connection increments ``generation``, so the bridge can refuse to actuate on a link
  it has not yet heard a HEARTBEAT on;
- only the messages the reader reads are decoded (``decode_only``): pymavlink's decode costs
  several microseconds a message, and an ArduPilot link's default streams carry a dozen a
  second the companion never reads (RAW_IMU, AHRS, MEMINFO, ...); the others are recorded whole
  in the ``.tlog`` and counted, not unpacked (nor made objects, when nothing records them);
- an unsigned frame of a message of numbers (what the autopilot streams) is decoded by the
  link, pymavlink's way but without its generic path (``SkimmingParser``), at under half
  the cost; signed links and every other message keep pymavlink's decode;
- what happens is said once in ``events`` (for the console and the bus), never printed.
"""

from __future__ import annotations

import errno
import operator
import os
import select
import socket
import struct
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import NamedTuple, Protocol

import serial
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.core.backoff import Backoff

READ_BUDGET = 32 * 1024
"""Bytes parsed per tick: ~1000 telemetry messages, several times ArduPilot's full stream."""
READ_CAP = 8 * 1024 * 1024
"""Bytes drained per tick at most; past it, the kernel's socket buffer holds the rest."""
RETRY_FIRST_S = 1.0
RETRY_MAX_S = 8.0
CONNECT_TIMEOUT_S = 5.0
"""A connection attempt not answered in this long is given up and retried."""


class Transport(Protocol):
    """A byte pipe to the autopilot. ``open`` may raise OSError; ``read`` never blocks."""

    def open(self) -> None: ...
    def ready(self) -> bool: ...
    def read_into(self, buffer: memoryview) -> int: ...
    def write(self, data: bytes) -> int: ...
    def close(self) -> None: ...
    def fileno(self) -> int | None: ...


class TcpTransport:
    """A TCP client with a non-blocking connect (ArduPilot SITL's ports, a telemetry bridge)."""

    def __init__(self, host: str, port: int) -> None:
        self.address = (host, port)
        self.sock: socket.socket | None = None
        self._connected = False
        self._unsent = b""

    def open(self) -> None:
        self.close()
        sock = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        sock.setblocking(False)
        sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        err = sock.connect_ex(self.address)
        if err not in (0, errno.EINPROGRESS, errno.EALREADY, errno.EWOULDBLOCK):
            sock.close()
            raise OSError(err, os.strerror(err))
        self.sock = sock
        self._connected = err == 0

    def ready(self) -> bool:
        """Connected; raises OSError if the connection attempt failed."""
        if self.sock is None:
            return False
        if not self._connected:
            _, writable, _ = select.select([], [self.sock], [], 0)
            if not writable:
                return False
            err = self.sock.getsockopt(socket.SOL_SOCKET, socket.SO_ERROR)
            if err:
                raise OSError(err, os.strerror(err))
            self._connected = True
        return True

    def read_into(self, buffer: memoryview) -> int:
        assert self.sock is not None
        try:
            n = self.sock.recv_into(buffer)
        except (BlockingIOError, InterruptedError):
            return 0
        if not n and len(buffer):
            raise ConnectionResetError(errno.ECONNRESET, "the autopilot closed the connection")
        return n

    def write(self, data: bytes) -> int:
        """Queue behind what the kernel has not taken yet; frames are never cut. Returns the
        bytes handed to the kernel. More than 64 KiB unsent means the peer is not reading:
        new frames are dropped (the next tick sends fresh commands) rather than queued."""
        if self.sock is None or not self._connected:
            return 0
        if len(self._unsent) > 65536:
            data = b""  # keep the whole frames already queued; drop this one
        pending = self._unsent + data
        try:
            sent = self.sock.send(pending) if pending else 0
        except (BlockingIOError, InterruptedError):
            sent = 0
        except OSError:
            return 0  # the read side notices a broken connection and reconnects
        self._unsent = pending[sent:]
        return sent

    @property
    def unsent(self) -> int:
        """Bytes queued that the kernel has not taken yet (0 once all is on its way)."""
        return len(self._unsent)

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()
        self.sock = None
        self._connected = False
        self._unsent = b""

    def fileno(self) -> int | None:
        return None if self.sock is None else self.sock.fileno()


class UdpTransport:
    """``udpin``/``udp``: listen and answer whoever last sent; ``udpout``: send to the address."""

    def __init__(self, host: str, port: int, listen: bool) -> None:
        self.address = (host, port)
        self.listen = listen
        self.peer: tuple[str, int] | None = None if listen else self.address
        self.sock: socket.socket | None = None

    def open(self) -> None:
        self.close()
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.setblocking(False)
        if self.listen:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            sock.bind(self.address)
        self.sock = sock

    def ready(self) -> bool:
        return self.sock is not None

    def read_into(self, buffer: memoryview) -> int:
        assert self.sock is not None
        size = 0
        while len(buffer) - size >= 65536:
            try:
                n, sender = self.sock.recvfrom_into(buffer[size:])
            except (BlockingIOError, InterruptedError):
                break
            except ConnectionRefusedError:
                continue  # an ICMP answer to an earlier udpout datagram: nobody listening yet
            if self.listen:
                self.peer = sender
            size += n
        return size

    def write(self, data: bytes) -> int:
        if self.sock is None or self.peer is None:
            return 0
        try:
            return self.sock.sendto(data, self.peer)
        except (BlockingIOError, InterruptedError, ConnectionRefusedError):
            return 0

    def close(self) -> None:
        if self.sock is not None:
            self.sock.close()
        self.sock = None

    def fileno(self) -> int | None:
        return None if self.sock is None else self.sock.fileno()


class SerialTransport:
    """A serial line (``/dev/ttyAMA0``, a USB telemetry radio, a pty) through pyserial; a
    device that vanishes raises on read and is reopened by the link's retry."""

    def __init__(self, device: str, baud: int) -> None:
        self.device = device
        self.baud = baud
        self.port: serial.Serial | None = None

    def open(self) -> None:
        self.close()
        try:
            self.port = serial.Serial(self.device, self.baud, timeout=0, write_timeout=0,
                                      exclusive=True)
        except serial.SerialException as exc:
            raise OSError(errno.EIO, str(exc)) from None

    def ready(self) -> bool:
        return self.port is not None

    drained = False
    """Whether the last ``read_into`` took everything the port held (a reader need not ask
    again this tick: one system call fewer)."""

    def read_into(self, buffer: memoryview) -> int:
        assert self.port is not None
        self.drained = False
        try:
            held = self.port.in_waiting
            waiting = min(len(buffer), held)
            self.drained = waiting == held
            if not waiting:
                return 0
            # pyserial opened the port non-blocking; one read(2) of what the kernel holds,
            # without pyserial's select() and copy (two instruments read every tick)
            got = os.readv(self.port.fileno(), [buffer[:waiting]])
            if not got:
                raise OSError(errno.EIO, "the device reported data and then none: unplugged?")
            return got
        except BlockingIOError:
            return 0
        except (serial.SerialException, OSError) as exc:
            raise OSError(errno.EIO, f"serial device failed: {exc}") from None

    def write(self, data: bytes) -> int:
        if self.port is None:
            return 0
        try:
            return self.port.write(data) or 0
        except serial.SerialTimeoutException:
            return 0  # the line is full: this command is dropped, the next tick sends afresh
        except (serial.SerialException, OSError):
            return 0  # the read side notices a vanished device and reopens it

    def close(self) -> None:
        if self.port is not None:
            try:
                self.port.close()
            except (serial.SerialException, OSError):
                pass
        self.port = None

    def fileno(self) -> int | None:
        return None if self.port is None else self.port.fileno()


def transport_for(url: str, baud: int) -> Transport:
    """``tcp:HOST:PORT``, ``udp:``/``udpin:HOST:PORT`` (listen), ``udpout:HOST:PORT``, or a
    serial device path (optionally ``DEVICE,BAUD``)."""
    scheme, _, rest = url.partition(":")
    scheme = scheme.lower()
    if scheme in ("tcp", "udp", "udpin", "udpout"):
        host, _, port_text = rest.rpartition(":")
        try:
            port = int(port_text)
        except ValueError:
            raise ValueError(f"{url!r}: expected {scheme}:HOST:PORT") from None
        if not host or not 0 < port < 65536:
            raise ValueError(f"{url!r}: expected {scheme}:HOST:PORT")
        if scheme == "tcp":
            return TcpTransport(host, port)
        return UdpTransport(host, port, listen=scheme != "udpout")
    device, _, baud_text = url.partition(",")
    if baud_text:
        try:
            baud = int(baud_text)
        except ValueError:
            raise ValueError(f"{url!r}: expected DEVICE or DEVICE,BAUD") from None
    return SerialTransport(device, baud)


@dataclass
class LinkStats:
    bytes_read: int = 0
    bytes_written: int = 0
    bytes_dropped: int = 0
    connects: int = 0
    skimmed: int = 0
    """Frames of messages the reader does not read: recorded, not decoded."""


class Skimmed(mavlink.MAVLink_unknown):
    """A frame of a message the reader never reads: its bytes, neither checked nor unpacked."""

    def __init__(self, msgid: int, data: bytearray) -> None:  # noqa: D107 - only what is read
        self._type = f"UNKNOWN_{msgid}"
        self._msgbuf = data
        self.data = data


V1, V2 = mavlink.PROTOCOL_MARKER_V1, mavlink.PROTOCOL_MARKER_V2
SIGNED = mavlink.MAVLINK_IFLAG_SIGNED
MAGICS = (bytes([V1]), bytes([V2]))


class _Plain(NamedTuple):
    """What decoding a message of numbers needs, read from pymavlink's class."""

    cls: type[mavlink.MAVLink_message]
    unpacker: struct.Struct
    order: Callable[[tuple[object, ...]], tuple[object, ...]]
    crc_extra: bytes
    size: int


def _as_it_is(fields: tuple[object, ...]) -> tuple[object, ...]:
    return fields


def _with_arrays(spans: list[tuple[int, int]]
                 ) -> Callable[[tuple[object, ...]], tuple[object, ...]]:
    """Fields in declaration order from an unpacked payload with arrays: each field's
    (first value, count), an array a list, as pymavlink gives it."""
    def order(values: tuple[object, ...]) -> tuple[object, ...]:
        return tuple(values[tip] if n == 1 else list(values[tip:tip + n]) for tip, n in spans)
    return order


def _plain_messages() -> dict[int, _Plain]:
    """The dialect's messages of numbers (no strings), by id: those pymavlink's decode
    unpacks without per-field work beyond ordering them (what the autopilot streams:
    HEARTBEAT, ATTITUDE, GPS_RAW_INT, GLOBAL_POSITION_INT, RC_CHANNELS, DISTANCE_SENSOR, ...)."""
    plain = {}
    for msgid, cls in mavlink.mavlink_map.items():
        fmt = cls.unpacker.format
        if "s" in fmt or "c" in fmt:
            continue
        lengths = cls.lengths
        if any(n != 1 for n in lengths):
            order = _with_arrays([(sum(lengths[:i]), lengths[i]) for i in cls.orders])
        elif len(cls.orders) > 1:
            order = operator.itemgetter(*cls.orders)
        else:
            order = _as_it_is
        plain[msgid] = _Plain(cls, cls.unpacker, order, bytes([cls.crc_extra]),
                              cls.unpacker.size)
    return plain


_PLAIN = _plain_messages()
_CRC16 = getattr(mavlink, "mcrf4xx", None)
"""fastcrc's CRC-16/MCRF4XX, which pymavlink's own x25crc calls when installed."""


def _crc(data: bytes) -> int:
    return _CRC16(data, 0xFFFF) if _CRC16 is not None else mavlink.x25crc(data).crc


class SkimmingParser(mavlink.MAVLink):
    """pymavlink's parser, decoding only the message ids in ``decoded`` (None: every one).

    ``parse_buffer`` frames the bytes in one pass and hands each wanted frame to pymavlink's
    own ``decode`` (CRC, signature, unpacking: the protocol stays pymavlink's). pymavlink's
    framing goes through three method calls and a buffer copy per frame, ~8 µs, which the
    autopilot's once-a-second burst of two dozen frames turned into the companion's slowest
    tick. The framing is pymavlink's robust parsing, byte for byte: a run of bytes that starts
    no frame is one BAD_DATA, a frame with unknown incompatibility flags or a bad CRC is one
    BAD_DATA and is skipped whole.

    An unsigned MAVLink 2 frame of a message of numbers (``_PLAIN``) on a link
    without signing is decoded here, as pymavlink's ``decode`` does it (the length and the
    CRC with the message's extra byte checked, the payload zero-extended or cut to the
    dialect's size, the fields put in declaration order, the message built by its own class
    and given the same header, payload, CRC and buffer), at under half its ~3–5 µs: the
    generic path's slices, header unpack and per-field loops were the tick's largest cost
    after the filter. Every other frame, and any this check refuses, goes to pymavlink,
    which also raises its own errors. A test holds the two equal, field for field.
    """

    decoded: frozenset[int] | None = None
    keep_skimmed = True
    """Whether ``parse_buffer`` returns the unread frames (as ``Skimmed``, for a recorder)
    or only counts them in ``skimmed``."""
    skimmed = 0
    unread: dict[tuple[int, int, int], int] | None = None
    """How many unread frames of each (system, component, message id) were dropped while
    framing, when a dict is given: what a sender streams that nothing reads (the bridge asks
    the autopilot to stop it)."""

    def decode(self, msgbuf: bytearray) -> mavlink.MAVLink_message:
        wanted = self.decoded
        if msgbuf[0] == V2:
            if len(msgbuf) < 12:
                return super().decode(msgbuf)
            msgid = msgbuf[7] | msgbuf[8] << 8 | msgbuf[9] << 16
            if wanted is not None and msgid not in wanted:
                return Skimmed(msgid, msgbuf)
            plain = _PLAIN.get(msgid)
            if plain is not None and not msgbuf[2] and self.signing.secret_key is None:
                msg = _decode_plain(msgbuf, msgid, plain)
                if msg is not None:
                    return msg
        elif wanted is not None and len(msgbuf) > 5 and msgbuf[5] not in wanted:
            return Skimmed(msgbuf[5], msgbuf)
        return super().decode(msgbuf)

    def parse_buffer(self, s: bytes) -> list[mavlink.MAVLink_message]:  # type: ignore[override]
        buf: bytearray = self.buf
        start: int = self.buf_index  # type: ignore[has-type]
        if start:
            del buf[:start]
            self.buf_index = 0
        buf += s
        self.total_bytes_received += len(s)
        out: list[mavlink.MAVLink_message] = []
        at, end = 0, len(buf)
        wanted = self.decoded
        dropping = wanted is not None and not self.keep_skimmed
        unread = self.unread
        counted = 0
        while at < end:
            magic = buf[at]
            if magic != V2 and magic != V1:
                starts = [k for k in (buf.find(m, at + 1) for m in MAGICS) if k >= 0]
                nxt = min(starts) if starts else end
                out.append(mavlink.MAVLink_bad_data(buf[at:nxt], "Bad prefix"))
                self.total_receive_errors += 1
                at = nxt
                continue
            if end - at < 3:
                break
            flags = buf[at + 2] if magic == V2 else 0
            size = buf[at + 1] + (mavlink.HEADER_LEN_V2 + 2 if magic == V2
                                  else mavlink.HEADER_LEN_V1 + 2)
            if flags & SIGNED:
                size += mavlink.MAVLINK_SIGNATURE_BLOCK_LEN
            if end - at < size:
                break
            if dropping and not flags & ~SIGNED:
                msgid = buf[at + 7] | buf[at + 8] << 8 | buf[at + 9] << 16 if magic == V2 \
                    else buf[at + 5]
                if msgid not in wanted:  # type: ignore[operator]
                    if unread is not None:
                        key = (buf[at + 5], buf[at + 6], msgid) if magic == V2 \
                            else (buf[at + 3], buf[at + 4], msgid)
                        unread[key] = unread.get(key, 0) + 1
                    at += size
                    counted += 1
                    continue
            frame = buf[at:at + size]
            at += size
            try:
                if flags & ~SIGNED:
                    raise mavlink.MAVError(f"invalid incompat_flags 0x{flags:x} 0x{magic:x} "
                                           f"{size}")
                msg = self.decode(frame)
            except mavlink.MAVError as exc:
                msg = mavlink.MAVLink_bad_data(frame, exc.message)
                self.total_receive_errors += 1
            out.append(msg)
        self.total_packets_received += len(out) + counted
        self.skimmed += counted
        del buf[:at]
        return out


def _decode_plain(msgbuf: bytearray, msgid: int, plain: _Plain
                  ) -> mavlink.MAVLink_message | None:
    """An unsigned MAVLink 2 frame of a message of numbers decoded as pymavlink does; None
    when its length or CRC is wrong (pymavlink then says why)."""
    mlen = msgbuf[1]
    if mlen != len(msgbuf) - 12:
        return None
    crc = msgbuf[-2] | msgbuf[-1] << 8
    if _crc(bytes(msgbuf[1:-2]) + plain.crc_extra) != crc:
        return None
    size = plain.size
    payload = bytes(msgbuf[10:-2])
    if mlen != size:
        payload = payload + bytes(size - mlen) if mlen < size else payload[:size]
    msg = plain.cls(*plain.order(plain.unpacker.unpack(payload)))
    msg._msgbuf = msgbuf
    msg._payload = msgbuf[6:-2]  # pymavlink's offset, a MAVLink 1 header's length
    msg._crc = crc
    msg._header = mavlink.MAVLink_header(msgid, 0, msgbuf[3], mlen, msgbuf[4], msgbuf[5],
                                         msgbuf[6])
    return msg


@dataclass
class AutopilotLink:
    """One MAVLink 2 connection to the autopilot; call ``poll`` once a tick."""

    url: str
    baud: int = 57600
    system_id: int = 1
    component_id: int = 191
    target_system: int = 1
    target_component: int = 1
    budget: int = READ_BUDGET
    transport: Transport | None = None
    stats: LinkStats = field(default_factory=LinkStats)
    events: list[str] = field(default_factory=list)
    generation: int = 0
    connected: bool = False
    recorder: Callable[[bytes], None] | None = None
    """Given every frame read and every frame sent (a ``.tlog``: ``tlog_writer.py``)."""

    def __post_init__(self) -> None:
        if self.transport is None:
            self.transport = transport_for(self.url, self.baud)
        self.mav = SkimmingParser(self, srcSystem=self.system_id,
                                  srcComponent=self.component_id)
        self.mav.robust_parsing = True
        self.mav.unread = {}
        self._buffer = bytearray(READ_CAP)
        self._socket = isinstance(self.transport, TcpTransport | UdpTransport)
        """A socket's read returns its whole queue, so a read short of the room left is the
        last one this tick (a tty's returns at most its line discipline's 4 KiB, which a
        921600-baud link outruns in a tick: it is read until empty)."""
        self.backoff = Backoff(RETRY_FIRST_S, RETRY_MAX_S)
        self._opened_at = 0.0
        self._opening = False
        self._last_failure = ""

    # -- connection -------------------------------------------------------------------------

    def _fail(self, now: float, why: str) -> None:
        assert self.transport is not None
        self.transport.close()
        was_up = self.connected
        self.connected = False
        self._opening = False
        if was_up:
            self.events.append(f"link to {self.url} lost: {why}; reconnecting")
            self.backoff.succeeded()
        elif why != self._last_failure:
            self.events.append(f"waiting for the autopilot at {self.url}: {why}; "
                               f"retrying every {self.backoff.delay_s:g}-"
                               f"{self.backoff.max_s:g} s")
        self._last_failure = why
        self.backoff.failed(now)

    def _connect(self, now: float) -> None:
        """Advance a connection attempt without blocking."""
        assert self.transport is not None
        try:
            if not self._opening:
                if not self.backoff.due(now):
                    return
                self._opened_at = now
                self.transport.open()
                self._opening = True
            if not self.transport.ready():
                if now - self._opened_at > CONNECT_TIMEOUT_S:
                    self._fail(now, "connection attempt timed out")
                return
        except OSError as exc:
            self._fail(now, exc.strerror or str(exc))
            return
        self._opening = False
        self.connected = True
        self.generation += 1
        self.stats.connects += 1
        self.backoff.succeeded()
        self._last_failure = ""
        self.mav.buf = bytearray()
        self.mav.buf_index = 0
        self.events.append(f"link to {self.url} open (MAVLink 2)")

    # -- traffic ----------------------------------------------------------------------------

    def poll(self, now: float) -> list[mavlink.MAVLink_message]:
        """Connect if need be, then read what arrived within the budget; never blocks."""
        if not self.connected:
            self._connect(now)
            if not self.connected:
                return []
        assert self.transport is not None
        view = memoryview(self._buffer)
        size = 0
        try:
            while size < READ_CAP:
                room = len(view) - size
                n = self.transport.read_into(view[size:])
                size += n
                drained = getattr(self.transport, "drained", False)  # a serial port says so
                if not n or (n < room and self._socket) or drained:
                    break
        except OSError as exc:
            self._fail(now, exc.strerror or str(exc))
            return []
        if not size:
            return []
        self.stats.bytes_read += size
        kept: list[mavlink.MAVLink_message] = []
        if size > self.budget:
            dropped = size - self.budget
            self.stats.bytes_dropped += dropped
            heartbeat = self._newest_heartbeat(self._buffer, dropped)
            if heartbeat is not None:
                kept.append(heartbeat)
            self.mav.buf = bytearray()
            self.mav.buf_index = 0
            data = bytes(view[dropped:size])
        else:
            data = bytes(view[:size])
        self.mav.keep_skimmed = self.recorder is not None
        skimmed = self.mav.skimmed
        try:
            kept.extend(self.mav.parse_buffer(data))
        except mavlink.MAVError as exc:
            kept.append(mavlink.MAVLink_bad_data(data, str(exc)))
        if self.recorder is not None:
            for msg in kept:
                if msg.get_type() != "BAD_DATA":
                    self.recorder(bytes(msg.get_msgbuf()))
        self.stats.skimmed += self.mav.skimmed - skimmed
        if self.mav.decoded is not None and self.mav.keep_skimmed:
            read = [msg for msg in kept if not isinstance(msg, Skimmed)]
            self.stats.skimmed += len(kept) - len(read)
            return read
        return kept

    def decode_only(self, names: Iterable[str]) -> None:
        """Decode only these messages (ardupilotmega names); the rest are skimmed."""
        self.mav.decoded = frozenset(getattr(mavlink, f"MAVLINK_MSG_ID_{name}")
                                     for name in names)

    def _newest_heartbeat(self, data: bytearray, end: int) -> mavlink.MAVLink_message | None:
        """The last valid HEARTBEAT from the autopilot in ``data[:end]`` (bytes about to be
        dropped), found backwards with a C-speed search for its header: system, component,
        message id 0."""
        marker = bytes([self.target_system, self.target_component, 0])
        at = end
        while (at := data.rfind(marker, 0, at)) >= 0:
            for start in (at - 5, at - 3):  # MAVLink 2 header (5 bytes before), MAVLink 1 (3)
                if start < 0 or data[start] not in (0xFD, 0xFE):
                    continue
                parser = mavlink.MAVLink(None)
                parser.robust_parsing = True
                for msg in parser.parse_buffer(bytes(data[start:start + 32])) or []:
                    if msg.get_type() == "HEARTBEAT" and msg.get_srcSystem() == \
                            self.target_system and msg.get_srcComponent() == \
                            self.target_component:
                        return msg
        return None

    def connect(self, now: float) -> bool:
        """Advance a connection attempt without reading; True once connected."""
        if not self.connected:
            self._connect(now)
        return self.connected

    # the byte counters a lockstep driver waits on (see ``mavhelm.sitl.lockstep``)
    def socket(self) -> socket.socket | None:
        return getattr(self.transport, "sock", None)

    def bytes_received(self) -> int:
        return self.stats.bytes_read

    def bytes_sent(self) -> int:
        return self.stats.bytes_written

    def unsent(self) -> int:
        """Bytes written but still queued in the transport (a TCP peer not reading yet)."""
        return int(getattr(self.transport, "unsent", 0))

    def write(self, data: bytes) -> None:
        """Called by pymavlink's encoder; dropped while the link is down."""
        if not self.connected:
            return
        assert self.transport is not None
        self.stats.bytes_written += self.transport.write(data)
        if self.recorder is not None:
            self.recorder(bytes(data))

    def fileno(self) -> int | None:
        assert self.transport is not None
        return self.transport.fileno()

    def close(self) -> None:
        assert self.transport is not None
        self.transport.close()
        self.connected = False

    def take_events(self) -> list[str]:
        out, self.events = self.events, []
        return out
