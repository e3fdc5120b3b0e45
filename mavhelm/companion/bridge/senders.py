"""Who may command the companion: the one check every command goes through.

Restart, remote flags, third-party requests and any later control (a web view's) go through
``MavlinkBridge.authorize``, which asks :meth:`SenderGate.check` with the sender and whether
its packet was signed. Allowed are the
mission's ``AllowedSenders`` or, by default, the autopilot's own ground station
(``MAV_GCS_SYSID``, read from the autopilot) and the local bus; a third-party request may also
come from a sender an ``Allow`` line binds (``From``). With ``RequireSigning`` an unsigned
packet is refused whoever it claims to be: over a radio a header is only a claim, a valid
signature is proof. A refusal is counted, and said at most once every ``QUIET_S`` per sender,
so a flood can neither hide nor scroll away everything else.
"""

from __future__ import annotations

from collections.abc import Iterable

from mavhelm.companion.status import SenderRefused
from mavhelm.core.sender import LOCAL_BUS, SenderId

QUIET_S = 5.0
"""A sender's refusals are said once in this long (all are counted)."""


class SenderGate:
    """The allowed senders, and the refusals so far."""

    def __init__(self, allowed: Iterable[SenderId] | None = None,
                 require_signing: bool = False) -> None:
        self.allowed: tuple[SenderId, ...] | None = None if allowed is None else tuple(allowed)
        """None: the autopilot's MAV_GCS_SYSID and the local bus."""
        self.require_signing = require_signing
        self.gcs_sysid: int | None = None
        """The autopilot's MAV_GCS_SYSID, once heard."""
        self.guests: tuple[SenderId, ...] = ()
        """Senders bound to a guest by an Allow line: they may send third-party requests."""
        self.refused = 0
        self._said_at: dict[str, float] = {}

    @property
    def needs_gcs_sysid(self) -> bool:
        return self.allowed is None and self.gcs_sysid is None

    def operators(self) -> tuple[SenderId, ...]:
        """Who may send any command (by default the local bus alone until the autopilot's
        MAV_GCS_SYSID is known)."""
        if self.allowed is not None:
            return self.allowed
        if self.gcs_sysid is None:
            return (LOCAL_BUS,)
        return (SenderId(self.gcs_sysid), LOCAL_BUS)

    def check(self, sender: SenderId, signed: bool, guest: bool = False) -> str | None:
        """Why ``sender`` may not give this command, or None if it may. ``guest``: a
        third-party request, which the senders bound by Allow lines may send too."""
        if self.require_signing and not sender.local and not signed:
            return "not signed, and RequireSigning is on"
        pool = self.operators() + (self.guests if guest else ())
        if any(allowed.matches(sender) for allowed in pool):
            return None
        if self.needs_gcs_sysid:
            return "the autopilot's MAV_GCS_SYSID is not known yet"
        return f"not an allowed sender (allowed: {', '.join(str(a) for a in pool)})"

    def refuse(self, sender: SenderId, what: str, why: str, now: float) -> SenderRefused | None:
        """Count a refusal; the event to say, unless this sender was named within QUIET_S."""
        self.refused += 1
        key = str(sender)
        said = self._said_at.get(key)
        if said is not None and 0.0 <= now - said < QUIET_S:
            return None
        self._said_at[key] = now
        return SenderRefused(key, what, why, self.refused)
