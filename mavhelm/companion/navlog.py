"""pNav's .olog and .xlog files (spec 2.2.5): plain text, one line per observation or tick.

The navigator produces the lines (pure); this writes them where the mission says: the folder
``NAV_LOG_PATH`` or the alog's, named ``<NAV_LOG_STEM>[_<creation time>].olog/.xlog``. The
time stamp is MOOS's ``_DD_MM_YYYY_____HH_MM_SS`` style so logs of successive runs sort and
never overwrite each other. Lines are flushed after every tick (in its idle time), as the alog
is: after a crash the logs hold everything up to it.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import TextIO


def nav_log_stem(folder: Path, stem: str, timestamp: bool, opened_on: float) -> Path:
    """The path of the logs without suffix."""
    if timestamp:
        stem += time.strftime("_%d_%m_%Y_____%H_%M_%S", time.localtime(opened_on))
    return folder / stem


class NavLogFiles:
    """A :class:`~mavhelm.nav.navigator.NavLogSink` writing ``.olog`` and ``.xlog`` files."""

    def __init__(self, folder: str | Path, stem: str = "pNav", *, timestamp: bool = True,
                 opened_on: float | None = None) -> None:
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        base = nav_log_stem(folder, stem, timestamp,
                            time.time() if opened_on is None else opened_on)
        self.olog_path = base.with_suffix(".olog")
        self.xlog_path = base.with_suffix(".xlog")
        self._olog: TextIO = self.olog_path.open("w", encoding="utf-8")
        self._xlog: TextIO = self.xlog_path.open("w", encoding="utf-8")
        self._olog.write("# t sensor type values fate [chi2 distance | age]\n")

    def olog(self, lines: list[str]) -> None:
        self._olog.write("\n".join(lines) + "\n")

    def xlog(self, lines: list[str]) -> None:
        self._xlog.write("\n".join(lines) + "\n")

    def flush(self) -> None:
        self._olog.flush()
        self._xlog.flush()

    def close(self) -> None:
        self._olog.close()
        self._xlog.close()
