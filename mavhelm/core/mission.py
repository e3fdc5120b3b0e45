"""Mission files in MOOS syntax: the data model (the parser lives below it).

A mission file holds global ``Key = Value`` lines, ``ProcessConfig = Name { … }`` blocks and
``Task = Type { … }`` blocks (inside the pHelm block, at top level, or in a ``TaskFile``).
Every entry remembers its file and line, so anything that rejects a value can say where it was.
"""

from __future__ import annotations

import os
import stat
from dataclasses import dataclass, field
from pathlib import Path

from mavhelm.core.errors import LocatedError


class MissionError(LocatedError):
    """A mission that cannot be run."""


@dataclass(frozen=True)
class Entry:
    key: str
    value: str
    file: str
    line: int

    def error(self, reason: str) -> MissionError:
        return MissionError(self.file, self.line, reason)

    def as_float(self) -> float:
        try:
            return float(self.value)
        except ValueError:
            raise self.error(f"{self.key} expects a number, got {self.value!r}") from None


@dataclass
class Block:
    """``ProcessConfig = name { … }`` (kind 'ProcessConfig') or ``Task = Type { … }`` ('Task')."""

    kind: str
    name: str
    file: str
    line: int
    entries: list[Entry] = field(default_factory=list)
    tasks: list[Block] = field(default_factory=list)

    def error(self, reason: str) -> MissionError:
        return MissionError(self.file, self.line, reason)

    def entry(self, key: str) -> Entry | None:
        """Last entry with this key (keys are case-insensitive)."""
        key = key.lower()
        for e in reversed(self.entries):
            if e.key.lower() == key:
                return e
        return None

    def all(self, key: str) -> list[Entry]:
        key = key.lower()
        return [e for e in self.entries if e.key.lower() == key]

    def get(self, key: str, default: str | None = None) -> str | None:
        e = self.entry(key)
        return default if e is None else e.value

    def get_float(self, key: str, default: float) -> float:
        e = self.entry(key)
        return default if e is None else e.as_float()

    def require(self, key: str) -> Entry:
        e = self.entry(key)
        if e is None:
            raise self.error(f"{self.kind} {self.name} needs {key}")
        return e


@dataclass
class Mission:
    path: str
    globals: Block
    processes: dict[str, Block] = field(default_factory=dict)
    tasks: list[Block] = field(default_factory=list)

    def process(self, name: str) -> Block | None:
        """A ProcessConfig block by name, case-insensitive."""
        for key, block in self.processes.items():
            if key.lower() == name.lower():
                return block
        return None


_HEADERS = ("processconfig", "task")


def _strip_comment(line: str) -> str:
    cut = line.find("//")
    return (line if cut < 0 else line[:cut]).strip()


def _split_key_value(text: str, file: str, number: int) -> tuple[str, str]:
    key, sep, value = text.partition("=")
    key = key.strip()
    if not sep:
        raise MissionError(file, number, f"expected Key = Value, got {text!r}")
    if not key:
        raise MissionError(file, number, f"empty key before '=' in {text!r}")
    if len(key.split()) > 1:
        raise MissionError(file, number, f"expected a one-word key before '=', got {key!r}")
    return key, value.strip()


