"""A command run in its own process while a test or benchmark watches its console.

Its merged stdout/stderr lines are collected on a thread with the wall time each was read (and
copied to a log file if asked), so a wait can look for a line without blocking on the pipe.
On Linux the child is asked to get SIGTERM if this process dies first, so a crashed test run
leaves no SITL or companion behind.
"""

from __future__ import annotations

import contextlib
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Sequence
from pathlib import Path


def set_parent_death_signal() -> None:  # pragma: no cover - runs in the child
    """Ask Linux to SIGTERM this child if the process that started it dies."""
    with contextlib.suppress(Exception):
        import ctypes

        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGTERM)   # PR_SET_PDEATHSIG


PREEXEC = set_parent_death_signal if sys.platform == "linux" else None
"""``preexec_fn`` for every child the rigs start."""


class ConsoleProcess:
    """``cmd`` running with its console lines collected in ``lines`` as (wall time, line)."""

    def __init__(self, cmd: Sequence[str], *, cwd: Path | None = None,
                 log_path: Path | None = None) -> None:
        self.cmd = list(cmd)
        self.log_path = log_path
        self.lines: list[tuple[float, str]] = []
        self.started_wall = time.monotonic()
        self.proc = subprocess.Popen(
            self.cmd, cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, text=True, bufsize=1, preexec_fn=PREEXEC)
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        assert self.proc.stdout is not None
        with (self.log_path.open("w") if self.log_path is not None
              else contextlib.nullcontext()) as log:
            for line in self.proc.stdout:
                self.lines.append((time.monotonic(), line.rstrip("\n")))
                if log is not None:
                    log.write(line)
                    log.flush()

    def running(self) -> bool:
        return self.proc.poll() is None

    def find(self, fragment: str, nth: int = 1) -> tuple[float, str] | None:
        """The ``nth`` console line containing ``fragment``: (wall time read, line)."""
        hits = [(t, line) for t, line in list(self.lines) if fragment in line]
        return hits[nth - 1] if len(hits) >= nth else None

    def find_all(self, fragment: str) -> list[str]:
        return [line for _, line in list(self.lines) if fragment in line]

    def output(self, last: int = 40) -> str:
        return "\n".join(line for _, line in list(self.lines)[-last:])

    def stop(self, sig: int = signal.SIGTERM, grace_s: float = 10.0) -> int:
        """``sig`` (its own pid; SIGTERM as systemd would), SIGKILL after ``grace_s``. Returns
        the exit code."""
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            try:
                self.proc.wait(grace_s)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self._reader.join(5.0)
        return self.proc.returncode
