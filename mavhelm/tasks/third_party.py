"""Third-party task execution (spec 1.3): the Captain's book of permissions and the one open
transaction.

A guest (an acoustic modem, a science computer) asks the helm to run a task on its behalf.
The mission grants it explicitly, ``Allow = job@client:Type1,Type2 | SessionTimeOut = s |
From = 42:191``; anything not granted is denied, and every answer goes back to the requester
with the reason. Rules, as the spec and the original pHelm have them:

- one transaction at a time: while a client's task runs, or during its session (the
  ``SessionTimeOut`` seconds after that task ended, when only that client may follow up),
  every other client is denied; the client itself must wait for its task to end or CLOSE it;
- a requested task runs ON at once, with a priority never more important than 2 (the
  mission's safety tasks and EndMission keep the vehicle);
- nothing is granted while the helm is offline: the operator has the vehicle;
- a guest is who its link says: ``From`` binds job@client to MAVLink senders
  (``system:component``) or to the companion's own bus (``local``), and a request, or a CLOSE,
  claiming that client from anyone else is denied. Without ``From`` the client is bound to
  the senders that may command the companion (the bridge lets no one else through) and the
  bus.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

from mavhelm.core.errors import LocatedError
from mavhelm.core.mission import Block, Entry
from mavhelm.core.params import Kind
from mavhelm.core.sender import LOCAL_BUS, SenderId, parse_sender
from mavhelm.core.thirdparty import Request, RequestError, parse_request
from mavhelm.tasks.base import Task
from mavhelm.tasks.pid import HelmGains
from mavhelm.tasks.registry import build_task, task_class

SESSION_DEFAULT_S = 5.0
SESSION_MAX_S = 30.0
MOST_IMPORTANT = 2
NOT_GRANTABLE = ("endmission", "overalltimeout")
_ALLOW = re.compile(r"^\s*([A-Za-z0-9_.\-]+)@([A-Za-z0-9_.\-]+)\s*:\s*([^|]+?)\s*"
                    r"((?:\|[^|]*)*)$")
_OPTION = re.compile(r"^\s*(SessionTimeOut|From)\s*=\s*(\S(?:.*\S)?)\s*$", re.IGNORECASE)


@dataclass(frozen=True)
class Permission:
    job: str
    client: str
    types: frozenset[str]
    """Task keywords, lower case."""
    session_timeout: float
    senders: tuple[SenderId, ...] = ()
    """Who may speak for job@client; empty: whoever may command the companion."""

    @property
    def who(self) -> str:
        return f"{self.job}@{self.client}"

    def grants(self, request: Request) -> bool:
        return (request.job == self.job and request.client == self.client
                and request.task_type is not None and request.task_type.lower() in self.types)

    def binds(self, sender: SenderId) -> bool:
        """``sender`` may speak for this permission's job@client."""
        return not self.senders or any(s.matches(sender) for s in self.senders)


class AllowSpec(Kind):
    """``job@client:Type1,Type2 [| SessionTimeOut = s] [| From = 42:191, local]``."""

    def describe(self) -> str:
        return (f"job@client:Type1,Type2 | SessionTimeOut = s (s in (0, {SESSION_MAX_S:g}], "
                f"default {SESSION_DEFAULT_S:g}) | From = SYSTEM:COMPONENT or local, comma "
                "separated (default: the senders allowed to command the companion)")

    def parse(self, entry: Entry) -> Permission:
        m = _ALLOW.match(entry.value)
        if m is None:
            raise entry.error(f"{entry.key} expects {self.describe()}, got {entry.value!r}")
        job, client, types_text, options_text = m.groups()
        types = [t.strip() for t in types_text.split(",")]
        for t in types:
            if task_class(t) is None:
                raise entry.error(f"{entry.key}: unknown task type {t!r}")
            if t.lower() in NOT_GRANTABLE:
                raise entry.error(f"{entry.key}: a third party cannot be granted {t}")
        options = _options(entry, options_text)
        session = SESSION_DEFAULT_S
        session_text = options.get("sessiontimeout")
        if session_text is not None:
            try:
                session = float(session_text)
            except ValueError:
                session = -1.0
            if not 0.0 < session <= SESSION_MAX_S:
                raise entry.error(f"{entry.key}: SessionTimeOut must be seconds in "
                                  f"(0, {SESSION_MAX_S:g}], got {session_text}")
        return Permission(job, client, frozenset(t.lower() for t in types), session,
                          _senders(entry, options.get("from")))


def _options(entry: Entry, text: str) -> dict[str, str]:
    """The ``| Key = value`` options after the types, each at most once."""
    options: dict[str, str] = {}
    for item in text.split("|")[1:]:
        m = _OPTION.match(item)
        if m is None:
            raise entry.error(f"{entry.key}: expected SessionTimeOut = s or From = senders "
                              f"after '|', got {item.strip()!r}")
        key = m.group(1).lower()
        if key in options:
            raise entry.error(f"{entry.key}: {m.group(1)} given twice")
        options[key] = m.group(2)
    return options


