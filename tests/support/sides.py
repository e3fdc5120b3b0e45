"""Where a scripted session runs: the real ArduPilot SITL, or ``mavhelm sim`` in lockstep.

The conformance scenario and the braking script play the same ground-station part against
both; each side gives them pymavlink connections (``gcs``, and ``companion`` when asked for)
and ``pump()``, which lets a little time pass and returns what arrived, tagged with the
connection it came on. ``RealSide`` polls sockets while the binary runs; ``SimSide`` steps the
simulator (``sitl_rig.Rig``).
"""

from __future__ import annotations

import select
from typing import Any, Protocol

GCS = (255, 190)
"""The ground station's system and component: MAV_GCS_SYSID's 255, Mission Planner's 190."""
COMPANION = (254, 191)
"""The companion's link: component 191, system 254 so its traffic is told apart."""


class Side(Protocol):
    """Where a script runs: its pymavlink connections and a way to let time pass."""

    gcs: Any
    companion: Any

    def pump(self) -> list[tuple[str, Any]]:
        """Let a little time pass; return the new messages as ("gcs"|"companion", msg)."""
        ...

    def wall_per_autopilot_s(self) -> float:
        """Roughly how many wall seconds one autopilot second takes (for heartbeats)."""
        ...


class RealSide:
    """The real SITL: the GCS on SERIAL0 first (its clock starts then), the companion (if
    ``companion``) on SERIAL1 once it opens."""

    def __init__(self, sitl: Any, *, companion: bool = True) -> None:
        from tests.support.ardupilot import connect_tcp

        self.sitl = sitl
        self.gcs = connect_tcp(sitl.ports.serial0, source_system=GCS[0],
                               source_component=GCS[1])
        self.companion = None
        if companion:
            sitl.wait_listening(sitl.ports.serial1)
            self.companion = connect_tcp(sitl.ports.serial1, source_system=COMPANION[0],
                                         source_component=COMPANION[1])

    def _conns(self) -> list[tuple[str, Any]]:
        return [("gcs", self.gcs)] + ([("companion", self.companion)] if self.companion else [])

    def pump(self) -> list[tuple[str, Any]]:
        from tests.support.ardupilot import read_available

        conns = self._conns()
        select.select([c.port for _, c in conns], [], [], 0.005)
        return [(who, m) for who, c in conns for m in read_available(c)]

    def wall_per_autopilot_s(self) -> float:
        return 1.0 / self.sitl.speedup

    def close(self) -> None:
        for _, conn in self._conns():
            conn.close()


class SimSide:
    """``mavhelm sim``'s Simulator in lockstep with a simulated clock (``sitl_rig.Rig``),
    ``dt`` autopilot seconds a pump. Built with ``wait_for_client=True`` it behaves as the real
    SITL: the GCS on the first port starts its clock and opens the second port, where the
    companion (if ``companion``) then connects."""

    def __init__(self, rig: Any, dt: float = 0.05, *, companion: bool = True) -> None:
        self.rig = rig
        self.dt = dt
        self._clients = [("gcs", rig.connect(0, *GCS))]
        if companion:
            self._clients.append(("companion", rig.connect(1, *COMPANION)))
        self.gcs = self._clients[0][1].conn
        self.companion = self._clients[1][1].conn if companion else None
        self._seen = [0] * len(self._clients)

    def pump(self) -> list[tuple[str, Any]]:
        self.rig.step(self.dt)
        out: list[tuple[str, Any]] = []
        for i, (who, c) in enumerate(self._clients):
            out.extend((who, m) for m in c.msgs[self._seen[i]:])
            self._seen[i] = len(c.msgs)
        return out

    def wall_per_autopilot_s(self) -> float:
        return 0.0

    def close(self) -> None:
        """The rig closes its own clients."""
