"""``mavhelm remote`` at the edge: keys from a terminal or a pipe, the screen, the link, and
the command line. The console's knowledge and decisions are in ``state.py``."""

from __future__ import annotations

import argparse
import codecs
import os
import select
import shutil
import signal
import socket
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from mavhelm.companion.bridge import COMPANION_COMPONENT
from mavhelm.companion.link import AutopilotLink, transport_for
from mavhelm.companion.remote.state import (
    GCS_COMPONENT_ID,
    GCS_SYSTEM_ID,
    Message,
    RemoteState,
)
from mavhelm.companion.remote.view import render
from mavhelm.companion.signing import KeyFileError, enable_signing, read_key


def parse_ids(text: str) -> tuple[int, int]:
    """``SYS:COMP`` → (system, component), each 0…255 (argparse type)."""
    sys_text, sep, comp_text = text.partition(":")
    try:
        ids = (int(sys_text), int(comp_text))
    except ValueError:
        ids = (-1, -1)
    if not sep or not all(0 <= v <= 255 for v in ids):
        raise argparse.ArgumentTypeError(f"expected SYSTEM:COMPONENT (0-255 each), got {text!r}")
    return ids


ARROWS = {"A": "up", "B": "down", "C": "right", "D": "left"}
ESC_FLUSH_S = 0.1


class KeyReader:
    """Splits what arrives on stdin into keys. Escape sequences are whole keys (arrows become
    ``up``/``down``/``left``/``right``, anything else ``esc``), so the ``A`` of an up-arrow
    can never arm the autopilot."""

    def __init__(self) -> None:
        self._decoder = codecs.getincrementaldecoder("utf-8")(errors="replace")
        self._held = ""
        self._held_at = 0.0

    def feed(self, data: bytes, now: float) -> list[str]:
        text = self._held + self._decoder.decode(data)
        self._held = ""
        keys: list[str] = []
        i = 0
        while i < len(text):
            ch = text[i]
            if ch != "\x1b":
                keys.append(ch)
                i += 1
                continue
            if i + 1 >= len(text):
                self._held, self._held_at = text[i:], now  # maybe the start of a sequence
                break
            if text[i + 1] not in "[O":
                keys.append("esc")  # Alt+key: swallowed whole, so Alt+A cannot arm
                i += 2
                continue
            j = i + 2
            while j < len(text) and not ("\x40" <= text[j] <= "\x7e"):
                j += 1  # CSI parameter bytes
            if j >= len(text):
                self._held, self._held_at = text[i:], now
                break
            keys.append(ARROWS.get(text[j], "esc") if j == i + 2 else "esc")
            i = j + 1
        return keys

    def flush(self, now: float) -> list[str]:
        """A lone ESC (or a cut-off sequence) held too long is an ESC key."""
        if self._held and now - self._held_at >= ESC_FLUSH_S:
            self._held = ""
            return ["esc"]
        return []


class _Stop(Exception):
    """SIGTERM or SIGHUP: leave as ``q`` does."""


def _raise_stop(signum, frame) -> None:
    raise _Stop(signal.Signals(signum).name)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--connect", required=True,
                        help="the vehicle: tcp:HOST:PORT, udp:HOST:PORT (listen), "
                             "udpout:HOST:PORT or a serial device (a telemetry radio)")
    parser.add_argument("--baud", type=int, default=57600, help="serial baud rate (57600)")
    parser.add_argument("--sysid", type=int, default=GCS_SYSTEM_ID,
                        help="this ground station's system id (default 255: ArduPilot takes "
                             "RC override only from MAV_GCS_SYSID)")
    parser.add_argument("--compid", type=int, default=GCS_COMPONENT_ID,
                        help="this ground station's component id (default 190)")
    parser.add_argument("--target", type=parse_ids, default=(1, 1), metavar="SYS:COMP",
                        help="the autopilot (default 1:1)")
    parser.add_argument("--companion", type=parse_ids, default=(1, COMPANION_COMPONENT),
                        metavar="SYS:COMP",
                        help="the companion that takes RESTART_HELM (default 1:191)")
    parser.add_argument("--key-file", default=None,
                        help="sign what this console sends (MAVLink 2 signing) with the "
                             "passphrase in this file (chmod 600); see docs/security.md")


def _send(link: AutopilotLink, messages: list[Message]) -> None:
    for msg in messages:
        link.mav.send(msg)


def _close_gently(link: AutopilotLink, wait_s: float = 0.3) -> None:
    """Close so that the last frames (the release of the sticks) get there: a TCP socket
    closed with unread input sends a reset, which can discard what is still queued. So
    finish writing, half-close, and drain until the peer closes or ``wait_s`` passes."""
    sock = link.socket() if link.connected else None
    if sock is None:
        link.close()
        return
    deadline = time.monotonic() + wait_s
    try:
        while link.unsent() and time.monotonic() < deadline:
            select.select([], [sock], [], 0.05)
            link.write(b"")
        sock.shutdown(socket.SHUT_WR)
        while (left := deadline - time.monotonic()) > 0:
            if select.select([sock], [], [], left)[0] and not sock.recv(65536):
                break
    except OSError:
        pass
    link.close()


class Screen:
    """Redraws in place (home, each line cleared to its end, the rest cleared), only when the
    picture changed."""

    def __init__(self, write: Callable[[str], None], tty: bool) -> None:
        self.write = write
        self.tty = tty
        self._last: list[str] | None = None

    def start(self) -> None:
        self.write("\x1b[?25l\x1b[2J" if self.tty else "\x1b[2J")

    def draw(self, state: RemoteState) -> None:
        size = shutil.get_terminal_size((100, 30))
        lines = render(state, max(20, size.columns - 1), size.lines if self.tty else None)
        if lines == self._last:
            return
        self._last = lines
        self.write("\x1b[H" + "".join(f"{line}\x1b[K\n" for line in lines) + "\x1b[J")

    def stop(self) -> None:
        if self.tty:
            self.write("\x1b[?25h")


