"""SIGINT and SIGTERM stop the long-running commands cleanly, even when the parent started them
with SIGINT ignored (what a shell without job control does to ``cmd &``)."""

from __future__ import annotations

import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

DEMO = Path(__file__).resolve().parents[1] / "examples" / "demo.moos"


def _ignoring_sigint() -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _start(*args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-u", "-m", "mavhelm.cli", *args],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            preexec_fn=_ignoring_sigint)


def _wait_for_line(proc: subprocess.Popen, prefix: str, timeout_s: float = 60.0) -> None:
    deadline = time.monotonic() + timeout_s
    assert proc.stdout is not None
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if line.startswith(prefix):
            return
        assert line or proc.poll() is None, f"exited before {prefix!r}"
    raise AssertionError(f"no {prefix!r} line in {timeout_s} s")


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_sim_stops_on_a_signal_though_started_with_sigint_ignored(sig):
    proc = _start("sim", "--fast-start", "--port", "0,0,0")
    try:
        _wait_for_line(proc, "mavhelm sim")
        proc.send_signal(sig)
        out, _ = proc.communicate(timeout=60)
        assert "Traceback" not in out, out
        assert (proc.returncode == 0 and "mavhelm sim: stopped" in out) or \
            (proc.returncode == 130 and "stopped while starting" in out), out
    finally:
        proc.kill()


def test_run_stops_on_sigint_though_started_with_sigint_ignored(tmp_path):
    proc = _start("run", str(DEMO), "--connect", "tcp:127.0.0.1:9", "--log-dir", str(tmp_path))
    try:
        _wait_for_line(proc, "mavhelm: ")
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
        assert proc.returncode == 0 and "mavhelm: stopped" in out, out
        assert list(tmp_path.glob("demo_*.alog")), "the log was not written and closed"
    finally:
        proc.kill()
