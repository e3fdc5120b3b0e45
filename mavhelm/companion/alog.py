"""pLogger: every bus message to a MOOS ``.alog`` file, and back.

The format is the one MOOS pLogger writes, so MOOS-IvP tools (alogview, aloggrep, alogsplit)
read our logs and ours read theirs: a ``%%`` banner holding ``%% LOGSTART <unix time>``, then one
line per message, ``time-since-LOGSTART variable source value``, left-aligned in columns of 15,
20 and 10 characters, time with 3 decimals.
"""

from __future__ import annotations

import re
import time as _time
from pathlib import Path
from typing import TextIO

from mavhelm.core.app import App
from mavhelm.core.bus import Bus, Message
from mavhelm.core.geodesy import GLOBAL_SCHEMA
from mavhelm.core.mission import Block, Mission
from mavhelm.core.moos import APP_PARAMS, GLOBAL_LOG_PATH
from mavhelm.core.params import (
    Alias,
    Boolean,
    Fixed,
    Number,
    Param,
    PathName,
    Refused,
    Schema,
    Text,
)

EVERY_VARIABLE = "the .alog holds every variable, each time it is posted"
NO_SLOG = "mavhelm writes no synchronous .slog"

LOG_DIR = Param("LogDir", PathName(folder=True), "runs", doc="folder for the .alog, relative "
                "to where mavhelm run is started (default: the global GlobalLogPath, else "
                "runs); `mavhelm run --log-dir` overrides it", attr="log_dir",
                aliases=(Alias("PATH"),))

LOGGER_SCHEMA = Schema("pLogger", (
    LOG_DIR,
    Param("AsyncLog", Fixed("TRUE", True, "mavhelm always writes the asynchronous .alog"),
          True, attr="async_log", doc="MOOS pLogger's asynchronous log: the .alog"),
    Param("WildcardLogging", Boolean(), None, attr="wildcard_logging", unused=EVERY_VARIABLE),
    Param("Log", Text(), [], repeat=True, attr="log", unused=EVERY_VARIABLE),
    Param("WildcardExclusionLog", Boolean(), None, attr="wildcard_exclusion_log",
          unused=EVERY_VARIABLE),
    Param("FileTimeStamp", Boolean(), None, attr="file_time_stamp",
          unused="the .alog's name always holds its start time"),
    Param("UTCLogDirectories", Boolean(), None, attr="utc_log_directories",
          unused="the .alog's name always holds its start time"),
    Param("DoublePrecision", Number(1, 17, integer=True), None, attr="double_precision",
          unused="numbers are written with 12 significant digits, as MOOS's default"),
    Param("SyncLog", Fixed("FALSE", False, f"{NO_SLOG}; remove SyncLog or set it false"),
          False, attr="sync_log", doc="MOOS pLogger's synchronous log (.slog)"),
    Param("DynamicSyncLogColumns", Number(0, 1000, integer=True), None,
          attr="dynamic_sync_log_columns", unused=NO_SLOG),
    Param("CompressAlogs", Fixed("FALSE", False, "mavhelm writes the .alog uncompressed"),
          False, attr="compress_alogs", doc="MOOS pLogger's gzipped .alog"),
    Param("File", Refused("the .alog is named after the mission file and its start time"),
          None, attr="file"),
    Param("LoggingDirectorySummaryFile", Refused("mavhelm writes no summary file"), None,
          attr="logging_directory_summary_file"),
), moos=APP_PARAMS)
"""mavhelm's pLogger block, with the keys MOOS's pLogger reads: honoured, noted as unused
(they only narrow what MOOS logs; mavhelm logs everything), or refused with why."""


def log_dir(mission: Mission) -> str:
    """The pLogger block's LogDir (checked like every block), else the mission's global
    GlobalLogPath (MOOS's GLOBALLOGPATH), else the default."""
    block = mission.process("pLogger") or Block("ProcessConfig", "pLogger", mission.path, 0)
    folder: str = LOGGER_SCHEMA.read(block)["log_dir"]
    if any(LOGGER_SCHEMA.param(e.key) is LOG_DIR for e in block.entries):
        return folder
    for entry in mission.globals.entries:
        if GLOBAL_SCHEMA.param(entry.key) is GLOBAL_LOG_PATH:
            folder = GLOBAL_SCHEMA.parse_entry(entry)[1]
    return folder