def _check(args: argparse.Namespace) -> str | None:
    """What argparse cannot check: the link's address, the ids' range."""
    try:
        transport_for(args.connect, args.baud)
    except ValueError as exc:
        return str(exc)
    for name in ("sysid", "compid"):
        if not 1 <= getattr(args, name) <= 255:
            return f"--{name} must be 1-255"
    return None


def _writer(out_fd: int) -> Callable[[str], None]:
    def write(text: str) -> None:
        data = text.encode("utf-8", "replace")
        while data:
            try:
                n = os.write(out_fd, data)
            except BlockingIOError:
                select.select([], [out_fd], [], 1.0)
                continue
            data = data[n:]
    return write


@dataclass
class Session:
    """One run of the console: the state, the link, the keys and the screen."""

    state: RemoteState
    link: AutopilotLink
    screen: Screen
    stdin_fd: int
    reader: KeyReader = field(default_factory=KeyReader)
    stdin_open: bool = True
    why: str = "q"
    next_draw: float = 0.0

    def _keys(self, now: float) -> list[str]:
        keys = self.reader.flush(now)
        if self.stdin_open and select.select([self.stdin_fd], [], [], 0)[0]:
            data = os.read(self.stdin_fd, 1024)
            if not data:
                self.stdin_open = False  # EOF: a script's last key was sent
                keys.append("q")
                self.why = "end of input"
            keys += self.reader.feed(data, now)
        return keys

    def step(self) -> None:
        """One pass: the link, the keys, the periodic duties, the screen, then a short wait."""
        state, link = self.state, self.link
        now = time.monotonic()
        messages = link.poll(now)
        _send(link, state.connection(link.connected, now))
        for event in link.take_events():
            state.link_event(event, now)
        for msg in messages:
            if msg.get_type() != "BAD_DATA":
                _send(link, state.receive(msg, now))
        for key in self._keys(now):
            _send(link, state.handle_key(key, now))
            if state.quit:
                return
        _send(link, state.tick(now))
        if now >= self.next_draw:
            self.screen.draw(state)
            self.next_draw = now + 0.25
        waits = [self.stdin_fd] if self.stdin_open else []
        sock = link.fileno() if link.connected else None
        if sock is not None:
            waits.append(sock)
        select.select(waits, [], [], max(0.0, min(0.05, self.next_draw - time.monotonic())))

    def finish(self) -> None:
        """Sticks released first, the last frame drawn; a vanished terminal is no error."""
        try:
            self.state.now = time.monotonic()
            _send(self.link, self.state.handle_key("q", self.state.now))
            self.state.status = f"quit ({self.why})"
            self.screen.draw(self.state)
            self.screen.stop()
        except OSError:
            pass  # the terminal has gone (SIGHUP): nothing to draw on


def _cbreak(fd: int) -> list | None:
    """Keys one at a time, unechoed; the terminal's settings as they were, to restore."""
    import termios
    import tty

    saved = termios.tcgetattr(fd)
    tty.setcbreak(fd, termios.TCSANOW)
    return saved


def _restore(fd: int, saved: list | None) -> None:
    if saved is None:
        return
    import termios

    try:
        termios.tcsetattr(fd, termios.TCSADRAIN, saved)
    except termios.error:
        pass


def run(args: argparse.Namespace) -> int:
    if (problem := _check(args)) is not None:
        print(f"mavhelm remote: {problem}", file=sys.stderr)
        return 2
    target, companion = tuple(args.target), tuple(args.companion)
    state = RemoteState(target=target, companion=companion, url=args.connect,
                        sysid=args.sysid, compid=args.compid, now=time.monotonic())
    link = AutopilotLink(args.connect, args.baud, args.sysid, args.compid, *target)
    if args.key_file is not None:
        try:
            enable_signing(link.mav, read_key(args.key_file))
        except KeyFileError as exc:
            print(f"mavhelm remote: {exc}", file=sys.stderr)
            return 2
    stdin_fd, out_fd = sys.stdin.fileno(), sys.stdout.fileno()
    write = _writer(out_fd)
    session = Session(state, link, Screen(write, os.isatty(out_fd)), stdin_fd)
    saved = None
    old_handlers = {sig: signal.signal(sig, _raise_stop) for sig in (signal.SIGTERM,
                                                                      signal.SIGHUP)}
    old_int = signal.getsignal(signal.SIGINT)
    try:
        if os.isatty(stdin_fd):
            saved = _cbreak(stdin_fd)
        session.screen.start()
        while not state.quit:
            session.step()
    except KeyboardInterrupt:
        session.why = "Ctrl-C"
    except _Stop as exc:
        session.why = str(exc)
    finally:
        # the clean-up is not to be cut short: a second Ctrl-C or SIGTERM waits for it
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            signal.signal(sig, signal.SIG_IGN)
        try:
            session.finish()
        finally:
            _restore(stdin_fd, saved)
            _close_gently(link)
            signal.signal(signal.SIGINT, old_int)
            for sig, handler in old_handlers.items():
                signal.signal(sig, handler)
    try:
        write(f"mavhelm remote: stopped ({session.why})\n")
    except OSError:
        pass
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="mavhelm remote",
        description="the iRemote console: a MAVLink ground station in a terminal")
    add_arguments(parser)
    return run(parser.parse_args(argv))
