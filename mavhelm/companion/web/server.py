"""The web page's server: aiohttp in a process of its own.

aiohttp (HTTP and websockets in one well-kept package, with no other server to run) serves the
page and pushes frames to every open page over a websocket. It runs in a child process, not a
thread: a thread would share the interpreter lock with the companion's tick, and on a busy
computer a server thread that the kernel pauses while it holds that lock stalls the tick for
milliseconds. The two talk over a local socket pair that keeps message boundaries
(SOCK_SEQPACKET): the companion sends each tick's facts pickled, without waiting
(``WebProcess.offer``; what the socket has no room for is dropped and counted), and reads the
page's actions, and any frame the server could not make, without waiting (``WebProcess.actions``,
``WebProcess.problems``). The server makes the page's frames from the facts (``frames.py``) and
encodes them, so that work stays off the helm's tick; pickle is safe on this channel, whose two
ends are the companion and the child it started. The server, at a lower priority, reads the
channel on its own timer rather than waking on each message, so a send never hands the
processor to it. A slow browser
only misses frames: each page's send runs on its own, and a page still busy with the last
frame skips the next. The child exits when the companion's end of the socket closes, so it
never outlives the companion.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import hmac
import json
import os
import pickle
import select
import socket
import subprocess
import sys
from dataclasses import asdict, dataclass
from importlib import resources
from typing import Any

from mavhelm.companion.web.control import ACTIONS, Action
from mavhelm.companion.web.frames import Frames

TOKEN_HEADER = "X-Mavhelm-Token"
"""The control token travels in a header: a page from another site cannot set one without the
browser asking this server first (CORS), so it cannot forge an action."""

TRACK_POINTS = 5000
"""The track a page that opens late is sent (the newest points)."""

ACTIONS_PER_TICK = 4
MESSAGE_MAX = 1 << 20
STATIC = ("index.html", "picture.js", "picture.css")
DEFAULT_HOST = "127.0.0.1"
NICE = 10
"""The server process's niceness: below the companion's."""
POLL_S = 0.05
"""How often the server reads the companion's frames (they come 4 times a second)."""


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


def _url(host: str, port: int) -> str:
    return f"http://[{host}]:{port}/" if ":" in host else f"http://{host}:{port}/"


# -- the companion's side ----------------------------------------------------------------------

class WebProcess:
    """The server process, from the companion: ``start``, then ``offer`` frames and take
    ``actions`` each tick (neither ever waits), ``stop`` at the end."""

    def __init__(self, host: str = DEFAULT_HOST, port: int = 8080, *,
                 token: str | None = None) -> None:
        self.host = host
        self.port = port
        self.token = token
        self.dropped = 0
        self.sent = 0
        self._problems: list[str] = []
        self._readable = select.poll()
        self._sock: socket.socket | None = None
        self._proc: subprocess.Popen | None = None

    @property
    def url(self) -> str:
        return _url(self.host, self.port)

    def start(self, timeout: float = 20.0) -> None:
        """Start the server and wait until it listens (port 0 picks a free one: ``port`` then
        holds it); OSError if the address cannot be had."""
        ours, theirs = socket.socketpair(socket.AF_UNIX, socket.SOCK_SEQPACKET)
        self._sock = ours
        try:
            self._proc = subprocess.Popen(
                [sys.executable, "-m", "mavhelm.companion.web.server", str(theirs.fileno())],
                pass_fds=(theirs.fileno(),), stdin=subprocess.DEVNULL)
        finally:
            theirs.close()
        ours.sendall(json.dumps({"host": self.host, "port": self.port,
                                 "token": self.token}).encode())
        ready, _, _ = select.select([ours], [], [], timeout)
        reply = json.loads(ours.recv(MESSAGE_MAX) or b"{}") if ready else {}
        if "listening" not in reply:
            self.stop()
            raise OSError(reply.get("error", f"the web server did not start in {timeout:g} s"))
        self.port = int(reply["listening"])
        ours.setblocking(False)
        self._readable.register(ours, select.POLLIN)

    def offer(self, message: dict[str, Any]) -> bool:
        """Send ``message`` (a tick's facts, ``type`` "facts", or a ready frame) if the socket
        has room now; else drop it (counted)."""
        if self._sock is None:
            return False
        data = pickle.dumps(message, protocol=pickle.HIGHEST_PROTOCOL)
        try:
            self._sock.send(data)
        except OSError:  # no room (EAGAIN), too big, or the server has gone
            self.dropped += 1
            return False
        self.sent += 1
        return True

    def actions(self) -> list[Action]:
        """The page's actions that have arrived (at most ``ACTIONS_PER_TICK``)."""
        out: list[Action] = []
        if self._sock is None or not self._readable.poll(0):
            return out
        while self._sock is not None and len(out) < ACTIONS_PER_TICK:
            try:
                data = self._sock.recv(MESSAGE_MAX)
            except OSError:
                break
            if not data:
                break
            with contextlib.suppress(ValueError, TypeError, KeyError):
                message = json.loads(data)
                if "problem" in message:
                    self._problems.append(str(message["problem"]))
                else:
                    out.append(Action(**message))
        return out

    def problems(self) -> list[str]:
        """What the server said it could not make into a frame since the last call (read with
        the actions)."""
        out, self._problems = self._problems, []
        return out

    def stop(self) -> None:
        if self._sock is not None:
            self._sock.close()
            self._sock = None
        if self._proc is not None:
            try:
                self._proc.wait(5.0)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()
            self._proc = None


