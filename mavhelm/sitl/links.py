"""The simulator's MAVLink links: TCP server ports like ArduPilot SITL, plus UDP outputs.

Every link has its own MAVLink encoder (own sequence numbers) and decoder, its own stream
rates, and exact byte counters: ``bytes_sent`` counts bytes the kernel accepted, and
``bytes_received`` bytes read from the socket, so a lockstep driver can wait for both sides to
have seen everything. Sockets are non-blocking; nothing here sleeps.

Link faults (link_drop, link_stall, link_garbage, link_duplicate, link_reorder) from a
``Scenario`` are applied to whole packets on the way out; drop and stall also act on input.
"""

from __future__ import annotations

import errno
import heapq
import select
import socket
from collections import Counter
from collections.abc import Iterable, Sequence
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

# fastcrc's CRC-16/MCRF4XX, which pymavlink's x25crc wraps when it is installed (None if not)
_MCRF4XX = getattr(mavlink, "mcrf4xx", None)


def _checksum(pkt: bytearray, crc_extra: int) -> int:
    """The MAVLink checksum of a packed packet (header after the magic byte, payload, then
    crc_extra): x25crc's value, without its object and per-call type checks when fastcrc is
    there (send_again runs for every stream message on every link)."""
    if _MCRF4XX is None:
        crc = mavlink.x25crc(pkt[1:-2])
        crc.accumulate(bytes((crc_extra,)))
        return crc.crc
    return _MCRF4XX(bytes((crc_extra,)), _MCRF4XX(bytes(pkt[1:-2]), 0xFFFF))

LINK_FAULTS = ("link_drop", "link_stall", "link_garbage", "link_duplicate", "link_reorder")


