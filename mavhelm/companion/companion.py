"""The companion process: MAVLink bridge, navigator, helm and logger in one community.

Tick order is MAVLink in → pNav → pHelm → MAVLink out → logger, so sensor data that arrives in a
tick is acted on, and actuation stopped, in that same tick.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from mavhelm.companion.alog import AlogLogger, log_dir
from mavhelm.companion.bridge import BridgeConfig, MavlinkBridge
from mavhelm.companion.console import StatusConsole
from mavhelm.companion.link import AutopilotLink, transport_for
from mavhelm.companion.moos import MoosNotes, mission_notes
from mavhelm.companion.navlog import NavLogFiles
from mavhelm.companion.serial_instruments import (
    SerialInstrument,
    instruments_from_mission,
    is_instrument_block,
)
from mavhelm.companion.status_wire import STATUS_PAYLOAD_TYPE
from mavhelm.companion.tick_watch import TickWatch
from mavhelm.companion.tlog_writer import TlogWriter
from mavhelm.core.app import App
from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import Clock, PacedClock
from mavhelm.core.collector import IdleCollector
from mavhelm.core.community import Community
from mavhelm.core.errors import LocatedError, SettingError
from mavhelm.core.geodesy import Origin, mission_origin
from mavhelm.core.mission import Mission, MissionError, load_mission
from mavhelm.core.moos import FOREIGN, foreign
from mavhelm.nav.acoustics import BLOCK as ACOUSTICS
from mavhelm.nav.navigator import Navigator
from mavhelm.tasks.helm import Helm

PROCESSES = ("iMAVLink", "pNav", "pHelm", "pLogger")
"""The ProcessConfig blocks a mission may hold: one per app of the companion."""


def check_processes(mission: Mission) -> None:
    """Refuse a ProcessConfig block no app reads (a misspelt ``pHlem`` would otherwise be
    ignored, with every setting in it); another MOOS process's block (ANTLER, iGPS) is
    accepted and said on the console (:mod:`mavhelm.core.moos`); the original's Acoustics
    block is pNav's (:mod:`mavhelm.nav.acoustics`)."""
    known = {name.lower() for name in (*PROCESSES, ACOUSTICS)}
    for name, block in mission.processes.items():
        if name.lower() not in known and not is_instrument_block(name) and not foreign(name):
            raise block.error(f"unknown ProcessConfig = {name} (known: {', '.join(PROCESSES)}, "
                              "iSerial_<label>, and the MOOS processes mavhelm does not run: "
                              f"{', '.join(p.name for p in FOREIGN)})")


def _entries(mission: Mission, process: str) -> list[tuple[str, str]]:
    block = mission.process(process)
    return [] if block is None else [(e.key.lower(), e.value) for e in block.entries]


class HelmReloader(App):
    """Hears RESTART_HELM (from any app, or a ground station's MAV_CMD_USER_1 to the
    companion) and rebuilds the helm at the start of the next tick."""

    name = "pHelmReload"

    def __init__(self, bus: Bus, reload: Callable[[float], None]) -> None:
        super().__init__(bus)
        self._reload = reload
        self._asked = False

    def subscriptions(self) -> set[str]:
        return {"RESTART_HELM"}

    def on_mail(self, mail: list[Message], now: float) -> None:
        self._asked = self._asked or any(m.name == "RESTART_HELM" for m in mail)

    def iterate(self, now: float) -> None:
        if self._asked:
            self._asked = False
            self._reload(now)


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
    instruments: list[SerialInstrument] = dataclasses.field(default_factory=list)

    @classmethod
    def from_mission(cls, mission: Mission | str | Path, clock: Clock, *,
                     connect: str | None = None) -> Plan:
        if not isinstance(mission, Mission):
            mission = load_mission(mission)
        origin = mission_origin(mission)
        check_processes(mission)
        log_dir(mission)
        bus = Bus(clock)
        navigator = Navigator.from_mission(bus, mission)
        helm = Helm.from_mission(bus, mission)
        instruments = instruments_from_mission(bus, mission, origin)
        link = BridgeConfig.from_block(mission.process("iMAVLink"), helm.gains.max_rudder,
                                       helm.gains.max_elevator)
        if connect is not None:
            try:
                transport_for(connect, link.baud)
            except ValueError as exc:
                raise MissionError("--connect", 0, str(exc)) from None
            link.connect = connect
        for instrument in instruments:
            if os.path.realpath(instrument.config.port) == os.path.realpath(link.connect):
                block = mission.process(instrument.config.process)
                assert block is not None
                raise block.require("Port").error(
                    f"Port {instrument.config.port} is the autopilot's link (iMAVLink Connect)")
        return cls(mission, bus, navigator, helm, link, origin, instruments)


