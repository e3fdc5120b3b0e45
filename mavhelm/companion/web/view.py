"""The community app behind the web page: keeps the bus's latest values and the track, builds
a frame ``FRAME_RATE_HZ`` times a second and hands it to the server process without waiting;
takes the page's actions in the tick and gives them to the bridge as a ground station's
commands.
"""

from __future__ import annotations

import math
import secrets
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from mavhelm.companion.bridge.handlers import local_command
from mavhelm.companion.console import StatusConsole
from mavhelm.companion.status import CompanionStatus
from mavhelm.companion.web import picture
from mavhelm.companion.web.control import WEB_COMPONENT, as_heard
from mavhelm.companion.web.server import WebProcess, parse_address
from mavhelm.core.app import App
from mavhelm.core.bus import Message

if TYPE_CHECKING:
    from mavhelm.companion.companion import Companion

FRAME_RATE_HZ = 4.0
TRACK_STEP_M = 0.5
"""A new track point once the vehicle has moved this far."""
FAILURE_REPEAT_S = 10.0
ACTION_VARIABLE = "WEB_CONTROL_WARNING"
"""Every action from the page, posted as an alert: logged, printed, sent as STATUSTEXT."""


class WebView(App):
    """Frames for ``server`` from ``companion`` (its helm is looked up each frame, so a
    RESTART_HELM shows the new mission)."""

    name = "iWeb"

    def __init__(self, companion: Companion, server: WebProcess,
                 echo: Callable[[str], None] | None = None) -> None:
        super().__init__(companion.bus)
        self.companion = companion
        self.server = server
        self.echo = echo
        self.values: dict[str, float | str] = {}
        self.alerts: list[str] = []
        self._track_new: list[list[float]] = []
        self._last_point: tuple[float, float] | None = None
        self._next_frame: float | None = None
        self.failures = 0
        self._failure_said: float | None = None
        self._helm: object | None = None
        self._console = next((a for a in companion.community.apps
                              if isinstance(a, StatusConsole)), None)
        fusion = companion.navigator.fusion
        self._beacons = picture.beacon_shapes(fusion.config.beacons if fusion else ())

    def subscriptions(self) -> frozenset[str]:
        return frozenset({"*"})

    def on_mail(self, mail: list[Message], now: float) -> None:
        values = self.values
        for msg in mail:
            values[msg.name] = msg.value
            if msg.name.endswith(("_ERROR", "_WARNING", "_REFUSED")) or msg.name == "NAV_WARNING":
                self.alerts.insert(0, f"{msg.name}: {msg.value}")
                del self.alerts[picture.ALERT_LINES:]
        x, y = values.get("NAV_X"), values.get("NAV_Y")
        if isinstance(x, float) and isinstance(y, float) and math.isfinite(x + y):
            last = self._last_point
            if last is None or math.hypot(x - last[0], y - last[1]) >= TRACK_STEP_M:
                self._last_point = (x, y)
                self._track_new.append([round(x, 2), round(y, 2)])

    def iterate(self, now: float) -> None:
        self._take_actions(now)
        if self._next_frame is not None and now < self._next_frame:
            return
        self._next_frame = now + 1.0 / FRAME_RATE_HZ
        try:
            self.server.offer(self.frame(now))
        except Exception as exc:  # noqa: BLE001 - the picture must never stop the helm
            self.failures += 1
            if self._failure_said is None or now - self._failure_said >= FAILURE_REPEAT_S:
                self._failure_said = now
                self.notify("WEB_VIEW_WARNING", f"a frame could not be made "
                            f"({type(exc).__name__}: {exc}); the helm carries on")

    def frame(self, now: float) -> dict[str, Any]:
        """What the page shows at ``now``; the mission's shapes only when the helm is new."""
        helm = self.companion.helm
        status = self._console.status if self._console is not None else CompanionStatus()
        owner = next((t for t in helm.tasks if t.name == status.owner and t.active), None)
        track, self._track_new = self._track_new, []
        bridge = self.companion.bridge
        heartbeat = bridge.last_heartbeat
        frame: dict[str, Any] = {
            "type": "frame", "t": round(now, 2), "status": picture.status_dict(status),
            "poses": picture.poses(self.values), "track": track,
            "goal": picture.active_goal(owner) if owner is not None else None,
            "running": picture.running_tasks(helm.tasks, now),
            "flags": {name: _shown(self.values[name]) for name in picture.flag_names(helm.tasks)
                      if name in self.values},
            "alerts": list(self.alerts),
            "ranges": picture.ranges(self.values),
            "link": {"packets": bridge.packets, "bad_packets": bridge.bad_packets,
                     "heartbeat_age": None if heartbeat is None else round(now - heartbeat, 1),
                     "connect": bridge.config.connect},
            "web": {"dropped": self.server.dropped},
        }
        if helm is not self._helm:
            self._helm = helm
            frame["mission"] = {"shapes": picture.mission_shapes(helm.tasks),
                                "beacons": self._beacons,
                                "remote_flags": list(bridge.config.remote_flags),
                                "path": str(self.companion.mission.path)}
        return frame

    def _take_actions(self, now: float) -> None:
        """The page's actions, each announced and then handed to the bridge as a COMMAND_LONG
        from the local bus (never as a MAVLink sender, which a radio could impersonate)."""
        for action in self.server.actions():
            self.notify(ACTION_VARIABLE, f"{action.describe()} from the web page "
                        f"({action.peer})")
            bridge = self.companion.bridge
            config = bridge.config
            online_mode = config.online_modes[0] if config.online_modes else "GUIDED"
            msg = action.command(online_mode, (config.system_id, config.component_id))
            local_command(bridge, as_heard(msg, (config.system_id, WEB_COMPONENT)), now)


def _shown(value: float | str) -> float | str:
    return value if isinstance(value, str) or math.isfinite(value) else str(value)


def start_web(companion: Companion, address: str, *, control: bool = False,
              echo: Callable[[str], None] = print) -> WebProcess:
    """Serve ``companion``'s picture on ``address`` (``[HOST:]PORT``), with the control
    actions behind a fresh token when ``control``; the view joins the community last, so a
    frame shows the tick that has just run."""
    host, port = parse_address(address)
    token = secrets.token_urlsafe(16) if control else None
    server = WebProcess(host, port, token=token)
    server.start()
    companion.community.apps.append(WebView(companion, server))
    echo(f"mavhelm: web view on {server.url} (read-only)" if token is None else
         f"mavhelm: web view on {server.url} with control; token {token} "
         f"(open {server.url}#token={token})")
    return server
