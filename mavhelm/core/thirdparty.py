"""Third-party requests (spec 1.3): the string a guest scientist sends, and how it is read.

A request asks the helm to run one task on a client's behalf, ``job@client:TASK=Type|Key=Val|…``,
or ends the client's transaction, ``job@client:CLOSE``. It travels as the bus variable
``THIRDPARTY_REQUEST`` (MOOS's name) or, over MAVLink, in a TUNNEL message to the companion
(``TUNNEL_PAYLOAD_TYPE``). :class:`ThirdPartyRequest` builds one, as MOOS's
``CThirdPartyRequest`` did; :func:`parse_request` reads one back, refusing anything malformed.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field

REQUEST_VARIABLE = "THIRDPARTY_REQUEST"
REPLY_VARIABLE = "THIRDPARTY_REPLY"
TUNNEL_PAYLOAD_TYPE = 32801
"""MAVLink TUNNEL payload_type of a request (to the companion) or a reply (from it): in the
range MAVLink leaves for private use (32768-65535)."""
MAX_LENGTH = 128
"""A TUNNEL payload's size: the longest request that can travel over MAVLink."""

_NAME = re.compile(r"[A-Za-z0-9_.\-]+")
_KEY = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


class RequestError(ValueError):
    """A request that cannot be read; the message says why, for the reply."""


@dataclass(frozen=True)
class Request:
    job: str
    client: str
    task_type: str | None
    """None for CLOSE."""
    properties: tuple[tuple[str, str], ...] = ()

    @property
    def who(self) -> str:
        return f"{self.job}@{self.client}"


@dataclass
class ThirdPartyRequest:
    """Builds a request: ``ThirdPartyRequest("Sample", "iScience").add_property("Location",
    "10,20").execute_task("GoToWayPoint")``."""

    job: str
    client: str
    properties: list[tuple[str, str]] = field(default_factory=list)

    def __post_init__(self) -> None:
        for what, value in (("job", self.job), ("client", self.client)):
            if not _NAME.fullmatch(value):
                raise RequestError(f"{what} must be one word, got {value!r}")

    def add_property(self, key: str, value: object) -> ThirdPartyRequest:
        text = str(value)
        if not _KEY.fullmatch(key) or key.upper() == "TASK":
            raise RequestError(f"property name must be one word (not TASK), got {key!r}")
        if any(c in text for c in "|\n\r") or not text.strip():
            raise RequestError(f"{key}: a value may not be empty or hold '|' or a line break")
        self.properties.append((key, text.strip()))
        return self

    def execute_task(self, task_type: str) -> str:
        if not _KEY.fullmatch(task_type):
            raise RequestError(f"task type must be one word, got {task_type!r}")
        parts = [f"TASK={task_type}", *(f"{k}={v}" for k, v in self.properties)]
        return self._sized(f"{self.job}@{self.client}:" + "|".join(parts))

    def close(self) -> str:
        return self._sized(f"{self.job}@{self.client}:CLOSE")

    @staticmethod
    def _sized(text: str) -> str:
        if len(text.encode()) > MAX_LENGTH:
            raise RequestError(f"request longer than {MAX_LENGTH} bytes cannot travel over "
                               "MAVLink; shorten names or values")
        return text


def parse_request(text: str) -> Request:
    """Read a request; RequestError with the reason if it is not one."""
    head, colon, body = text.strip().partition(":")
    job, at, client = head.partition("@")
    if not colon or not at or not _NAME.fullmatch(job) or not _NAME.fullmatch(client):
        raise RequestError("expected job@client:TASK=Type|Key=Value|… or job@client:CLOSE")
    if body.strip().upper() == "CLOSE":
        return Request(job, client, None)
    pairs = []
    for item in body.split("|"):
        key, eq, value = (part.strip() for part in item.partition("="))
        if not eq or not _KEY.fullmatch(key) or not value:
            raise RequestError(f"expected Key=Value, got {item.strip()!r}")
        pairs.append((key, value))
    if not pairs or pairs[0][0].upper() != "TASK":
        raise RequestError("a request starts with TASK=Type")
    task_type = pairs[0][1]
    if not _KEY.fullmatch(task_type):
        raise RequestError(f"task type must be one word, got {task_type!r}")
    return Request(job, client, task_type, tuple(pairs[1:]))
