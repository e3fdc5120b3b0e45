"""The life every app on the bus shares: configure, subscribe, take mail, iterate.

A Community (companion/community.py) runs its apps in a fixed order each tick, so what an
earlier app posts is in a later app's mail the same tick: MAVLink in → navigator → helm →
MAVLink out takes one tick from sensor to actuator.
"""

from __future__ import annotations

from collections.abc import Set as AbstractSet

from mavhelm.core.bus import Bus, Message


class App:
    """Base of the navigator, the helm, the MAVLink bridge and the logger."""

    name: str = "App"

    def __init__(self, bus: Bus) -> None:
        self.bus = bus

    def subscriptions(self) -> AbstractSet[str]:
        """Variables this app wants; asked every tick, so it may grow as tasks start. Return
        the same frozenset while they stay the same: the community then need not compare."""
        return frozenset()

    def on_mail(self, mail: list[Message], now: float) -> None:
        """Take this tick's mail (called before iterate, possibly with an empty list)."""

    def iterate(self, now: float) -> None:
        """Do this tick's work; post with self.notify."""

    def idle(self) -> None:
        """Work that can wait until the tick's commands are out: the loop calls it after the
        tick, before it sleeps (writing logs, the ground station's telemetry)."""

    def close(self) -> None:
        """Release files, ports and sockets."""

    def notify(self, name: str, value: float | str, time: float | None = None) -> None:
        self.bus.notify(name, value, self.name, time)
