"""Helpers for the interoperability tests: real clients (MAVSDK, MAVProxy) against the simulator.

Those clients run on wall-clock time, so the simulator must too: either in this process, stepped
every 10 ms by a daemon thread (``RealtimeSim``, which lets a test read the simulator's truth),
or as the real ``mavhelm sim`` command in a subprocess (``SimProcess``). Both listen on ephemeral
loopback ports only, so they never collide with a ``mavhelm sim`` someone is running.

Every wait here is ``waiting.wait_for`` (a deadline, and a failure that says what it saw);
every process started here is killed on the way out.
"""

from __future__ import annotations

import os
import queue
import re
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from pymavlink import mavutil

from mavhelm.core.clock import WallClock
from mavhelm.sitl.simulator import Simulator
from tests.support.waiting import wait_for

STEP = 0.01  # wall seconds between simulator steps (mavhelm sim's runner uses the same tick)
REPO = Path(__file__).resolve().parents[2]


class RealtimeSim:
    """A ``Simulator`` on the wall clock, stepped by a daemon thread.

    Read the simulator's state inside ``with rs.lock:`` for a consistent snapshot (the thread
    holds the lock for each step). An exception in the stepping thread is re-raised by
    ``check()`` and ``close()``, so a crashing simulator fails the test instead of hanging it.
    """

    def __init__(self, **kwargs: Any) -> None:
        kwargs.setdefault("ports", (0, 0, 0))
        kwargs.setdefault("host", "127.0.0.1")
        kwargs.setdefault("fast_start", True)
        self.clock = WallClock()
        self.sim = Simulator(self.clock, **kwargs)
        self.lock = threading.Lock()
        self._stop = threading.Event()
        self._error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, name="realtime-sim", daemon=True)
        self._thread.start()

    @property
    def ports(self) -> list[int]:
        return self.sim.ports

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                with self.lock:
                    self.sim.step(self.clock.now())
                time.sleep(STEP)
        except BaseException as exc:  # noqa: BLE001 - reported to the test thread
            self._error = exc

    def check(self) -> None:
        if self._error is not None:
            raise AssertionError(f"the simulator thread died: {self._error!r}") from self._error

    def wait(self, pred: Callable[[Simulator], Any], timeout: float, what: str) -> Any:
        """Wait until pred(sim), evaluated under the lock, is truthy."""
        def probe() -> Any:
            self.check()
            with self.lock:
                return pred(self.sim)

        def seen() -> str:
            with self.lock:
                return f"mode={self.sim.mode} armed={self.sim.armed}"

        return wait_for(probe, timeout, what, seen)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(timeout=5)
        with self.lock:
            self.sim.close()
        self.check()

    def __enter__(self) -> RealtimeSim:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _Output:
    """Collects a subprocess's merged stdout/stderr lines on a daemon thread."""

    def __init__(self, proc: subprocess.Popen[str]) -> None:
        self.lines: list[str] = []
        self._queue: queue.Queue[str | None] = queue.Queue()
        self._thread = threading.Thread(target=self._read, args=(proc,), daemon=True)
        self._thread.start()

    def _read(self, proc: subprocess.Popen[str]) -> None:
        assert proc.stdout is not None
        for line in proc.stdout:
            self.lines.append(line.rstrip("\n"))
            self._queue.put(line)
        self._queue.put(None)

    def text(self) -> str:
        return "\n".join(self.lines)

    def tail(self, n: int = 40) -> str:
        return "\n".join(self.lines[-n:])

    def next_line(self, timeout: float) -> str | None:
        try:
            return self._queue.get(timeout=max(timeout, 0.0))
        except queue.Empty:
            return None


def _stop_process(proc: subprocess.Popen[str], grace: float = 5.0) -> None:
    if proc.poll() is None:
        proc.terminate()
        try:
            proc.wait(timeout=grace)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(timeout=grace)


def _child_env(home: Path | None = None) -> dict[str, str]:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(REPO), env.get("PYTHONPATH")]))
    if home is not None:
        env["HOME"] = str(home)  # keep a user's ~/.mavinit.scr and ~/.mavproxy out of the test
    return env


