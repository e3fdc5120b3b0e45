"""A mission run end to end against the built-in simulator, in lockstep, over real TCP.

The companion connects to the simulator's first port as it would to an autopilot; a scripted
ground station on the second port hands control over (arm, GUIDED) as an operator would. The
demo, the end-to-end tests and the benchmarks all drive missions through this one path.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

from mavhelm.companion.companion import Companion
from mavhelm.core.bus import Message
from mavhelm.core.clock import SimClock
from mavhelm.core.geodesy import mission_origin
from mavhelm.core.mission import Mission, load_mission
from mavhelm.demo.groundstation import GroundStation, Operator
from mavhelm.sitl import flat_earth
from mavhelm.sitl.lockstep import Lockstep
from mavhelm.sitl.models import DEFAULT_MODEL
from mavhelm.sitl.simulator import Simulator
from mavhelm.sitl.truth import Truth

RECORDED = {
    "TASK_STARTED", "TASK_ENDED", "HELM_STATE", "HELM_ONLINE", "HELM_RUDDER_OWNER",
    "MISSION_ENDED", "AP_MODE", "AP_LINK", "AP_STATUSTEXT", "NAV_X", "NAV_Y", "NAV_HEADING",
    "NAV_X_SOURCE", "NAV_Y_SOURCE", "DESIRED_RUDDER", "DESIRED_THRUST", "MAVLINK_BAD_PACKETS",
}


@dataclass
class SimulatedRun:
    mission: Mission
    clock: SimClock
    sim: Simulator
    companion: Companion
    gcs: GroundStation
    operator: Operator
    lockstep: Lockstep
    track: list[Truth] = field(default_factory=list)
    messages: list[Message] = field(default_factory=list)
    record: set[str] = field(default_factory=lambda: set(RECORDED))
    wall_seconds: float = 0.0
    companion_tick_seconds: list[float] = field(default_factory=list)
    before_companion: Callable[[float], None] | None = None
    ended_at: float | None = None

    @classmethod
    def start(cls, mission: Mission | str | Path, *, model: str = DEFAULT_MODEL,
              defaults: str | None = None, fast_start: bool = True, scenario=None,
              seed: int = 0, alog_path: str | Path | None = None,
              start_heading: float = 0.0, params: dict[str, float] | None = None,
              record: Iterable[str] = (), operator_mode: str = "GUIDED",
              serial_sensors: Iterable = ()) -> SimulatedRun:
        """``serial_sensors``: the simulator's instrument ports (ptys the mission's iSerial
        blocks read), updated every simulator step. ``model``: a name of the model registry
        (``sitl.models.MODELS``); ``defaults`` are ``.parm`` files."""
        if not isinstance(mission, Mission):
            mission = load_mission(mission)
        clock = SimClock(0.0)
        origin = mission_origin(mission)
        sim = Simulator(clock, model=model, defaults=defaults, ports=(0, 0, 0),
                        home=flat_earth.Origin(origin.lat, origin.lon),
                        start_heading=start_heading,
                        fast_start=fast_start, scenario=scenario, seed=seed, params=params,
                        serial_sensors=list(serial_sensors))
        companion = Companion.build(mission, clock, connect=f"tcp:127.0.0.1:{sim.ports[0]}",
                                    alog_path=alog_path, alog_opened_on=time.time())
        gcs = GroundStation.connect(f"tcp:127.0.0.1:{sim.ports[1]}")
        operator = Operator(gcs, mode=operator_mode)
        lockstep = Lockstep(sim, clock, dt=companion.tick_period)
        run = cls(mission, clock, sim, companion, gcs, operator, lockstep)
        run.record |= set(record)
        companion.bus.subscribe("harness", ["*"])
        lockstep.add_peer(companion.bridge.link, run._companion_tick)
        lockstep.add_peer(gcs.conn, operator.tick)
        return run

    def _companion_tick(self, now: float) -> None:
        if self.before_companion is not None:
            self.before_companion(now)
        t0 = time.perf_counter()
        self.companion.tick(now)
        self.companion_tick_seconds.append(time.perf_counter() - t0)
        self.companion.idle()
        for m in self.companion.bus.fetch("harness"):
            if m.name in self.record or m.name.endswith("_ERROR"):
                self.messages.append(m)
                if m.name == "MISSION_ENDED" and self.ended_at is None:
                    self.ended_at = m.time
        self.track.append(self.sim.truth)

    def step(self) -> float:
        t0 = time.perf_counter()
        now = self.lockstep.step()
        self.wall_seconds += time.perf_counter() - t0
        return now

    def run_until(self, done: Callable[[float], bool], max_time: float) -> bool:
        end = self.clock.now() + max_time
        while self.clock.now() < end:
            if done(self.step()):
                return True
        return False

    def run_for(self, seconds: float) -> None:
        self.run_until(lambda _now: False, seconds)

    def hand_over(self, max_time: float = 120.0) -> float:
        """Run until the operator has armed the vehicle and put it in GUIDED; returns the time."""
        if not self.run_until(lambda _now: self.operator.handed_over_at is not None, max_time):
            raise TimeoutError(f"the autopilot never reached armed GUIDED in {max_time:g} s; "
                               f"status texts: {self.gcs.statustexts[-5:]}")
        return self.operator.handed_over_at or self.clock.now()

    def close_ground_station(self) -> None:
        """The operator closes the ground station (after the hand-over, say): it is no longer
        stepped and its connection closes; the autopilot carries on (FS_GCS_ENABLE 0)."""
        self.lockstep.remove_peer(self.gcs.conn)
        self.gcs.close()

    @property
    def companion_link(self):
        """The simulator's end of the companion's connection (what ArduPilot received)."""
        return self.lockstep.peers[0].link

    def values(self, name: str) -> list[Message]:
        return [m for m in self.messages if m.name == name]

    def mission_ended(self) -> bool:
        return self.ended_at is not None

    def run_mission(self, max_time: float, linger: float = 5.0) -> bool:
        """Hand over, run until EndMission goes active (then ``linger`` more seconds)."""
        self.hand_over()
        ended = self.run_until(lambda _now: self.mission_ended(), max_time)
        if ended:
            self.run_for(linger)
        return ended

    def close(self) -> None:
        self.companion.close()
        self.gcs.close()
        self.sim.close()

    def __enter__(self) -> SimulatedRun:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
