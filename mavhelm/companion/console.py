"""What the operator reads on the console and the ground station, and what a console program
reads over MAVLink: the companion's bus variables turned into status events, then rendered.

A field engineer watching ``mavhelm run`` over ssh wants to know, without opening a log, that
the link is up, which mode the autopilot is in, whether the helm is driving and why not, which
task started or ended and how, and every warning. :class:`BusEvents` is the one place that
knows which bus variable means which event (``status.py``); :class:`StatusConsole` renders each
event three ways:

- a console line with the time (a line repeated within ``quiet_s`` is held back and counted,
  so a flapping link cannot scroll everything else away);
- the helm's events as STATUSTEXT, with severities a ground station colours, at most
  ``GCS_LINES_PER_S`` a second, so the operator at the mode switch sees what the helm does;
- every event as data in a TUNNEL (``status_wire.py``), and the whole state once a second,
  for ``mavhelm remote`` and any other console that wants facts rather than English.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable

from mavhelm.companion.status import (
    Alert,
    Armed,
    AutopilotMode,
    AutopilotText,
    CompanionStatus,
    Event,
    Goal,
    HandedBack,
    HelmReloaded,
    HelmState,
    LinkNote,
    LinkUp,
    MissionEnded,
    NavFailure,
    NavSource,
    NavWarning,
    RemoteFlagPosted,
    SenderRefused,
    Severity,
    Snapshot,
    TaskEnded,
    TaskEvent,
    TaskStarted,
    ThirdPartyReply,
)
from mavhelm.companion.status_text import gcs_severity, line
from mavhelm.companion.status_wire import encode
from mavhelm.core.app import App
from mavhelm.core.bus import Message
from mavhelm.core.names import NAVIGATION_FAILURE


def _helm_state(m: Message) -> HelmState:
    return HelmState(m.string.partition(":")[0].strip().upper() == "ONLINE", m.string)


def _goal(m: Message) -> Goal:
    owner, sep, goal = m.string.partition(" steers: ")
    return Goal(owner, goal) if sep else Goal("", m.string)


def _owner(m: Message) -> Goal:
    return Goal("" if m.string == "none" else m.string, "")


def _task_event(m: Message) -> TaskEvent:
    task, _, text = m.string.partition(": ")
    return TaskEvent(task, text)


def _task_ended(m: Message) -> TaskEnded:
    name, _, how = m.string.partition(":")
    return TaskEnded(name, how)


EVENT_OF: dict[str, Callable[[Message], Event]] = {
    "MAVLINK_LINK": lambda m: LinkNote(m.string),
    "AP_LINK": lambda m: LinkUp(m.value == 1.0),
    "AP_MODE": lambda m: AutopilotMode(m.string),
    "AP_ARMED": lambda m: Armed(m.value == 1.0),
    "HELM_STATUS": _helm_state,
    "TASK_STARTED": lambda m: TaskStarted(m.string),
    "TASK_ENDED": _task_ended,
    "TASK_EVENT": _task_event,
    "HELM_RUDDER_OWNER": _owner,
    "HELM_GOAL": _goal,
    "MISSION_ENDED": lambda m: MissionEnded(m.string),
    "HELM_HANDBACK_DONE": lambda m: HandedBack(m.string),
    "HELM_RELOADED": lambda m: HelmReloaded(m.string),
    "REMOTE_FLAG": lambda m: RemoteFlagPosted(m.string),
    "THIRDPARTY_REPLY": lambda m: ThirdPartyReply(m.string),
    "AP_STATUSTEXT": lambda m: AutopilotText(m.string),
    "NAV_WARNING": lambda m: NavWarning(m.string),
    NAVIGATION_FAILURE: lambda m: NavFailure(m.string),
    "MAVLINK_SENDER_REFUSED": lambda m: SenderRefused.from_bus(m.string),
}
"""Bus variables that are status events, and which."""

STATES = frozenset({"AP_LINK", "AP_MODE", "AP_ARMED", "HELM_STATUS"})
"""Posted on every HEARTBEAT or tick: an event only when the value changes."""

ALERT_SEVERITY: tuple[tuple[str, Severity], ...] = (
    ("_ERROR", Severity.ERROR), ("_WARNING", Severity.WARNING), ("_REFUSED", Severity.WARNING),
    ("_NOTE", Severity.NOTICE))
"""Any other variable ending so is an alert: ``LEG3_ERROR: starved …``."""

GCS_LINES_PER_S = 4.0
TUNNEL_ALERTS_PER_S = 4.0
SNAPSHOT_PERIOD_S = 1.0


class BusEvents:
    """Bus variables in, status events out (states only when they change)."""

    def __init__(self) -> None:
        self._states: dict[str, float | str] = {}
        self._silent: set[str] = set()
        """Names that are never an event (most of a tick's mail): told apart once."""

    def of(self, msg: Message) -> Event | None:
        if msg.name in self._silent:
            return None
        event = self._of(msg)
        if event is None and self._never_an_event(msg.name):
            self._silent.add(msg.name)
        return event

    @staticmethod
    def _never_an_event(name: str) -> bool:
        return (name not in STATES and name not in EVENT_OF
                and not (name.startswith("NAV_") and name.endswith("_SOURCE"))
                and not any(name.endswith(suffix) for suffix, _ in ALERT_SEVERITY))

    def _of(self, msg: Message) -> Event | None:
        if msg.name in STATES:
            if self._states.get(msg.name) == msg.value:
                return None
            self._states[msg.name] = msg.value
        make = EVENT_OF.get(msg.name)
        if make is not None:
            return make(msg)
        if msg.name.startswith("NAV_") and msg.name.endswith("_SOURCE"):
            return NavSource(msg.name[4:-7], msg.string)
        for suffix, severity in ALERT_SEVERITY:
            if msg.name.endswith(suffix):
                return Alert(msg.name, msg.string, severity)
        return None


class TokenBucket:
    """A burst of ``rate`` sends, then ``rate`` a second."""

    def __init__(self, rate: float) -> None:
        self.rate = rate
        self._budget = rate
        self._time: float | None = None

    def take(self, now: float) -> bool:
        if self._time is not None:
            self._budget = min(self.rate, self._budget + (now - self._time) * self.rate)
        self._time = now
        if self._budget < 1.0:
            return False
        self._budget -= 1.0
        return True


def say(line: str) -> None:
    """A console line written whole, newline included, in one write: ``print`` writes the
    text and its end apart, and a SIGTERM between the two (a stop raising KeyboardInterrupt)
    left the line open for the next one ("…tcp:127.0.0.1:9mavhelm: stopped")."""
    sys.stdout.write(f"{line}\n")
    sys.stdout.flush()


def _clock_text(now: float) -> str:
    """Wall time of day (UTC) on the vehicle; seconds since start in a simulated run."""
    if now > 1e9:
        return time.strftime("%H:%M:%S", time.gmtime(now)) + f".{int(now * 10) % 10}"
    return f"t+{now:8.1f}s"


class StatusConsole(App):
    """Turns the bus into status events, keeps the state they build (``status``), prints
    them through ``echo``, sends the helm's to the ground station through
    ``statustext(text, severity)`` and every one, with a snapshot each second, through
    ``tunnel(payload)``: all in the loop's idle time (``idle``), after the tick."""

    name = "console"

    def __init__(self, bus, echo: Callable[[str], None] | None = print, quiet_s: float = 5.0,
                 statustext: Callable[[str, int], None] | None = None,
                 tunnel: Callable[[bytes], object] | None = None) -> None:
        super().__init__(bus)
        self.echo = echo
        self.statustext = statustext
        self.tunnel = tunnel
        self.quiet_s = quiet_s
        self.status = CompanionStatus()
        self._events = BusEvents()
        self._last_shown: dict[str, float] = {}
        self._held: dict[str, int] = {}
        self._gcs = TokenBucket(GCS_LINES_PER_S)
        self._tunnel_alerts = TokenBucket(TUNNEL_ALERTS_PER_S)
        self._next_snapshot: float | None = None
        self._snapshot: Snapshot | None = None
        self._snapshot_payload = b""
        """The last snapshot sent and its payload: most seconds nothing in it has changed."""
        self.gcs_dropped = 0
        self._pending: list[Message] = []

    def subscriptions(self) -> set[str]:
        return {"*"}

    def on_mail(self, mail: list[Message], now: float) -> None:
        self._pending += mail

    def idle(self) -> None:
        """The tick's events told once its commands are out: lines, STATUSTEXT and the
        status channel can wait, the autopilot's commands cannot."""
        now = self.bus.clock.now()
        mail, self._pending = self._pending, []
        self.take(mail, now)
        self._send_snapshot(now)

    def take(self, mail: list[Message], now: float) -> None:
        """Every event in ``mail``, told now."""
        for msg in mail:
            event = self._events.of(msg)
            if event is not None:
                self.publish(event, now)

    def publish(self, event: Event, now: float) -> None:
        """One event: into the state, onto the console, to the ground station."""
        self.status = self.status.apply(event)
        text = line(event)
        shown = False
        if text is not None:
            shown = self._show(text, now)
            severity = gcs_severity(event)
            if shown and severity is not None and self.statustext is not None:
                self._to_gcs(text, severity, now)
        if self.tunnel is not None and self._tunnelled(event, shown, now):
            self.tunnel(encode(event))

    def _send_snapshot(self, now: float) -> None:
        if self.tunnel is None:
            return
        if self._next_snapshot is None or now >= self._next_snapshot:
            self._next_snapshot = now + SNAPSHOT_PERIOD_S
            snapshot = self.status.snapshot()
            if snapshot != self._snapshot:
                self._snapshot, self._snapshot_payload = snapshot, encode(snapshot)
            self.tunnel(self._snapshot_payload)

    @staticmethod
    def describe(msg: Message) -> str | None:
        """A bus variable's line, as the console would print it (states not deduplicated)."""
        event = BusEvents().of(msg)
        return None if event is None else line(event)

    def _tunnelled(self, event: Event, shown: bool, now: float) -> bool:
        """Every state change; alerts as shown on the console, within their own rate; not the
        autopilot's texts (a ground station hears those from the autopilot)."""
        if isinstance(event, AutopilotText):
            return False
        if isinstance(event, (Alert, NavWarning)):
            return shown and self._tunnel_alerts.take(now)
        return True

    def _to_gcs(self, text: str, severity: int, now: float) -> None:
        if not self._gcs.take(now):
            self.gcs_dropped += 1
            return
        assert self.statustext is not None
        self.statustext(text, severity)

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
