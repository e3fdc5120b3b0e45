"""The companion's MAVLink traffic as a ``.tlog``, the telemetry log MAVProxy, Mission Planner
and QGroundControl write, so MAVExplorer and ``mavlogdump.py`` open it: each frame heard from
the autopilot link and each frame sent on it, after an 8-byte big-endian time stamp
(microseconds since the Unix epoch).

Recording must never stop the helm: a write that fails (a full disk) ends the recording, says
so once through ``on_error``, and the companion carries on.
"""

from __future__ import annotations

import struct
import time
from collections.abc import Callable
from pathlib import Path

STAMP = struct.Struct(">Q")


class TlogWriter:
    """Appends frames to ``path``; ``record(frame)`` is the link's recorder."""

    def __init__(self, path: str | Path, clock: Callable[[], float] = time.time,
                 on_error: Callable[[str], object] | None = None) -> None:
        self.path = Path(path)
        self.clock = clock
        self.on_error = on_error
        self.frames = 0
        self.failed: str | None = None
        self._file = open(self.path, "ab")  # noqa: SIM115 - held open for the run

    def record(self, frame: bytes) -> None:
        if self.failed is not None:
            return
        try:
            self._file.write(STAMP.pack(int(self.clock() * 1e6)) + frame)
            self.frames += 1
        except (OSError, ValueError, struct.error) as exc:
            self._stop(exc)

    def flush(self) -> None:
        """Out to the file (after each tick, in its idle time): a crash loses at most a tick."""
        if self.failed is not None:
            return
        try:
            self._file.flush()
        except (OSError, ValueError) as exc:
            self._stop(exc)

    def _stop(self, exc: Exception) -> None:
        self.failed = str(exc)
        if self.on_error is not None:
            self.on_error(f"the .tlog {self.path} stopped: {exc}")

    def close(self) -> None:
        try:
            self._file.close()
        except OSError as exc:
            self.failed = self.failed or str(exc)