def _nav_logs(navigator: Navigator, alog_folder: Path, opened_on: float | None
              ) -> NavLogFiles:
    """pNav's .olog/.xlog where its settings say; a failure names those settings."""
    where = navigator.log_settings
    try:
        return NavLogFiles(where["nav_log_path"] or alog_folder, where["nav_log_stem"],
                           timestamp=where["nav_log_timestamp"], opened_on=opened_on)
    except (OSError, ValueError) as exc:
        raise SettingError("pNav NAV_LOG_PATH, NAV_LOG_STEM", "the nav logs", exc) from None


@dataclass
class Companion:
    mission: Mission
    bus: Bus
    bridge: MavlinkBridge
    navigator: Navigator
    helm: Helm
    community: Community
    tick_period: float
    plan: Plan
    nav_logs: NavLogFiles | None = None
    tlog: TlogWriter | None = None
    collector: IdleCollector = dataclasses.field(default_factory=IdleCollector)

    @classmethod
    def build(cls, mission: Mission | str | Path, clock: Clock, *, connect: str | None = None,
              link: AutopilotLink | None = None,
              alog_path: str | Path | None = None,
              alog_opened_on: float | None = None,
              echo: Callable[[str], None] | None = None,
              tlog_path: str | Path | None = None) -> Companion:
        """Everything is configured (and the mission validated) before the link is opened.
        ``tlog_path``: record the autopilot link's traffic there (``tlog_writer.py``)."""
        plan = Plan.from_mission(mission, clock, connect=connect)
        bus, navigator, helm = plan.bus, plan.navigator, plan.helm
        bridge = MavlinkBridge(bus, plan.link, plan.origin, link,
                               time_source=getattr(clock, "observe", None))
        bridge.gate.guests = helm.third_party.bound_senders()
        apps: list[App] = [*plan.instruments, bridge.input, navigator, helm, bridge.output]
        nav_logs: NavLogFiles | None = None
        if alog_path is not None:
            try:
                apps.append(AlogLogger(bus, alog_path, clock.now(), opened_on=alog_opened_on))
            except (OSError, ValueError) as exc:
                raise SettingError("pLogger LogDir", f"the .alog {str(alog_path)!r}",
                                   exc) from None
            if navigator.wants_log:
                nav_logs = _nav_logs(navigator, Path(alog_path).parent, alog_opened_on)
                navigator.log = nav_logs
        apps.append(StatusConsole(
            bus, echo, statustext=bridge.send_statustext,
            tunnel=lambda payload: bridge.send_tunnel(STATUS_PAYLOAD_TYPE, payload,
                                                      target=(0, 0))))
        companion = cls(plan.mission, bus, bridge, navigator, helm, Community(bus, apps),
                        1.0 / helm.app_tick, plan, nav_logs)
        companion.community.apps.insert(0, HelmReloader(bus, companion.reload))
        companion.community.apps.insert(0, MoosNotes(bus, mission_notes(plan.mission)))
        if tlog_path is not None:
            try:
                # stamped on the companion's clock, as the .alog is: beside a SITL run faster
                # than real time (--clock autopilot) wall stamps would replay it that much slower
                companion.tlog = TlogWriter(
                    tlog_path, clock=bus.clock.now,
                    on_error=lambda why: bus.notify("TLOG_WARNING", why, "pLogger"))
            except (OSError, ValueError) as exc:
                companion.close()
                raise SettingError("--log-dir", f"the .tlog {str(tlog_path)!r}", exc) from None
            bridge.link.recorder = companion.tlog.record
        return companion

    def tick(self, now: float) -> None:
        self.community.tick(now)

    def idle(self) -> None:
        """The loop's time between a tick and its sleep: the logs are written and flushed,
        the ground station's telemetry sent and garbage collected
        (:mod:`mavhelm.core.collector`) here, not inside a tick, between the data coming in
        and the commands going out. Every loop that ticks a companion calls it."""
        self.community.idle()
        if self.tlog is not None:
            self.tlog.flush()
        self.collector.idle()

    def run_until(self, clock: PacedClock, done: Callable[[], bool]) -> None:
        """Tick in time on ``clock`` (the wall, or the autopilot's) until ``done()``: a late
        tick is not followed by a burst of catch-ups, and ticks that overrun their period are
        told to the operator as ``COMPANION_WARNING`` (:mod:`mavhelm.companion.tick_watch`)."""
        watch = TickWatch(self.tick_period)
        next_tick = clock.now()
        while not done():
            started = clock.now()
            self.tick(started)
            self.idle()
            late = watch.finished(started, clock.now())
            if late is not None:
                self.bus.notify("COMPANION_WARNING", late, "mavhelm")
            next_tick += self.tick_period
            if next_tick < clock.now() - self.tick_period:
                next_tick = clock.now()
            clock.sleep_until(next_tick)

    def reload(self, now: float) -> None:
        """RESTART_HELM (spec 1): re-read the mission file and its TaskFile and rebuild the
        helm. The new mission is read and checked whole first; on any error the running
        mission carries on untouched and the error goes to the operator."""
        try:
            plan = Plan.from_mission(self.mission.path, self.bus.clock)
        except LocatedError as exc:
            self.bus.notify("HELM_RELOAD_ERROR", f"reload refused, the running mission "
                            f"continues: {exc}", "pHelm")
            return
        helm = plan.helm
        helm.bus = self.bus
        helm.online = self.helm.online
        helm.nav = self.helm.nav
        apps = self.community.apps
        apps[apps.index(self.helm)] = helm
        self.bridge.gate.guests = helm.third_party.bound_senders()
        link = plan.link.replace(connect=self.plan.link.connect)  # --connect kept
        kept = [what for what, same in (("iMAVLink", link == self.plan.link),
                                        ("origin", plan.origin == self.plan.origin),
                                        ("pNav", _entries(plan.mission, "pNav")
                                         == _entries(self.mission, "pNav")))
                if not same]
        if kept:
            self.bus.notify("HELM_WARNING", f"reload: {', '.join(kept)} changes need a restart "
                            "of mavhelm run; the running link and navigator are kept", "pHelm")
        self.helm, self.mission = helm, plan.mission
        self.plan = Plan(plan.mission, self.bus, self.navigator, helm, self.plan.link,
                         self.plan.origin, self.plan.instruments)
        self.bus.notify("HELM_RELOADED", f"{plan.mission.path}: {len(helm.tasks)} tasks",
                        "pHelm")

    def mission_over(self) -> bool:
        """EndMission is active and any hand-back to the autopilot has been settled."""
        handback = self.bridge.handback
        return self.helm.mission_ended and (handback is None or handback.done)

    def close(self) -> None:
        self.collector.close()
        self.community.close()
        if self.nav_logs is not None:
            self.nav_logs.close()
        if self.tlog is not None:
            self.tlog.close()