class SimProcess:
    """``mavhelm sim`` in a subprocess on ephemeral ports, parsed from its banner line."""

    BANNER = re.compile(r"tcp:([0-9.]+):(\d+)")

    def __init__(self, *args: str, timeout: float = 15.0) -> None:
        cmd = [sys.executable, "-u", "-m", "mavhelm.cli", "sim", "--port", "0,0,0",
               *args]
        self.proc = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True, env=_child_env(),
                                     cwd=REPO)
        self.output = _Output(self.proc)
        try:
            deadline = time.monotonic() + timeout
            self.ports: list[int] = []
            while not self.ports:
                line = self.output.next_line(deadline - time.monotonic())
                if line is None:
                    raise AssertionError(
                        f"`mavhelm sim` printed no 'listening on tcp:...' line within "
                        f"{timeout:.0f} s (exit code {self.proc.poll()}); output:\n"
                        f"{self.output.text()}")
                self.ports = [int(p) for _, p in self.BANNER.findall(line)]
        except BaseException:
            self.close()
            raise

    SENSOR_LINE = re.compile(r"mavhelm sim: (\w+) on (/dev/\S+) \(")

    def sensor_paths(self, *names: str, timeout: float = 10.0) -> dict[str, str]:
        """The pseudo-terminals ``--sensors`` printed, {sensor: path}, read until every one of
        ``names`` is among them (fails after ``timeout`` with the output so far)."""
        paths: dict[str, str] = {}
        deadline = time.monotonic() + timeout
        while not set(names) <= set(paths):
            line = self.output.next_line(deadline - time.monotonic())
            assert line is not None, self.output.text()
            if m := self.SENSOR_LINE.match(line):
                paths[m.group(1)] = m.group(2)
        return paths

    def close(self) -> None:
        _stop_process(self.proc)

    def __enter__(self) -> SimProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class MavproxyProcess:
    """MAVProxy, headless, as a subprocess driven through its stdin like a typed console.

    Without a terminal MAVProxy's console simply reads lines from stdin (a pipe here), so
    commands are sent with ``send("mode GUIDED")``; EOF on stdin makes it exit. ``--no-state``
    keeps it from writing logs, and HOME points at a scratch directory so no user start-up
    script is run.
    """

    def __init__(self, master: str, workdir: Path, *extra: str) -> None:
        cmd = [sys.executable, "-u", "-m", "MAVProxy.mavproxy", f"--master={master}",
               "--no-state", *extra]
        self.proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True,
                                     env=_child_env(home=workdir), cwd=workdir)
        self.output = _Output(self.proc)

    def send(self, command: str) -> None:
        if self.proc.poll() is not None:
            raise AssertionError(f"MAVProxy exited (code {self.proc.returncode}) before "
                                 f"{command!r}; output:\n{self.output.tail()}")
        assert self.proc.stdin is not None
        self.proc.stdin.write(command + "\n")
        self.proc.stdin.flush()

    def mark(self) -> int:
        """Where the output is now: pass as ``since`` to wait only for lines printed later."""
        return len(self.output.lines)

    def wait_for(self, pattern: str, timeout: float, since: int = 0) -> str:
        """The first output line from index since on matching the regex; fail after timeout."""
        rx = re.compile(pattern)

        def find() -> str | None:
            for line in self.output.lines[since:]:
                if rx.search(line):
                    return line
            if self.proc.poll() is not None:
                raise AssertionError(f"MAVProxy exited (code {self.proc.returncode}) while "
                                     f"waiting for {pattern!r}; output:\n{self.output.tail()}")
            return None

        return wait_for(find, timeout, f"MAVProxy to print {pattern!r}",
                        lambda: "\n" + self.output.tail())

    def close(self) -> None:
        if self.proc.poll() is None and self.proc.stdin is not None:
            try:
                self.proc.stdin.close()  # EOF: MAVProxy's console loop stops
            except OSError:
                pass
            try:
                self.proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                pass
        _stop_process(self.proc)

    def __enter__(self) -> MavproxyProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class Companion:
    """A companion computer's link: a plain pymavlink connection to one of the sim's ports.

    It only listens (no HEARTBEAT of its own), so anything it sees change was changed by
    someone else. ``latest`` keeps the last message of each type from the autopilot.
    """

    def __init__(self, port: int, host: str = "127.0.0.1", sysid: int = 1,
                 compid: int = mavutil.mavlink.MAV_COMP_ID_ONBOARD_COMPUTER) -> None:
        self.conn = mavutil.mavlink_connection(f"tcp:{host}:{port}", source_system=sysid,
                                               source_component=compid, autoreconnect=False)
        self.latest: dict[str, Any] = {}
        self.heartbeats: list[Any] = []

    def wait_for(self, kind: str, pred: Callable[[Any], bool], timeout: float,
                 what: str) -> Any:
        """The first new message of type kind from the autopilot with pred(msg) true."""
        deadline = time.monotonic() + timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                raise AssertionError(f"timed out after {timeout:.0f} s waiting on the companion "
                                     f"link for {what}; last {kind}: {self.latest.get(kind)}")
            msg = self.conn.recv_match(blocking=True, timeout=min(0.2, left))
            if msg is None or msg.get_srcSystem() != 1 or msg.get_srcComponent() != 1:
                continue
            self.latest[msg.get_type()] = msg
            if msg.get_type() == "HEARTBEAT":
                self.heartbeats.append(msg)
            if msg.get_type() == kind and pred(msg):
                return msg

    def close(self) -> None:
        self.conn.close()

    def __enter__(self) -> Companion:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def armed(heartbeat: Any) -> bool:
    return bool(heartbeat.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)


def modes_of(heartbeats: Iterable[Any]) -> list[int]:
    """The distinct custom_mode values in order of appearance."""
    out: list[int] = []
    for hb in heartbeats:
        if not out or out[-1] != hb.custom_mode:
            out.append(hb.custom_mode)
    return out
