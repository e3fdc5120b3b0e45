"""Lockstep: the simulator and its MAVLink peers share one simulated clock over real sockets.

Each step the clock advances, the simulator steps and emits, every byte it sent is waited for
at each peer's socket, the peers tick, and every byte they sent is waited for at the
simulator's socket. The wait compares byte counts (the simulator's link counters against
pymavlink's ``total_bytes_*`` plus what sits in the socket, read with FIONREAD), so the run is
deterministic without sleeps, whatever the protocol carries.

A wait that makes no progress for a while means a peer is stuck, so it fails with a
``LockstepError`` after a wall-clock stall limit: 5 s unless the environment variable
``MAVHELM_LOCKSTEP_STALL_S`` gives another (a positive, finite number of seconds, e.g. 30 on a
slow or loaded machine; anything else is refused with a ValueError). The variable is read when
a ``Lockstep`` is built, and a ``wall_timeout`` passed to it explicitly takes precedence.
"""

from __future__ import annotations

import fcntl
import math
import os
import select
import socket
import struct
import termios
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Protocol

from pymavlink import mavutil

from mavhelm.core.clock import SimClock

if TYPE_CHECKING:
    from mavhelm.sitl.links import Link

STALL_ENV = "MAVHELM_LOCKSTEP_STALL_S"
DEFAULT_STALL_S = 5.0


class LockstepError(RuntimeError):
    pass


def stall_limit() -> float:
    """The wall-clock stall limit in seconds: $MAVHELM_LOCKSTEP_STALL_S, or 5 s when unset."""
    raw = os.environ.get(STALL_ENV)
    if raw is None:
        return DEFAULT_STALL_S
    try:
        value = float(raw)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise ValueError(
            f"{STALL_ENV} must be a positive, finite number of seconds, got {raw!r}")
    return value


def pending_bytes(sock) -> int:
    """Bytes waiting in a socket's receive queue."""
    raw = fcntl.ioctl(sock.fileno(), termios.FIONREAD, b"\0\0\0\0")
    return struct.unpack("i", raw)[0]


class Endpoint(Protocol):
    """A peer's end of its connection to the simulator: its socket and byte counters."""

    def socket(self) -> socket.socket | None: ...
    def bytes_received(self) -> int: ...
    def bytes_sent(self) -> int: ...
    def connect(self, now: float) -> bool: ...


class MavfileEndpoint:
    """A pymavlink connection as an endpoint (ground stations, test clients)."""

    def __init__(self, conn: mavutil.mavfile) -> None:
        self.conn = conn

    def socket(self) -> socket.socket | None:
        return self.conn.port

    def bytes_received(self) -> int:
        return self.conn.mav.total_bytes_received

    def bytes_sent(self) -> int:
        return self.conn.mav.total_bytes_sent

    def connect(self, now: float) -> bool:
        return True


@dataclass
class Peer:
    end: Endpoint
    tick: Callable[[float], None]
    link: Link | None = None  # the simulator's side, once it has accepted


class Lockstep:
    def __init__(self, sim, clock: SimClock, dt: float,
                 wall_timeout: float | None = None) -> None:
        self.sim = sim
        self.clock = clock
        self.dt = dt
        self.wall_timeout = stall_limit() if wall_timeout is None else wall_timeout
        self.peers: list[Peer] = []

    def add_peer(self, conn: mavutil.mavfile | Endpoint, tick: Callable[[float], None]) -> None:
        """A connection to one of the simulator's TCP ports (a pymavlink connection or an
        endpoint with its own byte counters, such as the companion's autopilot link), and what
        to run each step."""
        end = MavfileEndpoint(conn) if isinstance(conn, mavutil.mavfile) else conn
        peer = Peer(end, tick)
        peer.link = self._wait_for_link(end)
        self.peers.append(peer)

    def remove_peer(self, conn: mavutil.mavfile | Endpoint) -> None:
        """Stop stepping a peer (before it disconnects): the simulator no longer waits for it."""
        self.peers = [p for p in self.peers
                      if p.end is not conn and getattr(p.end, "conn", None) is not conn]

    def _wait_for_link(self, end: Endpoint):
        deadline = time.monotonic() + self.wall_timeout
        local = None
        while time.monotonic() < deadline:
            self.sim.service(self.clock.now())
            sock = end.socket() if end.connect(self.clock.now()) else None
            if sock is not None:
                local = sock.getsockname()
                for link in self.sim.links:
                    if tuple(link.peer[:2]) == tuple(local[:2]):
                        return link
            select.select([], [], [], 0.001)
        raise LockstepError(f"the simulator never accepted the connection from {local}")

    def _wait(self, done: Callable[[], bool], sock, what: str) -> None:
        if done():
            return
        deadline = time.monotonic() + self.wall_timeout
        while not done():
            if time.monotonic() > deadline:
                raise LockstepError(f"lockstep stalled waiting for {what}")
            select.select([sock], [], [], 0.001)

    def _deliver_to_peer(self, peer: Peer) -> None:
        link, end = peer.link, peer.end
        assert link is not None
        if end.bytes_received() >= link.bytes_sent:
            return  # nothing new was sent (a quiet link, most steps): no FIONREAD
        sock = end.socket()
        self._wait(lambda: end.bytes_received() + pending_bytes(sock) >= link.bytes_sent,
                   sock, "a peer to receive the simulator's bytes")

    def _deliver_to_sim(self, peer: Peer) -> None:
        link, end = peer.link, peer.end
        assert link is not None
        if link.bytes_received >= end.bytes_sent():
            return
        self._wait(lambda: link.bytes_received + pending_bytes(link.sock) >= end.bytes_sent(),
                   link.sock, "the simulator to receive a peer's bytes")

    def step(self) -> float:
        now = self.clock.advance(self.dt)
        self.sim.step(now)
        for port in self.sim.serial_sensors:
            port.settle()
        for peer in self.peers:
            self._deliver_to_peer(peer)
        for peer in self.peers:
            peer.tick(now)
        for peer in self.peers:
            self._deliver_to_sim(peer)
        return now

    def run_until(self, done: Callable[[float], bool], max_time: float) -> bool:
        """Step until done(now) or max_time of simulated time has passed; returns done."""
        end = self.clock.now() + max_time
        while self.clock.now() < end:
            now = self.step()
            if done(now):
                return True
        return False
