"""The companion's state as data: typed status events and the state they build.

The console, the ground station's STATUSTEXT, the TUNNEL channel and ``mavhelm remote`` all
need the same facts (link, mode, armed, whether the helm drives and why not, which tasks run,
who steers and for what, warnings, nav health). Each event says one fact; ``CompanionStatus``
is what the events so far amount to, built by the pure reducer :meth:`CompanionStatus.apply`,
so the companion and a console far away reach the same state from the same events.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from enum import IntEnum
from typing import Any, TypeAlias


class Severity(IntEnum):
    """MAV_SEVERITY: how a ground station colours a line."""

    ERROR = 3
    WARNING = 4
    NOTICE = 5
    INFO = 6


@dataclass(frozen=True, slots=True)
class LinkUp:
    """The autopilot's HEARTBEAT is heard (or no longer)."""

    up: bool


@dataclass(frozen=True, slots=True)
class LinkNote:
    """Something the autopilot connection did (opened, dropped, retrying)."""

    text: str


@dataclass(frozen=True, slots=True)
class AutopilotMode:
    mode: str


@dataclass(frozen=True, slots=True)
class Armed:
    armed: bool


@dataclass(frozen=True, slots=True)
class HelmState:
    """Whether the helm may drive; ``status`` is the bridge's one line, with the reason an
    operator can act on (``ONLINE: autopilot armed in GUIDED``, ``offline: …``)."""

    online: bool
    status: str

    @property
    def why(self) -> str:
        return self.status.partition(": ")[2]


@dataclass(frozen=True, slots=True)
class TaskStarted:
    name: str


@dataclass(frozen=True, slots=True)
class TaskEnded:
    """``how``: complete, timeout, starved (or closed, for a third party's task)."""

    name: str
    how: str


@dataclass(frozen=True, slots=True)
class TaskEvent:
    """A task fired its EventFlags (``task``: the task, ``text``: the reason)."""

    task: str
    text: str


@dataclass(frozen=True, slots=True)
class Goal:
    """Who holds the rudder and what for; an empty ``goal`` says only who."""

    owner: str
    goal: str


@dataclass(frozen=True, slots=True)
class Alert:
    """A warning or an error; ``source`` is the variable that carried it (``Leg_ERROR``)."""

    source: str
    text: str
    severity: Severity


@dataclass(frozen=True, slots=True)
class MissionEnded:
    """EndMission is active; ``task`` holds the vehicle."""

    task: str


@dataclass(frozen=True, slots=True)
class HelmReloaded:
    text: str


@dataclass(frozen=True, slots=True)
class HandedBack:
    """The autopilot took the vehicle back in ``mode`` (EndMission's HandBack)."""

    mode: str


@dataclass(frozen=True, slots=True)
class RemoteFlagPosted:
    flag: str


@dataclass(frozen=True, slots=True)
class ThirdPartyReply:
    text: str


@dataclass(frozen=True, slots=True)
class AutopilotText:
    """A STATUSTEXT from the autopilot, as the companion heard it."""

    text: str


@dataclass(frozen=True, slots=True)
class NavSource:
    """Which source now feeds a NAV variable (``key``: X, Y, HEADING, …); ``NONE`` when every
    source in its priority queue has timed out."""

    key: str
    source: str


@dataclass(frozen=True, slots=True)
class NavWarning:
    text: str


@dataclass(frozen=True, slots=True)
class NavFailure:
    """pNav's filters went off-line for good (spec 2.2.11); the mission ends."""

    why: str


@dataclass(frozen=True, slots=True)
class SenderRefused:
    """A command to the companion refused for who sent it (not allowed, or unsigned where
    signing is required); ``count``: commands refused so far. Said at most once every few
    seconds per sender, so the count is the whole story."""

    sender: str
    what: str
    why: str
    count: int

    def to_bus(self) -> str:
        """The bus variable's text (``MAVLINK_SENDER_REFUSED``): one field a ``|``."""
        return f"{self.sender}|{self.what}|{self.count}|{self.why}"

    @classmethod
    def from_bus(cls, text: str) -> SenderRefused:
        sender, what, count, why = (text.split("|", 3) + ["", "", ""])[:4]
        return cls(sender, what, why, int(count) if count.isdigit() else 0)


@dataclass(frozen=True, slots=True)
class Snapshot:
    """The state in one message, sent once a second so a console that joins late catches up.

    ``None`` is unknown. ``tasks_cut``: more tasks run than the message could name."""

    online: bool | None
    status: str
    mode: str | None
    armed: bool | None
    tasks: tuple[str, ...]
    owner: str
    goal: str
    tasks_cut: bool = False


