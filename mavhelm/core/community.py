"""A community: apps on one bus, run in a fixed order each tick (spec 1.1's MOOS community)."""

from __future__ import annotations

import time
from collections import defaultdict
from collections.abc import Sequence

from mavhelm.core.app import App
from mavhelm.core.bus import Bus


class Community:
    def __init__(self, bus: Bus, apps: Sequence[App], profile: bool = False) -> None:
        self.bus = bus
        self.apps = list(apps)
        self.ticks = 0
        self.profile = profile
        self.app_seconds: dict[str, list[float]] = defaultdict(list)
        self.tick_started = 0.0
        """``time.perf_counter()`` when this tick began: an app with work that can wait (a
        picture) sees how busy the tick already is."""
        self._subscribed: dict[str, frozenset[str]] = {}

    def tick(self, now: float) -> None:
        """Every app (re)subscribes, then each in order takes its mail and iterates.

        Subscribing all first means that even on the first tick, and when a task has just
        widened the helm's interests, nothing an earlier app posts is lost to a later one.
        """
        self.tick_started = time.perf_counter()
        for app in self.apps:
            names = app.subscriptions()
            last = self._subscribed.get(app.name)
            if names is not last and names != last:  # the bus keeps what it was told
                self.bus.subscribe(app.name, names)
                self._subscribed[app.name] = (names if isinstance(names, frozenset)
                                              else frozenset(names))
        for app in self.apps:
            t0 = time.perf_counter() if self.profile else 0.0
            app.on_mail(self.bus.fetch(app.name), now)
            app.iterate(now)
            if self.profile:
                self.app_seconds[app.name].append(time.perf_counter() - t0)
        self.ticks += 1

    def idle(self) -> None:
        """The time between a tick and the loop's sleep: each app's deferred work."""
        for app in self.apps:
            app.idle()

    def close(self) -> None:
        for app in reversed(self.apps):
            app.close()
