"""The variable bus: the MOOS database inside one process (spec 1.1).

Apps publish named variables (a double or a string, stamped with time and source) and receive,
once per tick, the mail they subscribed to. Subscribing to ``"*"`` receives everything (the
logger does). Mail is delivered in the order it was posted.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable
from typing import NamedTuple

from mavhelm.core.clock import Clock


class Message(NamedTuple):
    """One posting of a variable: immutable, as every subscriber gets the same one (a named
    tuple: a frozen dataclass cost twice as much to build, and a busy tick builds dozens)."""

    name: str
    value: float | str
    time: float
    source: str

    @property
    def is_double(self) -> bool:
        return not isinstance(self.value, str)

    @property
    def double(self) -> float:
        if isinstance(self.value, str):
            raise TypeError(f"{self.name} is a string, not a double")
        return self.value

    @property
    def string(self) -> str:
        return self.value if isinstance(self.value, str) else f"{self.value:g}"


_new_message = tuple.__new__
"""A Message built without the named tuple's own constructor, a Python function call that
cost more than the tuple (~200 against ~70 ns; a busy tick posts dozens)."""


class Bus:
    """Posts variables and holds each subscriber's mail until it fetches it."""

    def __init__(self, clock: Clock) -> None:
        self.clock = clock
        self._subscribers: dict[str, set[str]] = defaultdict(set)
        self._wildcard: set[str] = set()
        self._mail: dict[str, list[Message]] = defaultdict(list)
        self._latest: dict[str, Message] = {}
        self._routes: dict[str, tuple[str, ...]] = {}
        """Per variable, every client it goes to (its subscribers and the wildcard ones)."""

    def subscribe(self, client: str, names: Iterable[str]) -> None:
        for name in names:
            if name == "*":
                self._wildcard.add(client)
            else:
                self._subscribers[name].add(client)
        self._mail.setdefault(client, [])
        self._routes.clear()

    def notify(
        self, name: str, value: float | str, source: str, time: float | None = None
    ) -> Message:
        if type(value) is not float and not isinstance(value, str):  # a float as it is
            value = float(value)
        msg = _new_message(Message, (name, value, self.clock.now() if time is None else time,
                                     source))
        self._latest[name] = msg
        route = self._routes.get(name)
        if route is None:
            route = self._routes[name] = tuple(self._subscribers.get(name, set()) | self._wildcard)
        mail = self._mail
        for client in route:
            mail[client].append(msg)
        return msg

    def fetch(self, client: str) -> list[Message]:
        mail = self._mail.get(client, [])
        self._mail[client] = []
        return mail

    def latest(self, name: str) -> Message | None:
        return self._latest.get(name)
