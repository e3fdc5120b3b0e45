"""The companion process: MAVLink bridge, navigator, helm and logger in one community.

Tick order is MAVLink in → pNav → pHelm → MAVLink out → logger, so sensor data that arrives in a
tick is acted on, and actuation stopped, in that same tick.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from pymavlink import mavutil

from mavhelm.companion.alog import AlogLogger
from mavhelm.companion.bus import Bus
from mavhelm.companion.clock import Clock
from mavhelm.companion.community import Community
from mavhelm.companion.mavlink_bridge import MavlinkBridge
from mavhelm.companion.mission import Mission, load_mission
from mavhelm.nav.navigator import Navigator
from mavhelm.tasks.helm import Helm

DEFAULT_APP_TICK = 10.0


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
        bus = Bus(clock)
        navigator = Navigator.from_mission(bus, mission)
        helm = Helm.from_mission(bus, mission)
        app_tick = helm.block.get_float("AppTick", DEFAULT_APP_TICK)
        if app_tick <= 0:
            raise helm.block.require("AppTick").error("AppTick must be a positive rate in Hz")
        bridge = MavlinkBridge.from_mission(bus, mission, connect=connect, connection=connection)
        apps = [bridge.input, navigator, helm, bridge.output]
        if alog_path is not None:
            apps.append(AlogLogger(bus, alog_path, clock.now(), opened_on=alog_opened_on))
        return cls(mission, bus, bridge, navigator, helm, Community(bus, apps), 1.0 / app_tick)

    def tick(self, now: float) -> None:
        self.community.tick(now)

    def close(self) -> None:
        self.community.close()
