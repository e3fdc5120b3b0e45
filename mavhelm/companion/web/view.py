"""The community app behind the web page: gathers the facts of the tick (the bus values posted
since the last frame, the typed status, the running tasks, the steering task's goal)
``FRAME_RATE_HZ`` times a second and hands them to the server process without waiting, which
makes the page's frame from them (``frames.py``) off the helm's tick; takes the page's actions in
the tick and gives them to the bridge as a ground station's commands.
"""

from __future__ import annotations

import secrets
import time
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
BUSY_TICK = 2.0
"""A tick that has already taken this many times the usual before the view's turn is busy: the
frame waits for the next tick (at most ``MAX_DEFERRED`` in a row), so the picture's work lands
in the tick's slack rather than on the helm's slowest ticks."""
MAX_DEFERRED = 2
USUAL_STEPS = (1.01, 0.97)
"""The view's idea of a usual tick steps up by 1 % after a longer tick and down by 3 % after a
shorter one: it settles on the ticks' lower quartile, which slow ticks do not drag up."""
FAILURE_REPEAT_S = 10.0
ACTION_VARIABLE = "WEB_CONTROL_WARNING"
"""Every action from the page, posted as an alert: logged, printed, sent as STATUSTEXT."""


class WebView(App):
    """Facts for ``server`` from ``companion`` (its helm is looked up each frame, so a
    RESTART_HELM shows the new mission)."""

    name = "iWeb"

    def __init__(self, companion: Companion, server: WebProcess,
                 echo: Callable[[str], None] | None = None) -> None:
        super().__init__(companion.bus)
        self.companion = companion
        self.server = server
        self.echo = echo
        self._mail: list[Message] = []
        self._next_frame: float | None = None
        self._usual_s: float | None = None
        self.deferred = 0
        self._deferred_in_row = 0
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
        self._mail += mail

    def iterate(self, now: float) -> None:
        self._take_actions(now)
        for problem in self.server.problems():
            self._failed(problem, now)
        busy = self._busy_tick()
        due = self._next_frame
        if due is not None and now < due:
            return
        if busy and self._deferred_in_row < MAX_DEFERRED:
            self._deferred_in_row += 1
            self.deferred += 1
            return
        self._deferred_in_row = 0
        period = 1.0 / FRAME_RATE_HZ
        self._next_frame = due + period if due is not None and now - due < period else now + period
        try:
            self.server.offer(self.facts(now))
        except Exception as exc:  # noqa: BLE001 - the picture must never stop the helm
            self._failed(f"{type(exc).__name__}: {exc}", now)

    def _busy_tick(self) -> bool:
        """Whether this tick has been busy so far (against the usual, which it updates)."""
        so_far = time.perf_counter() - self.companion.community.tick_started
        usual = so_far if self._usual_s is None else self._usual_s
        self._usual_s = usual * USUAL_STEPS[0 if so_far > usual else 1]
        return so_far > BUSY_TICK * usual

    def _failed(self, problem: str, now: float) -> None:
        self.failures += 1
        if self._failure_said is None or now - self._failure_said >= FAILURE_REPEAT_S:
            self._failure_said = now
            self.notify("WEB_VIEW_WARNING", f"a frame could not be made ({problem}); "
                        "the helm carries on")

    def facts(self, now: float) -> dict[str, Any]:
        """What the tick knows for the page at ``now``: the values posted since the last
        frame, and the mission's shapes only when the helm is new."""
        helm = self.companion.helm
        status = self._console.status if self._console is not None else CompanionStatus()
        owner = next((t for t in helm.tasks if t.name == status.owner and t.active), None)
        mail, self._mail = self._mail, []
        bridge = self.companion.bridge
        heartbeat = bridge.last_heartbeat
        facts: dict[str, Any] = {
            "type": "facts", "t": now, "status": status,
            "values": {m.name: m.value for m in mail},
            "goal": picture.active_goal(owner) if owner is not None else None,
            "running": picture.running_tasks(helm.tasks, now),
            "link": {"packets": bridge.packets, "bad_packets": bridge.bad_packets,
                     "heartbeat_age": None if heartbeat is None else round(now - heartbeat, 1),
                     "connect": bridge.config.connect},
            "web": {"dropped": self.server.dropped},
        }
        if helm is not self._helm:
            self._helm = helm
            facts["mission"] = {"shapes": picture.mission_shapes(helm.tasks),
                                "beacons": self._beacons,
                                "flags": picture.flag_names(helm.tasks),
                                "remote_flags": list(bridge.config.remote_flags),
                                "path": str(self.companion.mission.path)}
        return facts

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