Event: TypeAlias = (LinkUp | LinkNote | AutopilotMode | Armed | HelmState | TaskStarted
                    | TaskEnded | TaskEvent | Goal | Alert | MissionEnded | HelmReloaded
                    | HandedBack | RemoteFlagPosted | ThirdPartyReply | AutopilotText
                    | NavSource | NavWarning | NavFailure | SenderRefused | Snapshot)

NO_SOURCE = "NONE"


@dataclass(frozen=True)
class CompanionStatus:
    """What the events so far say about the companion; ``None`` is not known yet."""

    link_up: bool | None = None
    mode: str | None = None
    armed: bool | None = None
    online: bool | None = None
    status: str = ""
    """The helm's line: ``ONLINE: …`` or ``offline: <why>``."""
    tasks: tuple[str, ...] = ()
    owner: str = ""
    goal: str = ""
    mission_ended: str | None = None
    """The EndMission task holding the vehicle, once the mission has ended."""
    handed_back: str | None = None
    nav_sources: tuple[tuple[str, str], ...] = ()
    """(key, source) per NAV variable, sorted by key."""
    nav_warning: str | None = None
    nav_failure: str | None = None
    last_alert: Alert | None = None
    refused: int = 0
    """Commands to the companion refused for their sender."""

    def apply(self, event: Event) -> CompanionStatus:
        """The state after ``event``; events that change nothing return ``self``."""
        reduce = _REDUCERS.get(type(event))
        return self if reduce is None else reduce(self, event)

    @property
    def nav_lost(self) -> tuple[str, ...]:
        """NAV variables no source feeds."""
        return tuple(key for key, source in self.nav_sources if source == NO_SOURCE)

    def snapshot(self) -> Snapshot:
        return Snapshot(self.online, self.status, self.mode, self.armed, self.tasks,
                        self.owner, self.goal)


def _replace(state: CompanionStatus, **changes: object) -> CompanionStatus:
    return dataclasses.replace(state, **changes)  # type: ignore[arg-type]


def _task_started(s: CompanionStatus, e: TaskStarted) -> CompanionStatus:
    return s if e.name in s.tasks else _replace(s, tasks=(*s.tasks, e.name))


def _task_ended(s: CompanionStatus, e: TaskEnded) -> CompanionStatus:
    tasks = tuple(name for name in s.tasks if name != e.name)
    if s.owner == e.name:
        return _replace(s, tasks=tasks, owner="", goal="")
    return _replace(s, tasks=tasks)


def _kept(old: str, new: str) -> str:
    """A snapshot's text may have been cut to fit: it never shortens what an event said."""
    return old if new and old.startswith(new) else new


def _snapshot(s: CompanionStatus, e: Snapshot) -> CompanionStatus:
    tasks = e.tasks
    if e.tasks_cut:
        tasks = (*tasks, *(name for name in s.tasks if name not in tasks))
    return _replace(s, online=e.online, status=_kept(s.status, e.status), mode=e.mode,
                    armed=e.armed, tasks=tasks, owner=e.owner, goal=_kept(s.goal, e.goal))


def _nav_source(s: CompanionStatus, e: NavSource) -> CompanionStatus:
    sources = dict(s.nav_sources)
    sources[e.key] = e.source
    return _replace(s, nav_sources=tuple(sorted(sources.items())))


_REDUCERS: dict[type, Callable[[CompanionStatus, Any], CompanionStatus]] = {
    LinkUp: lambda s, e: _replace(s, link_up=e.up),
    AutopilotMode: lambda s, e: _replace(s, mode=e.mode),
    Armed: lambda s, e: _replace(s, armed=e.armed),
    HelmState: lambda s, e: _replace(s, online=e.online, status=e.status),
    TaskStarted: _task_started,
    TaskEnded: _task_ended,
    Goal: lambda s, e: _replace(s, owner=e.owner, goal=e.goal),
    Alert: lambda s, e: _replace(s, last_alert=e),
    MissionEnded: lambda s, e: _replace(s, mission_ended=e.task),
    HelmReloaded: lambda s, e: _replace(s, tasks=(), owner="", goal="", mission_ended=None,
                                        handed_back=None),
    HandedBack: lambda s, e: _replace(s, handed_back=e.mode),
    NavSource: _nav_source,
    NavWarning: lambda s, e: _replace(s, nav_warning=e.text),
    NavFailure: lambda s, e: _replace(s, nav_failure=e.why),
    SenderRefused: lambda s, e: _replace(s, refused=max(s.refused, e.count)),
    Snapshot: _snapshot,
}
"""How each kind of event changes the state; kinds not listed (notes, flags, replies, the
autopilot's texts, task events) are news, not state."""
