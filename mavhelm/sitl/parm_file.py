"""ArduPilot ``.parm`` default-parameter files, as the SITL's ``--defaults`` reads them.

One parameter a line: ``NAME value`` or ``NAME,value`` (ArduPilot's reader splits on spaces,
tabs, commas and ``=``), optionally followed by the ``@READONLY`` flag; ``#`` starts a comment;
blank lines are skipped. ``--defaults a.parm,b.parm`` loads the files in order, a later value
overriding an earlier one.

ArduPilot skips a line it cannot read without a word (``motorboat.parm``'s ``SIM_TIDE_0.5``
sets nothing) and reads a value that is not a number as 0. Here a bad line is refused as
``file:line: reason`` (``ParmFileError``) so a typo cannot pass silently; ``strict=False`` does
what the firmware does instead (skip the line) and lists what it skipped, for loading the stock
files exactly as the real SITL does.
"""

from __future__ import annotations

import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

NAME_MAX = 16  # AP_MAX_NAME_SIZE: longer names are refused by the firmware too
_NAME = re.compile(r"[A-Z][A-Z0-9_]*\Z")
_SEPARATORS = re.compile(r"[ \t,=]+")
READONLY_FLAG = "@READONLY"
MAX_FILE_BYTES = 1_000_000


class ParmFileError(ValueError):
    """A line (or file) ArduPilot's parameter-file format does not allow: ``path:line: reason``.
    ``line`` is None when the fault is the file itself (missing, unreadable)."""

    def __init__(self, path: str, line: int | None, reason: str) -> None:
        self.path = path
        self.line = line
        self.reason = reason
        where = f"{path}:{line}" if line is not None else path
        super().__init__(f"{where}: {reason}")


@dataclass
class ParmValues:
    """What a set of files assigns: values by name (the last file's wins), the names flagged
    ``@READONLY``, where each value came from, and the lines skipped when not strict."""

    values: dict[str, float] = field(default_factory=dict)
    readonly: set[str] = field(default_factory=set)
    origin: dict[str, str] = field(default_factory=dict)
    skipped: list[ParmFileError] = field(default_factory=list)

    def update(self, other: ParmValues) -> None:
        self.values.update(other.values)
        self.readonly |= other.readonly
        self.origin.update(other.origin)
        self.skipped.extend(other.skipped)


def _parse_number(text: str) -> float | None:
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) else None


def parse_parm(text: str, path: str = "<string>", *, strict: bool = True) -> ParmValues:
    """The assignments of one file's text; ``path`` only names it in messages."""
    out = ParmValues()
    first_line: dict[str, int] = {}
    for number, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        try:
            name, value, readonly = _parse_line(line, path, number)
            if name in first_line:
                raise ParmFileError(path, number, f"{name} is set twice in this file (first at "
                                                  f"line {first_line[name]})")
        except ParmFileError as err:
            if strict:
                raise
            out.skipped.append(err)
            continue
        first_line[name] = number
        out.values[name] = value
        out.origin[name] = f"{path}:{number}"
        if readonly:
            out.readonly.add(name)
    return out


def _parse_line(line: str, path: str, number: int) -> tuple[str, float, bool]:
    tokens = [t for t in _SEPARATORS.split(line) if t]
    name = tokens[0]
    if len(tokens) == 1:
        raise ParmFileError(path, number, f"{name!r} has no value (expected 'NAME value')")
    if len(name) > NAME_MAX:
        raise ParmFileError(path, number, f"parameter name {name!r} is longer than "
                                          f"{NAME_MAX} characters")
    if not _NAME.match(name):
        raise ParmFileError(path, number, f"{name!r} is not a parameter name (capital letters, "
                                          "digits and '_', starting with a letter)")
    value = _parse_number(tokens[1])
    if value is None:
        raise ParmFileError(path, number, f"{name}: value {tokens[1]!r} is not a finite number")
    rest = tokens[2:]
    readonly = rest == [READONLY_FLAG]
    if rest and not readonly:
        raise ParmFileError(path, number, f"{name}: unexpected {' '.join(rest)!r} after the "
                                          f"value (only {READONLY_FLAG} may follow)")
    return name, value, readonly


def read_parm_file(path: str | Path, *, strict: bool = True) -> ParmValues:
    """One ``.parm`` file. Missing, unreadable, oversized or non-text files are refused
    whatever ``strict`` says: the firmware would not start with them either."""
    p = Path(path)
    name = str(path)
    try:
        if not p.is_file():
            raise ParmFileError(name, None, "no such file" if not p.exists() else
                                "not a regular file")
        if p.stat().st_size > MAX_FILE_BYTES:
            raise ParmFileError(name, None, f"larger than {MAX_FILE_BYTES} bytes; not a "
                                            "parameter file")
        data = p.read_bytes()
    except OSError as exc:
        raise ParmFileError(name, None, f"cannot read: {exc.strerror or exc}") from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ParmFileError(name, data[:exc.start].count(b"\n") + 1,
                            "not text (invalid UTF-8)") from None
    if "\x00" in text:
        raise ParmFileError(name, text[:text.index("\x00")].count("\n") + 1,
                            "not text (NUL byte)")
    return parse_parm(text, name, strict=strict)


def split_defaults(spec: str) -> list[str]:
    """``--defaults a.parm,b.parm`` → the file names, in order."""
    names = [part.strip() for part in spec.split(",")]
    if not spec.strip() or any(not n for n in names):
        raise ParmFileError(spec or "--defaults", None,
                            "empty file name in the --defaults list")
    return names


def read_defaults(files: str | Sequence[str | Path] | Iterable[str | Path], *,
                  strict: bool = True) -> ParmValues:
    """Every file of a ``--defaults`` list (a comma-separated string or a sequence of paths),
    later files overriding earlier ones."""
    paths = split_defaults(files) if isinstance(files, str) else list(files)
    out = ParmValues()
    for path in paths:
        out.update(read_parm_file(path, strict=strict))
    return out