def _senders(entry: Entry, text: str | None) -> tuple[SenderId, ...]:
    if text is None:
        return ()
    try:
        return tuple(parse_sender(word) for word in text.split(","))
    except ValueError as exc:
        raise entry.error(f"{entry.key}: From: {exc}") from None


@dataclass
class Reply:
    """The answer to one request: posted to the requester as ``job@client:VERDICT:detail``."""

    who: str
    verdict: str  # ACCEPTED, DENIED or CLOSED
    detail: str

    def __str__(self) -> str:
        return f"{self.who}:{self.verdict}:{self.detail}"


@dataclass
class ThirdParty:
    permissions: list[Permission]
    gains: HelmGains = field(default_factory=HelmGains)
    owner: Request | None = None
    task: Task | None = None
    session_until: float | None = None
    session_timeout: float = SESSION_DEFAULT_S

    def holder(self, now: float) -> str | None:
        """Who holds the transaction now (a running task or an open session), if anyone."""
        if self.owner is None:
            return None
        if self.task is not None and self.task.active:
            return self.owner.who
        if self.session_until is None and self.task is not None:
            self.session_until = now + self.session_timeout
        if self.session_until is not None and now <= self.session_until:
            return self.owner.who
        self.owner, self.task, self.session_until = None, None, None
        return None

    def bound_senders(self) -> tuple[SenderId, ...]:
        """The MAVLink senders some Allow line binds a guest to (they may send requests)."""
        return tuple(dict.fromkeys(s for p in self.permissions for s in p.senders
                                   if not s.local))

    def impostor(self, request: Request, sender: SenderId) -> str | None:
        """Why ``sender`` may not speak for the request's client (None if it may): an Allow
        line for that job@client binds it to other senders."""
        bound = [p for p in self.permissions if p.job == request.job
                 and p.client == request.client]
        if not bound or any(p.binds(sender) for p in bound):
            return None
        senders = ", ".join(dict.fromkeys(str(s) for p in bound for s in p.senders))
        return f"{request.who} is bound to {senders}; this request came from {sender}"

    def handle(self, text: str, closed_because: str | None, now: float,
               names: set[str], sender: SenderId = LOCAL_BUS
               ) -> tuple[Reply, Task | None, Task | None]:
        """(reply, task to start, task to close) for one request from ``sender``;
        ``closed_because`` says why the helm grants nothing now (offline, mission ended), or
        is None."""
        try:
            request = parse_request(text)
        except RequestError as exc:
            who = text.partition(":")[0].strip() or "?"
            return Reply(who, "DENIED", f"malformed request: {exc}"), None, None
        impostor = self.impostor(request, sender)
        if impostor is not None:
            return Reply(request.who, "DENIED", impostor), None, None
        holder = self.holder(now)
        if request.task_type is None:
            if holder != request.who or self.owner is None:
                return Reply(request.who, "DENIED", "no open transaction to close"), None, None
            closing = self.task if self.task is not None and self.task.active else None
            self.owner, self.task, self.session_until = None, None, None
            return Reply(request.who, "CLOSED", "transaction closed"), None, closing
        if closed_because is not None:
            return Reply(request.who, "DENIED", closed_because), None, None
        permission = next((p for p in self.permissions if p.grants(request)), None)
        if permission is None:
            return Reply(request.who, "DENIED", f"not allowed: no Allow line grants "
                                                f"{request.who} a {request.task_type} task"), \
                None, None
        if holder is not None and holder != request.who:
            return Reply(request.who, "DENIED", f"busy: {holder} holds the helm (one "
                                                "transaction at a time)"), None, None
        if self.task is not None and self.task.active:
            return Reply(request.who, "DENIED", f"its task {self.task.name} is still running: "
                                                "wait for it to end or CLOSE"), None, None
        try:
            task = self._build(request, names)
        except LocatedError as exc:
            return Reply(request.who, "DENIED", exc.reason), None, None
        self.owner, self.task, self.session_until = request, task, None
        self.session_timeout = permission.session_timeout
        return Reply(request.who, "ACCEPTED", f"task {task.name} at priority "
                                              f"{task.priority}"), task, None

    def _build(self, request: Request, names: set[str]) -> Task:
        assert request.task_type is not None
        entries = [Entry(k, v, "THIRDPARTY_REQUEST", 0) for k, v in request.properties
                   if k.lower() not in ("initialstate", "startflag")]
        keys = {e.key.lower() for e in entries}
        if "name" not in keys:
            entries.append(Entry("Name", f"{request.job}_{request.client}", "", 0))
        priority = next((e for e in entries if e.key.lower() == "priority"), None)
        if priority is None:
            entries.append(Entry("Priority", str(MOST_IMPORTANT), "", 0))
        entries.append(Entry("InitialState", "ON", "", 0))
        task = build_task(Block("Task", request.task_type, "THIRDPARTY_REQUEST", 0, entries),
                          self.gains)
        if task.priority < MOST_IMPORTANT:
            task.priority = MOST_IMPORTANT
        if task.name in names:
            raise LocatedError("THIRDPARTY_REQUEST", 0, f"a task named {task.name} exists "
                                                        "already: give another Name")
        return task
