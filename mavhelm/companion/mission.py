"""Mission files in MOOS syntax: the data model (the parser lives below it).

A mission file holds global ``Key = Value`` lines, ``ProcessConfig = Name { … }`` blocks and
``Task = Type { … }`` blocks (inside the pHelm block, at top level, or in a ``TaskFile``).
Every entry remembers its file and line, so anything that rejects a value can say where it was.
"""

from __future__ import annotations

from dataclasses import dataclass, field


class MissionError(Exception):
    """A mission that cannot be run: says file, line and what was expected, on one line."""

    def __init__(self, file: str, line: int, reason: str) -> None:
        super().__init__(f"{file}:{line}: {reason}")
        self.file = file
        self.line = line
        self.reason = reason


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
    """``ProcessConfig = name { … }`` (kind 'ProcessConfig') or ``Task = Type { … }`` (kind 'Task')."""

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