# -- the server process ------------------------------------------------------------------------

@dataclass
class _Page:
    ws: Any
    busy: bool = False


class PageServer:
    """Serves the page at ``/``, frames on ``/ws``, the last frame on ``/api/state``, and (with
    a ``token``) actions on ``POST /api/control/<action>``, handed to the companion over
    ``channel``."""

    def __init__(self, channel: socket.socket, host: str, port: int,
                 token: str | None) -> None:
        self.channel = channel
        self.host, self.port, self.token = host, port, token
        self.frames = Frames()
        self.mission: dict[str, Any] = {}
        self.track: list[list[float]] = []
        self.last: dict[str, Any] = {}
        self.pages: list[_Page] = []
        self.skipped = 0
        self._closed: asyncio.Event | None = None

    async def serve(self) -> None:
        from aiohttp import web

        self._closed = asyncio.Event()
        app = web.Application()
        app.add_routes([web.get("/", self._index), web.get("/ws", self._websocket),
                        web.get("/api/state", self._state),
                        web.post("/api/control/{action}", self._control),
                        *[web.get(f"/{name}", self._static) for name in STATIC]])
        runner = web.AppRunner(app, access_log=None)
        await runner.setup()
        site = web.TCPSite(runner, self.host, self.port)
        try:
            await site.start()
        except OSError as exc:
            self._reply({"error": f"cannot listen on {self.host}:{self.port}: "
                                  f"{exc.strerror or exc}"})
            return
        server = getattr(site, "_server", None)
        if server is not None and server.sockets:
            self.port = server.sockets[0].getsockname()[1]
        self._reply({"listening": self.port})
        self.channel.setblocking(False)
        poll = asyncio.create_task(self._poll_channel())
        await self._closed.wait()
        poll.cancel()
        for page in list(self.pages):
            await page.ws.close()
        await runner.cleanup()

    def _reply(self, message: dict[str, Any]) -> None:
        with contextlib.suppress(BlockingIOError):
            self.channel.sendall(json.dumps(message).encode())

    async def _poll_channel(self) -> None:
        """Read the channel every ``POLL_S`` rather than wait on it: a frame the tick sends then
        wakes nothing, so the kernel never switches from the tick to this process on a send."""
        while True:
            self._on_channel()
            await asyncio.sleep(POLL_S)

    def _on_channel(self) -> None:
        """Facts (or ready frames) from the companion, each made into a frame and absorbed; the
        newest is broadcast; the companion's end closing ends the server. A frame that cannot be
        made or encoded is skipped and said to the companion, which announces it."""
        newest = None
        while True:
            try:
                data = self.channel.recv(MESSAGE_MAX)
            except BlockingIOError:
                break
            except OSError:
                data = b""
            if not data:
                assert self._closed is not None
                self._closed.set()
                return
            try:
                message = pickle.loads(data)
                frame = self.frames.frame(message) if message.get("type") == "facts" else message
                text = json.dumps(frame, separators=(",", ":"), allow_nan=False)
            except Exception as exc:  # noqa: BLE001 - a bad frame must not end the page
                self._reply({"problem": f"{type(exc).__name__}: {exc}"})
                continue
            self._absorb(frame)
            newest = text
        if newest is not None:
            self._broadcast(newest)

    def _absorb(self, frame: dict[str, Any]) -> None:
        """Keep what a page opening late needs: the mission and the whole track."""
        if "mission" in frame:
            self.mission = frame["mission"]
            self.track = []
        self.track.extend(frame.get("track", ()))
        del self.track[:-TRACK_POINTS]
        self.last = frame

    def _broadcast(self, text: str) -> None:
        for page in list(self.pages):
            if page.busy:
                self.skipped += 1
                continue
            page.busy = True
            asyncio.create_task(self._send(page, text))

    @staticmethod
    async def _send(page: _Page, text: str) -> None:
        try:
            await page.ws.send_str(text)
        except (ConnectionError, RuntimeError):
            pass
        finally:
            page.busy = False

    async def _websocket(self, request):
        from aiohttp import WSMsgType, web

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

    async def _index(self, request):
        return self._file("index.html")

    async def _static(self, request):
        return self._file(request.path.lstrip("/"))

    @staticmethod
    def _file(name: str):
        from aiohttp import web

        text = resources.files("mavhelm.companion.web").joinpath("static", name).read_text()
        kind = {"html": "text/html", "js": "text/javascript", "css": "text/css"}
        return web.Response(text=text, content_type=kind[name.rpartition(".")[2]],
                            headers={"Cache-Control": "no-store"})

    async def _state(self, request):
        from aiohttp import web

        return web.json_response({**self.last, "mission": self.mission,
                                  "track_points": len(self.track), "skipped": self.skipped})

    async def _control(self, request):
        """An action from the page: refused when control is off (403), without the token
        (401) or with a wrong one (403), changing nothing; otherwise handed to the companion
        (202), or refused (503) if the companion has not taken the ones before."""
        from aiohttp import web

        given = request.headers.get(TOKEN_HEADER, "")
        if self.token is None:
            return web.json_response({"error": "control is off (mavhelm run --web-control)"},
                                     status=403)
        if not given:
            return web.json_response({"error": f"no {TOKEN_HEADER} header"}, status=401)
        if not hmac.compare_digest(given.encode(), self.token.encode()):
            return web.json_response({"error": "wrong token"}, status=403)
        try:
            body = await request.json() if request.can_read_body else {}
            action = Action.parse(request.match_info["action"],
                                  body if isinstance(body, dict) else {}, request.remote or "?")
        except ValueError as exc:
            return web.json_response({"error": str(exc)}, status=400)
        try:
            self.channel.send(json.dumps(asdict(action)).encode())
        except OSError:
            return web.json_response({"error": "busy: the companion has not taken the "
                                      "actions before"}, status=503)
        return web.json_response({"queued": action.describe()}, status=202)


def main(argv: list[str] | None = None) -> int:
    """The child process: its socket's file descriptor is the one argument; the first message
    on it is the address and token."""
    parser = argparse.ArgumentParser(prog="mavhelm-web")
    parser.add_argument("fd", type=int)
    args = parser.parse_args(argv)
    channel = socket.socket(fileno=args.fd)
    with contextlib.suppress(OSError):
        os.nice(NICE)  # the helm first, on a busy computer
    config = json.loads(channel.recv(MESSAGE_MAX) or b"{}")
    if not config:
        return 1
    server = PageServer(channel, config["host"], int(config["port"]), config.get("token"))
    with contextlib.suppress(KeyboardInterrupt):
        asyncio.run(server.serve())
    channel.close()
    return 0


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    sys.exit(main())
