"""The conformance rig for the simulator's MAVLink side (test_sitl_core, test_sitl_protocol).

``Rig`` drives a Simulator with a SimClock and talks to it with pymavlink, as a companion or a
ground station would. It delivers bytes exactly (byte counters + FIONREAD), so the tests are
deterministic and need no sleeps. Its wall-clock stall limit is the lockstep one
(``MAVHELM_LOCKSTEP_STALL_S``, 5 s by default). ``FakeScenario``/``FakeFault`` stand in for a
fault scenario file. Tests get a ready ``rig`` from the fixture in conftest.py, or build a
``Rig(...)`` themselves when they need other simulator settings.

A plain helper module (not a test module), imported by the tests that use it.
"""

from __future__ import annotations

import select
import time
from dataclasses import dataclass, field
from typing import Any

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.core.clock import SimClock
from mavhelm.sitl.lockstep import pending_bytes, stall_limit
from mavhelm.sitl.simulator import Simulator
from tests.support.ground_station import GroundStation
from tests.support.waiting import wait_for

M = mavlink


@dataclass
class Client(GroundStation):
    """One pymavlink connection to the simulator (a ground station or a companion) and every
    message it has received, commanding the autopilot (1/1) as ``GroundStation``."""

    conn: mavutil.mavfile
    link: Any
    msgs: list = field(default_factory=list)

    @property
    def mav(self) -> Any:
        return self.conn.mav

    def of(self, kind: str) -> list:
        return [m for m in self.msgs if m.get_type() == kind]

    def texts(self) -> list[str]:
        return [m.text for m in self.of("STATUSTEXT")]

    def acks(self, command: int | None = None) -> list:
        return [m for m in self.of("COMMAND_ACK") if command is None or m.command == command]

    def last(self, kind: str):
        got = self.of(kind)
        return got[-1] if got else None


class Rig:
    """A simulator, a simulated clock and pymavlink clients, delivered in lockstep."""

    def __init__(self, **kw) -> None:
        kw.setdefault("ports", (0, 0, 0))
        kw.setdefault("fast_start", True)
        self.wall_timeout = stall_limit()
        self.clock = SimClock(0.0)
        self.sim = Simulator(self.clock, **kw)
        self.clients: list[Client] = []

    def connect(self, port_index: int = 0, sysid: int = 255, compid: int = 190) -> Client:
        conn = mavutil.mavlink_connection(f"tcp:127.0.0.1:{self.sim.ports[port_index]}",
                                          source_system=sysid, source_component=compid,
                                          dialect="ardupilotmega")
        local = conn.port.getsockname()
        deadline = time.monotonic() + self.wall_timeout
        while time.monotonic() < deadline:
            self.sim.service(self.clock.now())
            for link in self.sim.links:
                if tuple(link.peer[:2]) == tuple(local[:2]):
                    c = Client(conn, link)
                    self.clients.append(c)
                    return c
            select.select([], [], [], 0.001)
        raise AssertionError("simulator did not accept")

    def _wait(self, done, sock) -> None:
        wait_for(done, self.wall_timeout, "the bytes sent to arrive (lockstep stalled)",
                 pause=lambda: select.select([sock], [], [], 0.001))

    def deliver(self) -> None:
        """Make sure the simulator's socket holds everything the clients sent."""
        for c in self.clients:
            if c.link.closed:
                continue
            self._wait(lambda c=c: c.link.bytes_received + pending_bytes(c.link.sock)
                       >= c.mav.total_bytes_sent, c.link.sock)

    def step(self, dt: float = 0.05, n: int = 1) -> None:
        for _ in range(n):
            self.deliver()
            self.sim.step(self.clock.advance(dt))
            for c in self.clients:
                self._wait(lambda c=c: c.mav.total_bytes_received + pending_bytes(c.conn.port)
                           >= c.link.bytes_sent, c.conn.port)
                while (m := c.conn.recv_msg()) is not None:
                    if m.get_type() != "BAD_DATA":
                        c.msgs.append(m)

    def run(self, seconds: float, dt: float = 0.05) -> None:
        self.step(dt, int(round(seconds / dt)))

    def until(self, pred, max_time: float, dt: float = 0.05) -> bool:
        end = self.clock.now() + max_time
        while self.clock.now() < end:
            self.step(dt)
            if pred():
                return True
        return False

    def close(self) -> None:
        for c in self.clients:
            c.conn.close()
        self.sim.close()


def command(c: Client, cmd: int, *params: float) -> None:
    """COMMAND_LONG from ``c`` to the autopilot (1/1)."""
    c.command(cmd, *params)


def arm_guided(r: Rig, c: Client) -> None:
    r.run(3.0)
    command(c, M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    r.step()
    command(c, M.MAV_CMD_DO_SET_MODE, 1, 15)
    r.step()
    assert r.sim.armed and r.sim.mode == "GUIDED"


@dataclass
class FakeFault:
    kind: str
    start: float
    end: float
    params: dict


class FakeScenario:
    """The faults.Scenario protocol: active(kind, t) and rng(name)."""

    def __init__(self, faults: list[FakeFault]) -> None:
        self.faults = faults

    def active(self, kind: str, t: float) -> list[FakeFault]:
        return [f for f in self.faults if f.kind == kind and f.start <= t < f.end]

    def rng(self, name: str):
        import zlib

        import numpy as np
        return np.random.default_rng(zlib.crc32(name.encode()))