class _Parser:
    """One pass over one file; a line-driven state machine so every error knows its line."""

    def __init__(self, text: str, file: str, *, hoof: bool = False) -> None:
        self.text = text
        self.file = file
        self.hoof = hoof
        self.globals = Block("Global", "Global", file, 1)
        self.processes: dict[str, Block] = {}
        self.tasks: list[Block] = []
        self.process: Block | None = None
        self.task: Block | None = None
        self.pending: Block | None = None
        self.previous: Entry | None = None

    def error(self, line: int, reason: str) -> MissionError:
        return MissionError(self.file, line, reason)

    def run(self) -> None:
        for number, raw in enumerate(self.text.splitlines(), start=1):
            text = _strip_comment(raw)
            if text:
                self.line(text, number)
        if self.pending is not None:
            raise self.pending.error(self._needs_brace(self.pending))
        open_block = self.task or self.process
        if open_block is not None:
            raise open_block.error(
                f"block opened here is never closed: {open_block.kind} = {open_block.name}"
                " needs a closing '}'"
            )

    @staticmethod
    def _unknown_block(key: str, value: str) -> str:
        return f"unknown block {key} = {value}: expected ProcessConfig = Name or Task = Type"

    @staticmethod
    def _needs_brace(block: Block) -> str:
        return f"expected '{{' on the same or the next line after {block.kind} = {block.name}"

    def line(self, text: str, number: int) -> None:
        if self.pending is not None:
            if text != "{":
                raise self.pending.error(self._needs_brace(self.pending))
            self.open(self.pending)
            self.pending = None
            return
        previous, self.previous = self.previous, None
        if self.bracket(text, number, previous):
            return
        opens = text.endswith("{")
        if opens:
            text = text[:-1].rstrip()
        if "=" not in text and self.task is None and self.process is None:
            wanted = (
                "Task = Type" if self.hoof else "Key = Value, ProcessConfig = Name or Task = Type"
            )
            raise self.error(number, f"expected {wanted}, got {text!r}")
        key, value = _split_key_value(text, self.file, number)
        kind = key.lower()
        if kind in _HEADERS and "{" in value:
            raise self.error(
                number,
                f"expected a line break after '{{': put the {key} block's entries on"
                " their own lines",
            )
        if kind in _HEADERS:
            block = self.header(kind, value, number)
            if opens:
                self.open(block)
            else:
                self.pending = block
            return
        if opens:
            raise self.error(number, self._unknown_block(key, value))
        self.previous = Entry(key, value, self.file, number)
        self.entry(self.previous)

    def bracket(self, text: str, number: int, previous: Entry | None) -> bool:
        """A line of ``{``, ``}``, ``[`` or ``]``: handled (True), refused, or not one (False)."""
        if text == "{":
            if previous is not None:
                raise self.error(number, self._unknown_block(previous.key, previous.value))
            raise self.error(
                number, "'{' without a block header (ProcessConfig = Name or Task = Type)"
            )
        if text == "}":
            self.close(number)
            return True
        if text.startswith("}"):
            raise self.error(number, f"expected '}}' alone on its line, got {text!r}")
        if text in ("[", "]"):
            if self.task is None and self.process is not None and \
                    self.process.name.lower() == "acoustics":
                return True  # the original's Beacon = name [ … ] groups: entries are enough
            raise self.error(number, f"a '{text}' line belongs only in the Acoustics block "
                             "(Beacon = name [ POS = x,y,z  TX = CHn  TAT = s ])")
        return False

    def header(self, kind: str, value: str, number: int) -> Block:
        if kind == "processconfig":
            if self.hoof:
                raise self.error(number, "a .hoof file holds only Task blocks, not ProcessConfig")
            if self.task is not None or self.process is not None:
                outer = self.task or self.process
                assert outer is not None
                raise self.error(
                    number,
                    f"nested ProcessConfig inside {outer.kind} = {outer.name}"
                    f" (opened at line {outer.line}): close that block first",
                )
            label = "ProcessConfig needs a process name"
        else:
            if self.task is not None:
                raise self.error(
                    number,
                    f"nested Task inside Task = {self.task.name} (opened at line"
                    f" {self.task.line}): close that block first",
                )
            if self.process is not None and self.process.name.lower() != "phelm":
                raise self.error(
                    number,
                    f"Task blocks belong in ProcessConfig = pHelm, not in {self.process.name}",
                )
            label = "Task needs a task type"
        if not value:
            raise self.error(number, f"{label} after '='")
        if len(value.split()) > 1:
            raise self.error(number, f"{label} (one word), got {value!r}")
        block_kind = "ProcessConfig" if kind == "processconfig" else "Task"
        return Block(block_kind, value, self.file, number)

    def open(self, block: Block) -> None:
        if block.kind == "Task":
            self.task = block
            return
        for name, other in self.processes.items():
            if name.lower() == block.name.lower():
                raise block.error(
                    f"ProcessConfig = {block.name} is already configured at line {other.line}"
                )
        self.processes[block.name] = block
        self.process = block

    def close(self, number: int) -> None:
        if self.task is not None:
            task, self.task = self.task, None
            self.tasks.append(task)
            if self.process is not None:
                self.process.tasks.append(task)
        elif self.process is not None:
            self.process = None
        else:
            raise self.error(number, "stray '}' with no open block")

    def entry(self, entry: Entry) -> None:
        if self.task is not None:
            self.task.entries.append(entry)
        elif self.process is not None:
            self.process.entries.append(entry)
            if entry.key.lower() == "taskfile" and self.process.name.lower() == "phelm":
                hoof = self.load_task_file(entry)
                self.tasks.extend(hoof)
                self.process.tasks.extend(hoof)
        elif self.hoof:
            raise entry.error(f"a .hoof file holds only Task blocks, got {entry.key} = ...")
        else:
            self.globals.entries.append(entry)

    def load_task_file(self, entry: Entry) -> list[Block]:
        if not entry.value:
            raise entry.error("TaskFile needs a file name")
        path = Path(entry.value).expanduser()
        if not path.is_absolute():
            path = Path(self.file).parent / path
        try:
            if path.resolve() == Path(self.file).resolve():
                raise entry.error("TaskFile names this mission file itself; "
                                  "name a .hoof file of Task blocks")
        except OSError:
            pass
        try:
            text = read_text_file(path)
        except _Unreadable as exc:
            raise entry.error(f"cannot read TaskFile {str(path)!r}: {exc}") from None
        return parse_tasks(text, str(path))


