"""A MOOS mission file as mavhelm reads it: the notes said once at start-up, and ``mavhelm
convert`` (what each line maps to).

Every block is read by its schema (the globals, iMAVLink, pNav, pHelm, pLogger, iSerial_*, each
task type); the MOOS boilerplate and the blocks of other MOOS processes are accepted and said
once on the console with why mavhelm has no use for them (:mod:`mavhelm.core.moos`).
"""

from __future__ import annotations

from collections.abc import Iterator

from mavhelm.companion.alog import LOGGER_SCHEMA
from mavhelm.companion.bridge import IMAVLINK_SCHEMA
from mavhelm.companion.serial_instruments import INSTRUMENT_SCHEMA, is_instrument_block
from mavhelm.core.app import App
from mavhelm.core.bus import Bus, Message
from mavhelm.core.geodesy import GLOBAL_SCHEMA
from mavhelm.core.mission import Block, Entry, Mission, MissionError
from mavhelm.core.moos import foreign, notes, source_of
from mavhelm.core.params import Schema
from mavhelm.nav.acoustics import BLOCK as ACOUSTICS
from mavhelm.nav.navigator import NAV_SCHEMA
from mavhelm.tasks.helm import HELM_SCHEMA
from mavhelm.tasks.registry import NOT_SUPPORTED, task_class

NOTE_VARIABLE = "MOOS_NOTE"
"""Where the notes go: the console shows a ``*_NOTE`` as a notice."""

SCHEMAS: dict[str, Schema] = {"imavlink": IMAVLINK_SCHEMA, "pnav": NAV_SCHEMA,
                              "phelm": HELM_SCHEMA, "plogger": LOGGER_SCHEMA}


def schema_of(block: Block) -> Schema | None:
    """The schema that reads a block (None: another MOOS process's block, or unknown)."""
    if block.kind == "Global":
        return GLOBAL_SCHEMA
    if block.kind == "Task":
        cls = task_class(block.name)
        return None if cls is None else cls.schema()
    if is_instrument_block(block.name):
        return INSTRUMENT_SCHEMA
    return SCHEMAS.get(block.name.lower())


def _blocks(mission: Mission) -> Iterator[Block]:
    yield mission.globals
    yield from mission.processes.values()
    yield from mission.tasks


def mission_notes(mission: Mission) -> list[str]:
    """What the mission gives that mavhelm accepts and does not use, one line per reason."""
    read = [(block, schema) for block in _blocks(mission)
            if (schema := schema_of(block)) is not None]
    return notes(read, mission)


class MoosNotes(App):
    """Posts the mission's notes once, on the first tick (when the console is listening)."""

    name = "mavhelm"

    def __init__(self, bus: Bus, lines: list[str]) -> None:
        super().__init__(bus)
        self._lines = list(lines)

    def subscriptions(self) -> frozenset[str]:
        return frozenset()

    def on_mail(self, mail: list[Message], now: float) -> None:
        pass

    def iterate(self, now: float) -> None:
        for line in self._lines:
            self.notify(NOTE_VARIABLE, line)
        self._lines = []


def _entry_line(entry: Entry, schema: Schema, mission: Mission) -> str:
    param = schema.param(entry.key)
    if param is None:
        return "REFUSED: unknown setting"
    if param.unused:
        return f"accepted, not used: {param.unused}"
    try:
        schema.parse_entry(entry)
    except MissionError as exc:
        return f"REFUSED: {exc.reason}"
    text = "honoured" if param.key == entry.key.lower() else f"honoured as {param.name}"
    if param.unit:
        text += f" ({param.unit})"
    if param.name.upper().startswith("SENSOR_"):
        head = entry.value.partition("->")[0].strip()
        source, how = source_of(head, mission)
        return f"{text}: reads {source}_* ({how or 'a source prefix as it stands'})"
    return text


def _block_line(block: Block, mission: Mission) -> str:
    if block.kind == "Task":
        cls = task_class(block.name)
        if cls is not None:
            return f"task {cls.keyword}"
        refused = NOT_SUPPORTED.get(block.name.strip().lower())
        return f"REFUSED: {refused[1]}" if refused else "REFUSED: unknown task type"
    process = foreign(block.name)
    if process is not None:
        return f"not run by mavhelm: {process.why}"
    if block.name.lower() == ACOUSTICS.lower():
        return ("read by pNav: each Beacon is a BEACON named by its TX channel (LBL_TWTT_<n>)")
    if schema_of(block) is None:
        return "REFUSED: unknown ProcessConfig"
    return f"read as mavhelm's {block.name}"


def convert(mission: Mission) -> list[str]:
    """``file:line: text -> what mavhelm does with it``, for every line of every block."""
    out: list[str] = []
    for block in _blocks(mission):
        schema = schema_of(block)
        if block.kind != "Global":
            out.append(f"{block.file}:{block.line}: {block.kind} = {block.name} -> "
                       f"{_block_line(block, mission)}")
        for entry in block.entries:
            where = f"{entry.file}:{entry.line}: {entry.key} = {entry.value}"
            if block.name.lower() == ACOUSTICS.lower():
                what = "honoured: part of a Beacon"
            elif schema is None:
                what = ("part of a block mavhelm does not run" if foreign(block.name)
                        else "REFUSED with its block")
            elif entry.key.lower() == "taskfile" and block.name.lower() == "phelm":
                what = "TaskFile: its Task blocks are read as the pHelm block's"
            else:
                what = _entry_line(entry, schema, mission)
            out.append(f"{where} -> {what}")
    return sorted(out, key=_position)


def _position(line: str) -> tuple[str, int]:
    file, _, rest = line.partition(":")
    number, _, _ = rest.partition(":")
    return file, int(number) if number.isdigit() else 0
