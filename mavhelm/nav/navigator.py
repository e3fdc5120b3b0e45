"""pNav on the bus: routes sensor variables through priority queues into ``NAV_*`` (spec 2.1).

For queue key ``K`` and source ``S`` the input is the variable ``S_K`` (``GPS_X``, ``INS_YAW``,
``AP_SPEED``); when the source is named after the key (``Depth = DEPTH @ 1``) the plain ``DEPTH``
is accepted as well as ``DEPTH_DEPTH``. The output is ``NAV_K`` stamped with the sensor's time.

Only fresh values are forwarded, once each: when every source of a key is stale, ``NAV_K`` goes
quiet instead of repeating the last value, so the helm's tasks starve and stop the vehicle
rather than steering on a position that is no longer true.
"""

from __future__ import annotations

import math
from typing import Final

from mavhelm.core.app import App
from mavhelm.core.bus import Bus, Message
from mavhelm.core.geodesy import heading_to_yaw, yaw_to_heading
from mavhelm.core.mission import Block, Mission, MissionError
from mavhelm.core.names import NO_SOURCE
from mavhelm.core.params import Param, Schema
from mavhelm.nav.priority_queue import PriorityQueue, QueueSpec

QUEUE_KEYS: Final = (
    "X",
    "Y",
    "Z",
    "DEPTH",
    "YAW",
    "PITCH",
    "ROLL",
    "SPEED",
    "ALTITUDE",
    "HEADING",
)
"""Keys of a pNav block that are priority queues. YAW is radians (yaw = −heading), HEADING
degrees clockwise from north; configure one of the two, the navigator posts both."""

NAV_SCHEMA = Schema(
    "pNav",
    tuple(Param(key.title(), QueueSpec(), None, doc=f"priority queue feeding NAV_{key}",
                attr=key.lower()) for key in QUEUE_KEYS),
    unsupported=("SENSOR_", "EKF_", "LSQ_", "NAV_LOG", "FIXED"),
)
"""A pNav block is its priority queues; the filters' settings are refused until they exist."""

_UNSET: Final = object()


class Navigator(App):
    """Forwards the best live source of each NAV key; says which source that is."""

    name = "pNav"

    def __init__(self, bus: Bus, queues: list[PriorityQueue]) -> None:
        super().__init__(bus)
        keys = [q.key for q in queues]
        if len(set(keys)) != len(keys):
            raise ValueError(f"duplicate priority queue keys in {keys}")
        if "YAW" in keys and "HEADING" in keys:
            raise ValueError("configure a Yaw queue or a Heading queue, not both")
        self.queues = list(queues)
        self._inputs: dict[str, list[tuple[PriorityQueue, str]]] = {}
        for queue in self.queues:
            for source in queue.sources:
                names = {f"{source.name}_{queue.key}"}
                if source.name == queue.key:
                    names.add(source.name)
                for name in names:
                    self._inputs.setdefault(name, []).append((queue, source.name))
        self._announced: dict[str, object] = {q.key: _UNSET for q in self.queues}

    @classmethod
    def from_block(cls, bus: Bus, block: Block) -> Navigator:
        """Build from a ``ProcessConfig = pNav`` block; every refusal is a located error."""
        settings = NAV_SCHEMA.read(block)
        if settings["yaw"] is not None and settings["heading"] is not None:
            later = max(block.require("Yaw"), block.require("Heading"), key=lambda e: e.line)
            raise later.error("configure a Yaw queue or a Heading queue, not both")
        queues = [settings[key.lower()] for key in QUEUE_KEYS if settings[key.lower()]]
        if not queues:
            raise block.error("pNav needs at least one priority queue, e.g. X = GPS @ 2.0")
        return cls(bus, queues)

    @classmethod
    def from_mission(cls, bus: Bus, mission: Mission) -> Navigator:
        """Build from the mission's ``ProcessConfig = pNav`` block, which must exist."""
        block = mission.process("pNav")
        if block is None:
            raise MissionError(mission.path, 0, "the mission has no ProcessConfig = pNav block")
        return cls.from_block(bus, block)

    def subscriptions(self) -> set[str]:
        return set(self._inputs)

    def on_mail(self, mail: list[Message], now: float) -> None:
        for msg in mail:
            routes = self._inputs.get(msg.name)
            if not routes or not msg.is_double or not math.isfinite(msg.double):
                continue
            for queue, source in routes:
                if now - msg.time > queue.timeout(source):
                    continue
                if queue.offer(source, msg.double, msg.time):
                    self._announce(queue.key, source)
                    self._post(queue.key, msg.double, msg.time)

    def iterate(self, now: float) -> None:
        for queue in self.queues:
            self._announce(queue.key, queue.current_source(now))

    def _announce(self, key: str, source: str | None) -> None:
        name = NO_SOURCE if source is None else source
        if self._announced[key] != name:
            self._announced[key] = name
            self.notify(f"NAV_{key}_SOURCE", name)

    def _post(self, key: str, value: float, time: float) -> None:
        if key == "YAW":
            self.notify("NAV_YAW", value, time)
            self.notify("NAV_HEADING", yaw_to_heading(value), time)
        elif key == "HEADING":
            heading = value % 360.0
            self.notify("NAV_HEADING", heading, time)
            self.notify("NAV_YAW", heading_to_yaw(heading), time)
        else:
            self.notify(f"NAV_{key}", value, time)
