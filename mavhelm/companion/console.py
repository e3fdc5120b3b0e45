"""What the operator reads on the console, and on the ground station: one line per event.

A field engineer watching ``mavhelm run`` over ssh wants to know, without opening a log, that
the link is up, which mode the autopilot is in, whether the helm is driving and why not, which
task started or ended and how, and every warning. This app turns those bus variables into
short lines; a line repeated within ``quiet_s`` is held back and counted, so a flapping link
cannot scroll everything else away.

The helm's own events (online/offline and why, tasks, warnings, errors, mission end) also go
to the ground station as STATUSTEXT, with severities a ground station colours, at most
``GCS_LINES_PER_S`` a second: the operator at the mode switch sees what the helm is doing.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from mavhelm.core.app import App
from mavhelm.core.bus import Message

SHOWN_AS: dict[str, Callable[[Message], str]] = {
    "MAVLINK_LINK": lambda m: m.string,
    "AP_LINK": lambda m: "autopilot link up" if m.value == 1.0 else "autopilot link DOWN",
    "AP_MODE": lambda m: f"autopilot mode {m.string}",
    "AP_ARMED": lambda m: "autopilot armed" if m.value == 1.0 else "autopilot disarmed",
    "HELM_STATUS": lambda m: f"helm {m.string}",
    "TASK_STARTED": lambda m: f"task {m.string} started",
    "TASK_ENDED": lambda m: "task {} ended: {}".format(*m.string.partition(":")[::2]),
    "MISSION_ENDED": lambda m: f"MISSION ENDED ({m.string} holds the vehicle)",
    "HELM_HANDBACK_DONE": lambda m: f"vehicle handed back to the autopilot in {m.string}",
    "HELM_RELOADED": lambda m: f"helm reloaded: {m.string}",
    "REMOTE_FLAG": lambda m: f"flag {m.string} posted by the ground station",
    "THIRDPARTY_REPLY": lambda m: f"third party {m.string}",
    "HELM_GOAL": lambda m: m.string,
    "TASK_EVENT": lambda m: f"task event {m.string}",
    "AP_STATUSTEXT": lambda m: f"autopilot says: {m.string}",
}
"""Variables shown as they are posted, and how."""

STATES = frozenset({"AP_LINK", "AP_MODE", "AP_ARMED", "HELM_STATUS"})
"""Posted on every HEARTBEAT or tick: shown only when the value changes."""

ALERT_SUFFIXES = ("_WARNING", "_ERROR", "_REFUSED")
"""Any variable ending so is shown as it is: ``LEG3_ERROR: starved …``."""

SEVERITY_NOTICE, SEVERITY_INFO = 5, 6
SEVERITY_ERROR, SEVERITY_WARNING = 3, 4
GCS_SEVERITY: dict[str, int] = {
    "HELM_STATUS": SEVERITY_NOTICE,
    "MISSION_ENDED": SEVERITY_NOTICE,
    "HELM_HANDBACK_DONE": SEVERITY_NOTICE,
    "HELM_RELOADED": SEVERITY_NOTICE,
    "REMOTE_FLAG": SEVERITY_INFO,
    "THIRDPARTY_REPLY": SEVERITY_INFO,
    "HELM_GOAL": SEVERITY_INFO,
    "TASK_EVENT": SEVERITY_WARNING,
    "TASK_STARTED": SEVERITY_INFO,
    "TASK_ENDED": SEVERITY_INFO,
}
"""The helm's events a ground station is told about (MAV_SEVERITY); alerts by suffix below."""
GCS_LINES_PER_S = 4.0


def gcs_severity(name: str) -> int | None:
    """The MAV_SEVERITY a variable goes to the ground station with, or None (console only)."""
    if name in GCS_SEVERITY:
        return GCS_SEVERITY[name]
    if name.endswith("_ERROR"):
        return SEVERITY_ERROR
    if name.endswith(("_WARNING", "_REFUSED")):
        return SEVERITY_WARNING
    return None


def _clock_text(now: float) -> str:
    """Wall time of day (UTC) on the vehicle; seconds since start in a simulated run."""
    if now > 1e9:
        return time.strftime("%H:%M:%S", time.gmtime(now)) + f".{int(now * 10) % 10}"
    return f"t+{now:8.1f}s"


class StatusConsole(App):
    """Prints the events in ``SHOWN_AS`` and every ``*_WARNING``/``*_ERROR``/``*_REFUSED``,
    and sends the helm's to the ground station through ``statustext(text, severity)``."""

    name = "console"

    def __init__(self, bus, echo: Callable[[str], None] | None = print, quiet_s: float = 5.0,
                 statustext: Callable[[str, int], None] | None = None) -> None:
        super().__init__(bus)
        self.echo = echo
        self.statustext = statustext
        self.quiet_s = quiet_s
        self._last_shown: dict[str, float] = {}
        self._held: dict[str, int] = {}
        self._states: dict[str, float | str] = {}
        self._gcs_budget = GCS_LINES_PER_S
        self._gcs_time: float | None = None
        self.gcs_dropped = 0

    def subscriptions(self) -> set[str]:
        return {"*"}

    def on_mail(self, mail: list[Message], now: float) -> None:
        for msg in mail:
            if msg.name in STATES:
                if self._states.get(msg.name) == msg.value:
                    continue
                self._states[msg.name] = msg.value
            text = self.describe(msg)
            if text is None:
                continue
            if self._show(text, now) and self.statustext is not None:
                severity = gcs_severity(msg.name)
                if severity is not None:
                    self._to_gcs(text, severity, now)

    def _to_gcs(self, text: str, severity: int, now: float) -> None:
        """A token bucket: a burst of GCS_LINES_PER_S lines, then that many a second."""
        if self._gcs_time is not None:
            self._gcs_budget = min(GCS_LINES_PER_S,
                                   self._gcs_budget + (now - self._gcs_time) * GCS_LINES_PER_S)
        self._gcs_time = now
        if self._gcs_budget < 1.0:
            self.gcs_dropped += 1
            return
        self._gcs_budget -= 1.0
        assert self.statustext is not None
        self.statustext(text, severity)

    @staticmethod
    def describe(msg: Message) -> str | None:
        shown = SHOWN_AS.get(msg.name)
        if shown is not None:
            return shown(msg)
        if msg.name.endswith(ALERT_SUFFIXES):
            return f"{msg.name}: {msg.string}"
        return None

    def _show(self, text: str, now: float) -> bool:
        """Print the line unless it repeats one shown within ``quiet_s``; True if shown."""
        last = self._last_shown.get(text)
        if last is not None and now - last < self.quiet_s:
            self._held[text] = self._held.get(text, 0) + 1
            return False
        held = self._held.pop(text, 0)
        suffix = f"  (and {held} more like it)" if held else ""
        self._last_shown[text] = now
        if self.echo is not None:
            self.echo(f"{_clock_text(now)}  {text}{suffix}")
        return True
