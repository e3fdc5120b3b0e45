"""Who sent a command: a MAVLink ``system:component`` or the local bus.

A command to the companion, or a guest's request, is obeyed only from a sender the mission
names. Over MAVLink a sender is what its packets' header says (trustworthy only when the link
is signed); on the bus it is a process in the companion itself. ``SenderId`` is that identity,
``parse_sender`` reads the mission's spelling of it (``255``, ``42:191``, ``local``), and
``mavlink_source``/``sender_of_source`` carry a MAVLink sender as the ``source`` of the bus
variable the bridge posts for it, so the helm can tell who asked.
"""

from __future__ import annotations

from dataclasses import dataclass

LOCAL = "local"
"""The mission's word for the companion's own bus."""
_MAVLINK_SOURCE = "mavlink:"


@dataclass(frozen=True, slots=True)
class SenderId:
    """A MAVLink system (any component when ``component`` is None), or the local bus."""

    system: int | None
    """None: the local bus."""
    component: int | None = None

    @property
    def local(self) -> bool:
        return self.system is None

    def matches(self, other: SenderId) -> bool:
        """``other`` (a concrete sender) is this one: same system, and same component unless
        this one names none."""
        if self.local or other.local:
            return self.local and other.local
        return self.system == other.system and self.component in (None, other.component)

    def __str__(self) -> str:
        if self.system is None:
            return LOCAL
        return f"{self.system}" if self.component is None else f"{self.system}:{self.component}"


LOCAL_BUS = SenderId(None)
UNKNOWN = SenderId(-1, -1)
"""A sender that matches no one."""


def mavlink_sender(system: int, component: int) -> SenderId:
    return SenderId(system, component)


def parse_sender(text: str) -> SenderId:
    """``local``, ``SYSTEM`` or ``SYSTEM:COMPONENT`` (1-255 each); ValueError with the reason."""
    word = text.strip()
    if word.lower() == LOCAL:
        return LOCAL_BUS
    system_text, colon, component_text = word.partition(":")
    ids = []
    for part in (system_text, component_text) if colon else (system_text,):
        if not part.strip().isdigit() or not 1 <= int(part) <= 255:
            raise ValueError(f"expected local, SYSTEM or SYSTEM:COMPONENT (1-255 each), "
                             f"got {word!r}")
        ids.append(int(part))
    return SenderId(ids[0], ids[1] if colon else None)


def mavlink_source(system: int, component: int) -> str:
    """The bus ``source`` of a variable posted for a MAVLink sender."""
    return f"{_MAVLINK_SOURCE}{system}:{component}"


def sender_of_source(source: str) -> SenderId:
    """Who a bus variable came from: the MAVLink sender the bridge posted it for, or else
    the local bus (any process of the companion)."""
    if not source.startswith(_MAVLINK_SOURCE):
        return LOCAL_BUS
    system, _, component = source[len(_MAVLINK_SOURCE):].partition(":")
    if not (system.isdigit() and component.isdigit()):
        return UNKNOWN
    return SenderId(int(system), int(component))
