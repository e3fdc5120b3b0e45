"""What the operator reads on the companion's console: one timestamped line per event.

A field engineer watching ``mavhelm run`` over ssh wants to know, without opening a log, that
the link is up, which mode the autopilot is in, whether the helm is driving and why not, which
task started or ended and how, and every warning. This app turns those bus variables into
short lines; a line repeated within ``quiet_s`` is held back and counted, so a flapping link
cannot scroll everything else away.
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
    "AP_STATUSTEXT": lambda m: f"autopilot says: {m.string}",
}
"""Variables shown as they are posted, and how."""

ALERT_SUFFIXES = ("_WARNING", "_ERROR", "_REFUSED")
"""Any variable ending so is shown as it is: ``LEG3_ERROR: starved …``."""


def _clock_text(now: float) -> str:
    """Wall time of day (UTC) on the vehicle; seconds since start in a simulated run."""
    if now > 1e9:
        return time.strftime("%H:%M:%S", time.gmtime(now)) + f".{int(now * 10) % 10}"
    return f"t+{now:8.1f}s"


class StatusConsole(App):
    """Prints the events in ``SHOWN_AS`` and every ``*_WARNING``/``*_ERROR``/``*_REFUSED``."""

    name = "console"

    def __init__(self, bus, echo: Callable[[str], None] = print, quiet_s: float = 5.0) -> None:
        super().__init__(bus)
        self.echo = echo
        self.quiet_s = quiet_s
        self._last_shown: dict[str, float] = {}
        self._held: dict[str, int] = {}

    def subscriptions(self) -> set[str]:
        return {"*"}

    def on_mail(self, mail: list[Message], now: float) -> None:
        for msg in mail:
            text = self.describe(msg)
            if text is not None:
                self._show(text, now)

    @staticmethod
    def describe(msg: Message) -> str | None:
        shown = SHOWN_AS.get(msg.name)
        if shown is not None:
            return shown(msg)
        if msg.name.endswith(ALERT_SUFFIXES):
            return f"{msg.name}: {msg.string}"
        return None

    def _show(self, text: str, now: float) -> None:
        last = self._last_shown.get(text)
        if last is not None and now - last < self.quiet_s:
            self._held[text] = self._held.get(text, 0) + 1
            return
        held = self._held.pop(text, 0)
        suffix = f"  (and {held} more like it)" if held else ""
        self._last_shown[text] = now
        self.echo(f"{_clock_text(now)}  {text}{suffix}")
