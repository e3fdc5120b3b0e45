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

from mavhelm.companion.app import App
from mavhelm.companion.bus import Bus, Message
from mavhelm.companion.mission import Block, Mission, MissionError
from mavhelm.geo import heading_to_yaw, yaw_to_heading
from mavhelm.nav.priority_queue import PriorityQueue

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

IGNORED_PREFIXES: Final = ("SENSOR_", "EKF_", "LSQ_", "NAV_LOG", "FIXED")
"""pNav settings for the filters (not built yet): accepted so full MOOS pNav blocks load."""

COMMON_KEYS: Final = frozenset({"APPTICK", "COMMSTICK"})

NO_SOURCE: Final = "NONE"

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
        """Build from a ``ProcessConfig = pNav`` block; unknown settings are located errors."""
        queues: dict[str, PriorityQueue] = {}
        lines: dict[str, int] = {}
        for entry in block.entries:
            key = entry.key.upper()
            if key in QUEUE_KEYS:
                if key in queues:
                    raise entry.error(
                        f"{entry.key}: priority queue already defined at line {lines[key]}"
                    )
                other = {"YAW": "HEADING", "HEADING": "YAW"}.get(key, "")
                if other in queues:
                    raise entry.error(
                        f"{entry.key}: a {other.title()} queue is already defined at line"
                        f" {lines[other]}; configure Yaw or Heading, not both"
                    )
                queues[key] = PriorityQueue.parse(entry)
                lines[key] = entry.line
            elif key in COMMON_KEYS or key.startswith(IGNORED_PREFIXES):
                continue
            else:
                raise entry.error(
                    f"unknown pNav setting {entry.key!r}: expected a priority queue"
                    f" ({', '.join(k.title() for k in QUEUE_KEYS)} = SOURCE @ timeout, …)"
                    " or a SENSOR_/EKF_/LSQ_/FIXED/NAV_LOG setting"
                )
        if not queues:
            raise block.error("pNav needs at least one priority queue, e.g. X = GPS @ 2.0")
        return cls(bus, list(queues.values()))

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
