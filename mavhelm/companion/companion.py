"""The companion process: MAVLink bridge, navigator, helm and logger in one community.

Tick order is MAVLink in → pNav → pHelm → MAVLink out → logger, so sensor data that arrives in a
tick is acted on, and actuation stopped, in that same tick.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from pymavlink import mavutil

from mavhelm.companion.alog import AlogLogger
from mavhelm.companion.mavlink_bridge import MavlinkBridge
from mavhelm.core.bus import Bus
from mavhelm.core.clock import Clock
from mavhelm.core.community import Community
from mavhelm.core.mission import Mission, load_mission
from mavhelm.nav.navigator import Navigator
from mavhelm.tasks.helm import Helm

PROCESSES = ("iMAVLink", "pNav", "pHelm")
"""The ProcessConfig blocks a mission may hold: one per app of the companion."""


def check_processes(mission: Mission) -> None:
    """Refuse a ProcessConfig block no app reads (a misspelt ``pHlem`` would otherwise be
    ignored, with every setting in it)."""
    known = {name.lower() for name in PROCESSES}
    for name, block in mission.processes.items():
        if name.lower() not in known:
            raise block.error(f"unknown ProcessConfig = {name} (known: {', '.join(PROCESSES)})")


@dataclass
class Companion:
    mission: Mission
    bus: Bus
    bridge: MavlinkBridge
    navigator: Navigator
    helm: Helm
    community: Community
    tick_period: float

    @classmethod
    def build(cls, mission: Mission | str | Path, clock: Clock, *, connect: str | None = None,
              connection: mavutil.mavfile | None = None,
              alog_path: str | Path | None = None,
              alog_opened_on: float | None = None) -> Companion:
        """Everything is configured (and the mission validated) before the link is opened."""
        if not isinstance(mission, Mission):
            mission = load_mission(mission)
        check_processes(mission)
        bus = Bus(clock)
        navigator = Navigator.from_mission(bus, mission)
        helm = Helm.from_mission(bus, mission)
        bridge = MavlinkBridge.from_mission(bus, mission, connect=connect, connection=connection,
                                            max_rudder=helm.gains.max_rudder)
        apps = [bridge.input, navigator, helm, bridge.output]
        if alog_path is not None:
            apps.append(AlogLogger(bus, alog_path, clock.now(), opened_on=alog_opened_on))
        return cls(mission, bus, bridge, navigator, helm, Community(bus, apps), 1.0 / helm.app_tick)

    def tick(self, now: float) -> None:
        self.community.tick(now)

    def close(self) -> None:
        self.community.close()
