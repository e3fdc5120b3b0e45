"""The web page's server: aiohttp on its own thread and event loop.

aiohttp (HTTP and websockets in one well-kept package, with no other server to run) serves the
page and pushes frames to every open page over a websocket. The companion's tick never waits
for it: the tick drops its newest frame into a one-slot :class:`Mailbox` (a frame the server has
not taken yet is replaced and counted as dropped) and takes the page's actions from a bounded
queue. A slow browser only misses frames: each page's send runs on its own, and a page still
busy with the last frame skips the next.
"""

from __future__ import annotations

import asyncio
import contextlib
import hmac
import json
import queue
import threading
from dataclasses import dataclass
from importlib import resources
from typing import Any

from aiohttp import WSMsgType, web

from mavhelm.companion.web.control import ACTIONS, Action

TOKEN_HEADER = "X-Mavhelm-Token"
"""The control token travels in a header: a page from another site cannot set one without the
browser asking this server first (CORS), so it cannot forge an action."""

ACTION_QUEUE = 8
"""Actions waiting for the next tick; more are refused (503) rather than queued without end."""

TRACK_POINTS = 5000
"""The track a page that opens late is sent (the newest points)."""

STATIC = ("index.html", "picture.js", "picture.css")


class Mailbox:
    """One slot: the newest frame. ``offer`` never blocks; a frame not taken before the next
    is offered is dropped (counted)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._frame: dict[str, Any] | None = None
        self.dropped = 0
        self._wake: tuple[asyncio.AbstractEventLoop, asyncio.Event] | None = None

    def bind(self, loop: asyncio.AbstractEventLoop, event: asyncio.Event) -> None:
        self._wake = (loop, event)

    def offer(self, frame: dict[str, Any]) -> None:
        with self._lock:
            pending = self._frame is not None
            self._frame = frame
            if pending:
                self.dropped += 1
        if not pending and self._wake is not None:
            loop, event = self._wake
            with contextlib.suppress(RuntimeError):  # the loop has closed
                loop.call_soon_threadsafe(event.set)

    def take(self) -> dict[str, Any] | None:
        with self._lock:
            frame, self._frame = self._frame, None
        return frame


@dataclass
class _Page:
    ws: web.WebSocketResponse
    busy: bool = False


class WebServer:
    """Serves the page at ``http://host:port/``, frames on ``/ws``, the last frame on
    ``/api/state``, and (with a ``token``) actions on ``POST /api/control/<action>``."""

    def __init__(self, host: str = "127.0.0.1", port: int = 8080, *,
                 token: str | None = None) -> None:
        self.host = host
        self.port = port
        self.token = token
        self.mailbox = Mailbox()
        self.actions: queue.Queue[Action] = queue.Queue(ACTION_QUEUE)
        self.mission: dict[str, Any] = {}
        self.track: list[list[float]] = []
        self.last: dict[str, Any] = {}
        self.pages: list[_Page] = []
        self.sent = 0
        self.skipped = 0
        self._loop: asyncio.AbstractEventLoop | None = None
        self._runner: web.AppRunner | None = None
        self._thread: threading.Thread | None = None
        self._started = threading.Event()
        self._error: BaseException | None = None
        self._stop: asyncio.Event | None = None

    # -- the companion's side ------------------------------------------------------------------

    def start(self, timeout: float = 10.0) -> None:
        """Listen (port 0 picks a free one: ``port`` then holds it); raises OSError if the
        address cannot be had."""
        self._thread = threading.Thread(target=self._serve, name="mavhelm-web", daemon=True)
        self._thread.start()
        if not self._started.wait(timeout):
            raise OSError(f"the web server did not start on {self.host}:{self.port}")
        if self._error is not None:
            raise OSError(f"cannot serve the web page on {self.host}:{self.port}: "
                          f"{self._error}") from self._error

    def stop(self) -> None:
        loop, stop = self._loop, self._stop
        if loop is not None and stop is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):
                loop.call_soon_threadsafe(stop.set)
        if self._thread is not None:
            self._thread.join(5.0)

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"http://{host}:{self.port}/"

    # -- the server's thread -------------------------------------------------------------------

    def _serve(self) -> None:
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._main())
        except BaseException as exc:  # noqa: BLE001 - reported to start(), never to the tick
            self._error = exc
        finally:
            self._started.set()
            loop.close()

    async def _main(self) -> None:
        self._stop = asyncio.Event()
        wake = asyncio.Event()
        self.mailbox.bind(asyncio.get_running_loop(), wake)
        app = web.Application()
        app.add_routes([web.get("/", self._index), web.get("/ws", self._websocket),
                        web.get("/api/state", self._state),
                        web.post("/api/control/{action}", self._control),
                        *[web.get(f"/{name}", self._static) for name in STATIC]])
        self._runner = web.AppRunner(app, access_log=None)
        await self._runner.setup()
        site = web.TCPSite(self._runner, self.host, self.port)
        await site.start()
        server = getattr(site, "_server", None)
        if server is not None and server.sockets:
            self.port = server.sockets[0].getsockname()[1]
        self._started.set()
        pump = asyncio.create_task(self._pump(wake))
        await self._stop.wait()
        pump.cancel()
        for page in list(self.pages):
            await page.ws.close()
        await self._runner.cleanup()

    async def _pump(self, wake: asyncio.Event) -> None:
        while True:
            await wake.wait()
            wake.clear()
            frame = self.mailbox.take()
            if frame is None:
                continue
            self._absorb(frame)
            text = json.dumps(frame, separators=(",", ":"), allow_nan=False)
            for page in list(self.pages):
                if page.busy:
                    self.skipped += 1
                    continue
                page.busy = True
                asyncio.create_task(self._send(page, text))

    def _absorb(self, frame: dict[str, Any]) -> None:
        """Keep what a page opening late needs: the mission and the whole track."""
        if "mission" in frame:
            self.mission = frame["mission"]
            self.track = []
        self.track.extend(frame.get("track", ()))
        del self.track[:-TRACK_POINTS]
        self.last = frame

    async def _send(self, page: _Page, text: str) -> None:
        try:
            await page.ws.send_str(text)
            self.sent += 1
        except (ConnectionError, RuntimeError):
            pass
        finally:
            page.busy = False

    async def _websocket(self, request: web.Request) -> web.WebSocketResponse:
        ws = web.WebSocketResponse(heartbeat=10.0)
        await ws.prepare(request)
        hello = {"type": "hello", "mission": self.mission, "track": self.track,
                 "control": self.token is not None, "actions": list(ACTIONS)}
        await ws.send_str(json.dumps(hello, separators=(",", ":"), allow_nan=False))
        page = _Page(ws)
        self.pages.append(page)
        try:
            async for msg in ws:
                if msg.type in (WSMsgType.ERROR, WSMsgType.CLOSE):
                    break
        finally:
            self.pages.remove(page)
        return ws

    async def _index(self, request: web.Request) -> web.Response:
        return self._file("index.html")

    async def _static(self, request: web.Request) -> web.Response:
        return self._file(request.path.lstrip("/"))

    @staticmethod
    def _file(name: str) -> web.Response:
        text = resources.files("mavhelm.companion.web").joinpath("static", name).read_text()
        kind = {"html": "text/html", "js": "text/javascript", "css": "text/css"}
        return web.Response(text=text, content_type=kind[name.rpartition(".")[2]],
                            headers={"Cache-Control": "no-store"})

    async def _state(self, request: web.Request) -> web.Response:
        return web.json_response({**self.last, "mission": self.mission},
                                 dumps=lambda v: json.dumps(v, allow_nan=False))

    async def _control(self, request: web.Request) -> web.Response:
        """An action from the page: refused (403) when control is off or the token is wrong,
        changing nothing; otherwise queued for the next tick (202)."""
        given = request.headers.get(TOKEN_HEADER, "")
        if self.token is None:
            return web.json_response({"error": "control is off (mavhelm run --web-control)"},
                                     status=403)
        if not given:
            return web.json_response({"error": f"no {TOKEN_HEADER} header"}, status=401)
        if not hmac.compare_digest(given.encode(), self.token.encode()):
            return web.json_response({"error": "wrong token"}, status=403)
        name = request.match_info["action"]
        if name not in ACTIONS:
            return web.json_response({"error": f"unknown action {name!r} (known: "
                                      f"{', '.join(ACTIONS)})"}, status=404)
        try:
            body = await request.json() if request.can_read_body else {}
        except ValueError:
            body = None
        if not isinstance(body, dict):
            return web.json_response({"error": "the body must be a JSON object"}, status=400)
        peer = request.remote or "?"
        try:
            action = Action.parse(name, body, peer)
        except ValueError as exc:
            return web.json_response({"error": str(exc)}, status=400)
        try:
            self.actions.put_nowait(action)
        except queue.Full:
            return web.json_response({"error": "busy: too many actions waiting"}, status=503)
        return web.json_response({"queued": action.describe()}, status=202)


DEFAULT_HOST = "127.0.0.1"


def parse_address(text: str) -> tuple[str, int]:
    """``[HOST:]PORT`` (``[::1]:8080`` for IPv6): loopback unless a host is given; ValueError
    says what is wrong."""
    host, sep, port = text.rpartition(":")
    if not sep:
        host = DEFAULT_HOST
    host = host.strip("[]") or DEFAULT_HOST
    try:
        number = int(port)
    except ValueError:
        number = -1
    if not 0 <= number <= 65535:
        raise ValueError(f"expected [HOST:]PORT with PORT 0-65535, not {text!r}")
    return host, number