def parse_mission(text: str, file: str) -> Mission:
    """Parse mission text; ``file`` names it in errors and anchors relative TaskFile paths."""
    parser = _Parser(text, file)
    parser.run()
    return Mission(file, parser.globals, parser.processes, parser.tasks)


def parse_tasks(text: str, file: str) -> list[Block]:
    """Parse the text of a .hoof file: Task blocks and comments only."""
    parser = _Parser(text, file, hoof=True)
    parser.run()
    return parser.tasks


MAX_FILE_BYTES = 1 << 20
"""A mission or TaskFile larger than 1 MiB is refused: no hand-written mission comes close,
and reading a mistaken path (a log, a disk image) must not exhaust the companion's memory."""


class _Unreadable(Exception):
    """Why a mission or TaskFile path cannot be read, in a user's words."""


def read_text_file(path: str | Path, limit: int = MAX_FILE_BYTES) -> str:
    """The text of a regular file of at most ``limit`` bytes.

    Opened without blocking and checked before reading, so a FIFO cannot hang the helm, a
    device (``/dev/zero``, a serial port) cannot fill memory and a directory gets a plain
    answer. Bytes that are not UTF-8 become U+FFFD, which the parser then refuses in place.
    """
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOCTTY", 0))
    except OSError as exc:
        raise _Unreadable(exc.strerror or str(exc)) from None
    try:
        mode = os.fstat(fd).st_mode
        if stat.S_ISDIR(mode):
            raise _Unreadable("it is a directory, not a file")
        if stat.S_ISFIFO(mode):
            raise _Unreadable("it is a pipe (FIFO), not a regular file")
        if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
            raise _Unreadable("it is a device, not a regular file")
        if not stat.S_ISREG(mode):
            raise _Unreadable("it is not a regular file")
        chunks: list[bytes] = []
        size = 0
        while size <= limit:
            chunk = os.read(fd, limit + 1 - size)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        if size > limit:
            raise _Unreadable(f"it is larger than {limit // 1024} KiB")
    except OSError as exc:
        raise _Unreadable(exc.strerror or str(exc)) from None
    finally:
        os.close(fd)
    return b"".join(chunks).decode("utf-8", errors="replace")


def _read(path: str | Path) -> tuple[str, str]:
    file = str(path)
    try:
        return read_text_file(path), file
    except _Unreadable as exc:
        raise MissionError(file, 0, f"cannot read mission file: {exc}") from None


def load_mission(path: str | Path) -> Mission:
    """Read and parse a .moos mission file (TaskFile paths are relative to its directory)."""
    return parse_mission(*_read(path))


def load_tasks(path: str | Path) -> list[Block]:
    """Read and parse a .hoof file of Task blocks."""
    return parse_tasks(*_read(path))