class Link:
    """One connection: a TCP client accepted on a server port, or a UDP output."""

    def __init__(self, sock: socket.socket, peer: tuple[str, int], index: int, kind: str,
                 srcSystem: int = 1, srcComponent: int = 1, scenario: Any = None,
                 serial: int = 0) -> None:
        self.sock = sock
        self.peer = peer
        self.index = index  # position in the simulator's port list (UDP outs follow the ports)
        self.kind = kind  # "tcp" or "udp"
        self.bytes_sent = 0
        self.bytes_received = 0
        self.received: Counter[str] = Counter()  # message types decoded from this peer
        self.closed = False
        # the encoder writes each packet it packs straight into write() below
        self.mav = mavlink.MAVLink(self, srcSystem=srcSystem, srcComponent=srcComponent)
        self.parser = mavlink.MAVLink(None, srcSystem=srcSystem, srcComponent=srcComponent)
        self.parser.robust_parsing = True
        self._out = bytearray()  # bytes accepted for sending, not yet written (TCP)
        self._dgrams: list[bytes] = []  # UDP datagrams not yet sent
        self._held: list[bytes] = []  # packets held by a link_stall
        self._reorder: bytes | None = None  # packet waiting to be swapped with the next
        # stream scheduling: msgid → interval (s); next due time; emission order
        self.intervals: dict[int, float] = {}
        self.next_due: dict[int, float] = {}
        self.order: dict[int, int] = {}
        self.next_any = 0.0  # earliest next_due of any scheduled message
        self._schedule: list[int] | None = None
        self._position: dict[int, int] = {}  # msgid → index in the schedule
        self._queue_due: list[tuple[float, int]] | None = None  # heap of (next_due, msgid)
        self.systems_seen: set[tuple[int, int]] = set()  # (sysid, compid) heard here
        self.scenario = scenario
        # one random stream per connection: port index and how many came before on that port
        self._rng = scenario.rng(f"link{index}/{serial}") if scenario is not None else None
        self._active: dict[str, Any] = {}

    # ------------------------------------------------------------------ streams
    def set_interval(self, msgid: int, interval: float, first_due: float) -> None:
        """Stream msgid every interval seconds (0 stops it), first at first_due."""
        self.intervals[msgid] = max(0.0, interval)
        if interval > 0:
            self.next_due[msgid] = first_due
            self.next_any = min(self.next_any, first_due)
        else:
            self.next_due.pop(msgid, None)
        self._schedule = None
        self._queue_due = None

    def schedule(self) -> list[int]:
        """Message ids currently streamed, in emission order."""
        if self._schedule is None:
            self._schedule = sorted((m for m, iv in self.intervals.items() if iv > 0),
                                    key=lambda m: (self.order.get(m, 1000), m))
            self._position = {m: i for i, m in enumerate(self._schedule)}
        return self._schedule

    def take_due(self, now: float, limit: float) -> list[int]:
        """The streamed ids due by ``limit``, in emission order, each moved on by its interval
        (from now if it fell a whole interval behind: late messages are not replayed). A heap
        of due times finds them without looking at every stream each step."""
        if self.next_any > limit:
            return []
        due, heap = self.next_due, self._queue_due
        if heap is None:
            heap = self._queue_due = [(t, m) for m, t in due.items()]
            heapq.heapify(heap)
        ready = []
        while heap and heap[0][0] <= limit:
            ready.append(heapq.heappop(heap)[1])
        self.schedule()
        ready.sort(key=self._position.__getitem__)
        for mid in ready:
            interval = self.intervals[mid]
            nxt = due[mid] + interval
            t = due[mid] = nxt if nxt > limit else now + interval
            heapq.heappush(heap, (t, mid))
        self.next_any = heap[0][0] if heap else 1e300
        return ready

    # ------------------------------------------------------------------ faults
    def update_faults(self, now: float) -> None:
        """Look up this link's active link faults once per step."""
        if self.scenario is None:
            return
        was_stalled = "link_stall" in self._active
        active: dict[str, Any] = {}
        for kind in LINK_FAULTS:
            for f in self.scenario.active(kind, now):
                target = f.params.get("link") if f.params else None
                if target is None or int(target) == self.index:
                    active[kind] = f
                    break
        self._active = active
        if was_stalled and "link_stall" not in active and self._held:
            held, self._held = self._held, []
            for pkt in held:
                self._queue(pkt)

    def input_blocked(self) -> bool:
        return "link_stall" in self._active

    def input_dropped(self) -> bool:
        return "link_drop" in self._active

    # ------------------------------------------------------------------ output
    def send(self, msg: Any) -> None:
        """Encode with this link's sequence numbers and queue for the socket."""
        self.mav.send(msg)

    def send_again(self, msg: Any) -> None:
        """Send msg, unchanged since it was last packed (on any link): that packet with this
        link's sequence number and checksum, the same bytes as packing it anew, so a stream
        message due on several links, or one that never changes, is packed once. Packs it
        (send()) unless that packet is an unsigned MAVLink 2 one from this link's source."""
        mav = self.mav
        pkt = bytearray(msg.get_msgbuf())
        if (len(pkt) < 12 or pkt[0] != mavlink.PROTOCOL_MARKER_V2 or pkt[2] != 0
                or mav.signing.sign_outgoing
                or (pkt[5], pkt[6]) != (mav.srcSystem, mav.srcComponent)):
            self.send(msg)
            return
        pkt[4] = mav.seq
        pkt[-2:] = _checksum(pkt, msg.crc_extra).to_bytes(2, "little")
        mav.seq = (mav.seq + 1) % 256
        mav.total_packets_sent += 1
        mav.total_bytes_sent += len(pkt)
        self.send_raw(bytes(pkt))

    def write(self, buf: bytes) -> None:
        """The file side of the link's encoder: one packed packet, queued as send_raw does."""
        self.send_raw(bytes(buf))

    def send_raw(self, pkt: bytes) -> None:
        """Queue an already-encoded packet (forwarding), through the link faults."""
        if not self._active:
            self._queue(pkt)
            return
        a = self._active
        if "link_drop" in a:
            return
        if "link_stall" in a:
            self._held.append(pkt)
            return
        rng = self._rng
        assert rng is not None  # faults are active only with a scenario
        if "link_garbage" in a and rng.random() < float(a["link_garbage"].params.get("prob", 0.1)):
            n = int(rng.integers(1, 16))
            self._queue(rng.integers(0, 256, n, dtype="uint8").tobytes())
        if "link_reorder" in a:
            if self._reorder is not None:
                first, self._reorder = self._reorder, None
                self._queue(pkt)
                self._queue(first)
                return
            if rng.random() < float(a["link_reorder"].params.get("prob", 0.1)):
                self._reorder = pkt
                return
        self._queue(pkt)
        if "link_duplicate" in a and rng.random() < float(
                a["link_duplicate"].params.get("prob", 0.1)):
            self._queue(pkt)

    def _queue(self, data: bytes) -> None:
        if self.kind == "udp":
            self._dgrams.append(data)
        else:
            self._out += data

    def flush(self) -> None:
        """Write as much as the kernel takes now; keep the rest for the next call."""
        if self._reorder is not None and "link_reorder" not in self._active:
            self._queue(self._reorder)
            self._reorder = None
        if self.closed:
            self._out.clear()
            self._dgrams.clear()
            return
        if self.kind == "udp":
            while self._dgrams:
                d = self._dgrams[0]
                try:
                    n = self.sock.send(d)
                except (BlockingIOError, InterruptedError):
                    return
                except OSError:
                    n = 0  # e.g. ICMP port unreachable: the datagram is lost
                else:
                    self.bytes_sent += n
                self._dgrams.pop(0)
            return
        while self._out:
            try:
                n = self.sock.send(self._out)
            except (BlockingIOError, InterruptedError):
                return
            except OSError:
                self.close()
                return
            if n <= 0:
                return
            self.bytes_sent += n
            del self._out[:n]

    @property
    def pending(self) -> int:
        """Bytes queued but not yet written."""
        return len(self._out) + sum(len(d) for d in self._dgrams)

    # ------------------------------------------------------------------ input
    def receive(self) -> list[Any]:
        """Read everything available now and decode it."""
        if self.closed or self.input_blocked():
            return []
        msgs: list[Any] = []
        while True:
            try:
                data = self.sock.recv(65536)
            except (BlockingIOError, InterruptedError):
                break
            except OSError as e:
                if self.kind == "udp" and e.errno in (errno.ECONNREFUSED, errno.EHOSTUNREACH):
                    continue
                self.close()
                break
            if not data:
                if self.kind == "tcp":
                    self.close()
                break
            self.bytes_received += len(data)
            if self.input_dropped():
                continue
            try:
                got = self.parser.parse_buffer(data)
            except Exception:  # noqa: BLE001 - a corrupt stream must never stop the simulator
                got = None
            for m in got or ():
                kind = m.get_type()
                if kind != "BAD_DATA":
                    self.received[kind] += 1
                    msgs.append(m)
        return msgs

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            try:
                self.sock.close()
            except OSError:
                pass


