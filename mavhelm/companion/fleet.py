"""Several boats on one shore screen: what a ground-station link hears, told apart by MAV_SYSID.

``mavhelm view`` listens where a ground station would (a telemetry radio, MAVProxy's ``--out``,
each autopilot's telemetry port) and keeps, per system: the autopilot's mode and arming (its
HEARTBEAT), the helm's state from the companion's typed status channel (TUNNEL payload 32802,
decoded and applied with the companion's own reducer), the companion's pose and demands
(NAMED_VALUE_FLOAT NAV_X, NAV_Y, NAV_HDG …) and the last STATUSTEXT lines. It only listens:
nothing is sent, so any number of viewers can share a link. Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.mode_request import ROVER_MODES
from mavhelm.companion.status import CompanionStatus
from mavhelm.companion.status_wire import STATUS_PAYLOAD_TYPE, decode

TEXT_LINES = 5
STALE_S = 5.0
"""Nothing heard from a system for this long: it is shown as silent."""


@dataclass
class Boat:
    """One vehicle (autopilot and companion sharing its MAV_SYSID)."""

    sysid: int
    mode: str | None = None
    armed: bool | None = None
    heard_at: float | None = None
    companion_at: float | None = None
    status: CompanionStatus = field(default_factory=CompanionStatus)
    values: dict[str, float] = field(default_factory=dict)
    texts: deque[str] = field(default_factory=lambda: deque(maxlen=TEXT_LINES))

    @property
    def steering(self) -> str:
        """Who steers and for what (the active task), or the helm's line if nobody does."""
        s = self.status
        if s.owner:
            return f"{s.owner}: {s.goal}" if s.goal else s.owner
        return s.status or "(no helm heard)"

    def row(self, now: float) -> dict[str, Any]:
        heard = max((t for t in (self.heard_at, self.companion_at) if t is not None),
                    default=None)
        return {"sysid": self.sysid, "mode": self.mode, "armed": self.armed,
                "online": self.status.online, "helm": self.status.status,
                "owner": self.status.owner, "goal": self.status.goal,
                "tasks": list(self.status.tasks), "steering": self.steering,
                "x": self.values.get("NAV_X"), "y": self.values.get("NAV_Y"),
                "heading": self.values.get("NAV_HDG"), "texts": list(self.texts),
                "silent": heard is None or now - heard > STALE_S}


def _text(value: Any) -> str:
    if isinstance(value, (bytes, bytearray)):
        value = bytes(value).decode("utf-8", "replace")
    return str(value).rstrip("\x00")


@dataclass
class Fleet:
    """Every vehicle heard, by MAV_SYSID."""

    boats: dict[int, Boat] = field(default_factory=dict)

    def _boat(self, sysid: int) -> Boat:
        boat = self.boats.get(sysid)
        if boat is None:
            boat = self.boats[sysid] = Boat(sysid)
        return boat

    def take(self, msg: Any, now: float) -> None:
        """One message heard at ``now``; what no vehicle sends (a ground station's) is ignored,
        and a malformed one changes nothing."""
        kind = msg.get_type()
        sysid = msg.get_srcSystem()
        if kind == "HEARTBEAT":
            if msg.type == mavlink.MAV_TYPE_GCS or msg.autopilot == mavlink.MAV_AUTOPILOT_INVALID:
                return
            boat = self._boat(sysid)
            boat.heard_at = now
            boat.mode = ROVER_MODES.get(msg.custom_mode, f"MODE{msg.custom_mode}")
            boat.armed = bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
        elif kind == "TUNNEL" and msg.payload_type == STATUS_PAYLOAD_TYPE:
            length = max(0, min(int(msg.payload_length), len(msg.payload)))
            event = decode(bytes(msg.payload[:length]))
            if event is not None:
                boat = self._boat(sysid)
                boat.companion_at = now
                boat.status = boat.status.apply(event)
        elif kind == "NAMED_VALUE_FLOAT":
            value = float(msg.value)
            if math.isfinite(value):
                boat = self._boat(sysid)
                boat.companion_at = now
                boat.values[_text(msg.name)] = value
        elif kind == "STATUSTEXT" and sysid in self.boats:
            self.boats[sysid].texts.append(_text(msg.text))

    def rows(self, now: float) -> list[dict[str, Any]]:
        return [self.boats[s].row(now) for s in sorted(self.boats)]

    def lines(self, now: float) -> list[str]:
        """The console's table: one line a vehicle."""
        out = [f"{'SYS':>3}  {'MODE':<8} {'ARM':<3} {'HELM':<7} {'X':>8} {'Y':>8} {'HDG':>5}  "
               "STEERING"]
        for r in self.rows(now):
            pos = [f"{r[k]:8.1f}" if r[k] is not None else f"{'-':>8}" for k in ("x", "y")]
            hdg = f"{r['heading']:5.0f}" if r["heading"] is not None else f"{'-':>5}"
            helm = {True: "ONLINE", False: "offline", None: "?"}[r["online"]]
            arm = {True: "yes", False: "no", None: "?"}[r["armed"]]
            silent = "  (silent)" if r["silent"] else ""
            out.append(f"{r['sysid']:>3}  {r['mode'] or '?':<8} {arm:<3} {helm:<7} {pos[0]} "
                       f"{pos[1]} {hdg}  {r['steering']}{silent}")
        return out