_BANNER = "%" * 60
_NUMBER = re.compile(r"[+-]?(?:(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|nan|inf)", re.IGNORECASE)


def format_value(value: float | str) -> str:
    """Doubles with 12 significant digits (as MOOS's ``%.12g``); strings on one line."""
    if isinstance(value, str):
        return value.replace("\r", " ").replace("\n", " ")
    return f"{value:.12g}"


def format_line(msg: Message, start: float) -> str:
    """One .alog line, without the newline."""
    return (
        f"{msg.time - start:<15.3f} {msg.name:<20} {msg.source or '?':<10} "
        f"{format_value(msg.value)}"
    ).rstrip()


PENDING_MAX = 5000
"""Messages held for the idle time at most: a loop that never idles (a tool ticking a
companion by hand) still gets its log, in blocks."""


class AlogLogger(App):
    """Subscribes to everything; writes and flushes it in the idle time after each tick
    (formatting forty lines and a write(2) are a tenth of a busy tick), so a crash or a
    power cut on the boat loses at most one tick of log."""

    name = "pLogger"

    def __init__(self, bus: Bus, path: str | Path, start_time: float | None = None,
                 opened_on: float | None = None) -> None:
        """Open ``path`` (parents created) and write the banner; ``start_time`` defaults to
        the bus clock's now and is kept to the millisecond the format records. ``opened_on``
        is the wall-clock date for the banner when the bus clock is simulated (it defaults to
        ``start_time``, which on the vehicle is wall-clock time)."""
        super().__init__(bus)
        self.path = Path(path)
        start = bus.clock.now() if start_time is None else float(start_time)
        self.start = round(start, 3)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file: TextIO | None = self.path.open("w", encoding="utf-8")
        opened = _time.strftime("%a %b %d %H:%M:%S %Y",
                                _time.gmtime(self.start if opened_on is None else opened_on))
        self._file.write(
            f"{_BANNER}\n"
            f"%% LOG FILE:       {self.path}\n"
            f"%% FILE OPENED ON  {opened} UTC\n"
            f"%% LOGSTART        {self.start:20.3f}\n"
            f"{_BANNER}\n"
        )
        self._file.flush()
        self._pending: list[Message] = []

    def subscriptions(self) -> set[str]:
        return {"*"}

    def on_mail(self, mail: list[Message], now: float) -> None:
        if self._file is None:
            return
        self._pending += mail
        if len(self._pending) > PENDING_MAX:
            self.idle()

    def idle(self) -> None:
        """Write what is pending, then forget it: a stop (SIGTERM, Ctrl-C) that lands while
        the lines are formatted leaves them pending for ``close`` to write (the last tick
        before a clean stop was lost when they were taken first: a hand-back's record, in CI)."""
        if self._file is None or not self._pending:
            return
        start = self.start
        text = "".join([format_line(msg, start) + "\n" for msg in self._pending])
        self._file.write(text)
        self._pending = []
        self._file.flush()

    def close(self) -> None:
        if self._file is not None:
            self.idle()
            self._file.close()
            self._file = None


def read_alog(path: str | Path) -> list[Message]:
    """Messages of an .alog file with absolute times (LOGSTART + relative).

    A value that reads as a number comes back as a float, anything else as a string (the
    format does not record the type; MOOS tools guess the same way). Lines that are not
    ``time variable source [value]`` are skipped, as MOOS tools do.
    """
    start = 0.0
    messages: list[Message] = []
    with Path(path).open(encoding="utf-8", errors="replace") as f:
        for line in f:
            if line.startswith("%"):
                fields = line.split()
                if len(fields) >= 3 and fields[1] == "LOGSTART":
                    try:
                        start = float(fields[2])
                    except ValueError:
                        pass
                continue
            fields = line.split(None, 3)
            if len(fields) < 3:
                continue
            try:
                t = float(fields[0])
            except ValueError:
                continue
            text = fields[3].strip() if len(fields) == 4 else ""
            value: float | str = float(text) if _NUMBER.fullmatch(text) else text
            messages.append(Message(fields[1], value, start + t, fields[2]))
    return messages