class LinkHub:
    """Listening TCP ports and UDP outputs; owns every live Link."""

    def __init__(self, ports: Sequence[int], host: str = "127.0.0.1",
                 udp_out: Iterable[tuple[str, int]] = (), srcSystem: int = 1,
                 srcComponent: int = 1, scenario: Any = None) -> None:
        self.servers: list[socket.socket] = []
        self.ports: list[int] = []
        self.links: list[Link] = []
        self._src = (srcSystem, srcComponent)
        self.scenario = scenario
        self.new_links: list[Link] = []
        self._accepted: dict[int, int] = {}
        self.host = host
        self._listening = select.poll()  # the servers, for accept()
        for port in ports:
            self.listen(port)
        for j, (uhost, uport) in enumerate(udp_out):
            u = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            u.setblocking(False)
            u.connect((uhost, int(uport)))
            self._add(Link(u, (uhost, int(uport)), len(self.ports) + j, "udp", *self._src,
                           scenario=scenario))

    def listen(self, port: int) -> int:
        """Open one more TCP server port (0: any free one); returns its number. Its index in
        ``ports`` is its link index."""
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        try:
            s.bind((self.host, int(port)))
            s.listen(8)
        except OSError:
            s.close()
            raise
        s.setblocking(False)
        self.servers.append(s)
        self._listening.register(s, select.POLLIN)
        self.ports.append(s.getsockname()[1])
        return self.ports[-1]

    def set_source(self, system: int, component: int = 1) -> None:
        """The (system, component) every link sends as, now and for links accepted later."""
        self._src = (system, component)
        for link in self.links:
            link.mav.srcSystem = system
            link.mav.srcComponent = component

    def _add(self, link: Link) -> None:
        self.links.append(link)
        self.new_links.append(link)

    def accept(self) -> None:
        """Take every pending TCP connection. Asked every step, so one poll() over the
        listening ports says which have any first (cheaper than an accept() refused on each)."""
        ready = {fd for fd, _ in self._listening.poll(0)}
        if not ready:
            return
        for i, s in enumerate(self.servers):
            if s.fileno() not in ready:
                continue
            while True:
                try:
                    c, peer = s.accept()
                except (BlockingIOError, InterruptedError):
                    break
                except OSError:
                    break
                c.setblocking(False)
                c.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                n = self._accepted.get(i, 0)
                self._accepted[i] = n + 1
                self._add(Link(c, peer, i, "tcp", *self._src, scenario=self.scenario, serial=n))

    def prune(self) -> None:
        self.links = [lk for lk in self.links if not lk.closed]

    def close(self) -> None:
        for lk in self.links:
            lk.close()
        for s in self.servers:
            self._listening.unregister(s)
            try:
                s.close()
            except OSError:
                pass
        self.links = []
        self.servers = []
