"""The page's frames, made in the web server's process from the facts the companion hands it.

The companion's tick only gathers facts (the bus values posted since the last frame, the typed
status, the running tasks and the steering task's goal) and hands them over pickled; turning
them into what the page draws (estimates, ranges, flags, alerts, the track) and into JSON happens
here, in the server's process, off the helm's tick. ``Frames`` keeps what that needs between
frames: every value heard, the alerts, the last track point.
"""

from __future__ import annotations

import math
from typing import Any

from mavhelm.companion.web import picture

TRACK_STEP_M = 0.5
"""A new track point once the vehicle has moved this far."""
ALERT_SUFFIXES = ("_ERROR", "_WARNING", "_REFUSED")
"""Variables the page lists as alerts (NAV_WARNING among them)."""


class Frames:
    """Facts in, frames out: ``frame(facts)`` for each facts message, in order."""

    def __init__(self) -> None:
        self.values: dict[str, float | str] = {}
        self.alerts: list[str] = []
        self.flags: list[str] = []
        self._last_point: tuple[float, float] | None = None

    def frame(self, facts: dict[str, Any]) -> dict[str, Any]:
        """The page's frame for ``facts`` (what ``WebView.facts`` gathers)."""
        fresh: dict[str, float | str] = facts["values"]
        self.values.update(fresh)
        for name, value in fresh.items():
            if name.endswith(ALERT_SUFFIXES):
                self.alerts.insert(0, f"{name}: {value}")
        del self.alerts[picture.ALERT_LINES:]
        values = self.values
        frame: dict[str, Any] = {
            "type": "frame", "t": round(facts["t"], 2),
            "status": picture.status_dict(facts["status"]),
            "poses": picture.poses(values), "track": self._track(fresh),
            "goal": facts["goal"], "running": facts["running"],
            "alerts": list(self.alerts), "ranges": picture.ranges(values),
            "link": facts["link"], "web": facts["web"],
        }
        mission = facts.get("mission")
        if mission is not None:
            self.flags = mission.pop("flags")
            frame["mission"] = mission
        frame["flags"] = {name: _shown(values[name]) for name in self.flags if name in values}
        return frame

    def _track(self, fresh: dict[str, float | str]) -> list[list[float]]:
        x, y = fresh.get("NAV_X"), fresh.get("NAV_Y")
        if not (isinstance(x, float) and isinstance(y, float) and math.isfinite(x + y)):
            return []
        last = self._last_point
        if last is not None and math.hypot(x - last[0], y - last[1]) < TRACK_STEP_M:
            return []
        self._last_point = (x, y)
        return [[round(x, 2), round(y, 2)]]


def _shown(value: float | str) -> float | str:
    return value if isinstance(value, str) or math.isfinite(value) else str(value)
