"""The companion process: MAVLink bridge, navigator, helm and logger in one community.

Tick order is MAVLink in → pNav → pHelm → MAVLink out → logger, so sensor data that arrives in a
tick is acted on, and actuation stopped, in that same tick.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from mavhelm.companion.alog import AlogLogger
from mavhelm.companion.console import StatusConsole
from mavhelm.companion.link import AutopilotLink, transport_for
from mavhelm.companion.mavlink_bridge import BridgeConfig, MavlinkBridge
from mavhelm.core.bus import Bus
from mavhelm.core.clock import Clock
from mavhelm.core.community import Community
from mavhelm.core.geodesy import Origin, mission_origin
from mavhelm.core.mission import Mission, MissionError, load_mission
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
class Plan:
    """A mission read and checked whole — every block, every setting — before any link opens.

    Building one is how a mission is validated: ``mavhelm run`` refuses to start, and a
    reload would refuse to replace the running mission, unless this succeeds.
    """

    mission: Mission
    bus: Bus
    navigator: Navigator
    helm: Helm
    link: BridgeConfig
    origin: Origin

    @classmethod
    def from_mission(cls, mission: Mission | str | Path, clock: Clock, *,
                     connect: str | None = None) -> Plan:
        if not isinstance(mission, Mission):
            mission = load_mission(mission)
        origin = mission_origin(mission)
        check_processes(mission)
        bus = Bus(clock)
        navigator = Navigator.from_mission(bus, mission)
        helm = Helm.from_mission(bus, mission)
        link = BridgeConfig.from_block(mission.process("iMAVLink"), helm.gains.max_rudder)
        if connect is not None:
            try:
                transport_for(connect, link.baud)
            except ValueError as exc:
                raise MissionError("--connect", 0, str(exc)) from None
            link.connect = connect
        return cls(mission, bus, navigator, helm, link, origin)


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
              link: AutopilotLink | None = None,
              alog_path: str | Path | None = None,
              alog_opened_on: float | None = None,
              echo: Callable[[str], None] | None = None) -> Companion:
        """Everything is configured (and the mission validated) before the link is opened."""
        plan = Plan.from_mission(mission, clock, connect=connect)
        bus, navigator, helm = plan.bus, plan.navigator, plan.helm
        bridge = MavlinkBridge(bus, plan.link, plan.origin, link,
                               time_source=getattr(clock, "observe", None))
        apps = [bridge.input, navigator, helm, bridge.output]
        if alog_path is not None:
            apps.append(AlogLogger(bus, alog_path, clock.now(), opened_on=alog_opened_on))
        apps.append(StatusConsole(bus, echo, statustext=bridge.send_statustext))
        return cls(plan.mission, bus, bridge, navigator, helm, Community(bus, apps),
                   1.0 / helm.app_tick)

    def tick(self, now: float) -> None:
        self.community.tick(now)

    def mission_over(self) -> bool:
        """EndMission is active and any hand-back to the autopilot has been settled."""
        handback = self.bridge.handback
        return self.helm.mission_ended and (handback is None or handback.done)

    def close(self) -> None:
        self.community.close()
