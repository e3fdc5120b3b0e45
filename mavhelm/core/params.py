"""One declarative parameter schema for every block of a mission file.

Each task and app declares each of its settings once, as a :class:`Param` — name, kind (which
parses the text and knows the allowed range), unit, default or required, and a line of doc.
:class:`Schema` reads a block against those declarations: an unknown key is refused with the
list of known ones, a missing required key is refused, every value that is not finite or not in
range is refused, all as ``file:line: reason``. The parameter reference in ``docs/`` is
generated from the same declarations, so the docs cannot drift from what is accepted.

Why by hand: the mission syntax is MOOS's (case-insensitive keys, ``NEVER`` time-outs,
comma lists, repeated keys) and every refusal must carry its file and line; general schema
libraries (pydantic, voluptuous) know neither and would need as much glue as this module.
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

from mavhelm.core.mission import Block, Entry, MissionError


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED: Any = _Required()
"""The default of a parameter the block must give."""

NEVER = "NEVER"


def _number_text(x: float) -> str:
    return f"{x:.12g}"


class Kind:
    """How a value is written and what range it must lie in. Subclasses parse one entry."""

    label: ClassVar[str] = "value"

    def parse(self, entry: Entry) -> Any:
        raise NotImplementedError

    def describe(self) -> str:
        """The accepted values, as the parameter reference shows them."""
        return self.label

    def check_value(self, value: Any) -> bool:
        """Whether an already parsed value (a default) is acceptable: used by tests and docs."""
        return True


@dataclass(frozen=True)
class Number(Kind):
    """A finite number within [lo, hi] (open ends where asked); ``integer`` for whole numbers."""

    lo: float = -math.inf
    hi: float = math.inf
    lo_open: bool = False
    hi_open: bool = False
    integer: bool = False

    def _range_text(self) -> str:
        if self.lo == -math.inf and self.hi == math.inf:
            return "any finite number"
        if self.hi == math.inf:
            return f"{'>' if self.lo_open else '>='} {_number_text(self.lo)}"
        if self.lo == -math.inf:
            return f"{'<' if self.hi_open else '<='} {_number_text(self.hi)}"
        left = "(" if self.lo_open else "["
        right = ")" if self.hi_open else "]"
        return f"in {left}{_number_text(self.lo)}, {_number_text(self.hi)}{right}"

    def describe(self) -> str:
        what = "whole number" if self.integer else "number"
        return f"{what} {self._range_text()}" if self._range_text() != "any finite number" \
            else f"any finite {what}"

    def in_range(self, x: float) -> bool:
        if not math.isfinite(x):
            return False
        if self.integer and not float(x).is_integer():
            return False
        if x < self.lo or (self.lo_open and x == self.lo):
            return False
        return not (x > self.hi or (self.hi_open and x == self.hi))

    def check_value(self, value: Any) -> bool:
        return isinstance(value, int | float) and self.in_range(float(value))

    def parse_text(self, text: str, entry: Entry, what: str) -> float:
        try:
            x = float(text)
        except ValueError:
            raise entry.error(f"{what} expects a {self.describe()}, got {text.strip()!r}") \
                from None
        if not math.isfinite(x):
            raise entry.error(f"{what} must be a finite number, got {text.strip()!r}")
        if not self.in_range(x):
            raise entry.error(f"{what} must be a {self.describe()}, got {text.strip()}")
        return x

    def parse(self, entry: Entry) -> float | int:
        x = self.parse_text(entry.value, entry, entry.key)
        return int(x) if self.integer else x


@dataclass(frozen=True)
class Seconds(Kind):
    """A time-out: a finite number of seconds in (0, hi], or ``NEVER`` (None) where allowed."""

    hi: float = 7 * 24 * 3600.0
    never: bool = True
    never_reason: str = ""
    """Why NEVER is refused here, said to the user (default: "give seconds")."""

    def describe(self) -> str:
        span = f"seconds in (0, {_number_text(self.hi)}]"
        return f"{span} or NEVER" if self.never else span

    def check_value(self, value: Any) -> bool:
        if value is None:
            return self.never
        return Number(0.0, self.hi, lo_open=True).check_value(value)

    def parse(self, entry: Entry) -> float | None:
        if entry.value.strip().upper() == NEVER:
            if not self.never:
                raise entry.error(self.never_reason or f"{entry.key} cannot be NEVER here: "
                                  "give seconds")
            return None
        return Number(0.0, self.hi, lo_open=True).parse_text(entry.value, entry, entry.key)


@dataclass(frozen=True)
class Fixed(Kind):
    """A setting a task type pins: only ``text`` is accepted (parsed to ``value``), anything
    else is refused with ``reason``. EndMission's Priority 0 and TimeOut NEVER are these."""

    text: str
    value: Any
    reason: str

    def describe(self) -> str:
        return f"only {self.text}"

    def check_value(self, value: Any) -> bool:
        return value == self.value

    def parse(self, entry: Entry) -> Any:
        if entry.value.strip().upper() != self.text.upper():
            raise entry.error(f"{self.reason}, got {entry.value.strip()}")
        return self.value


@dataclass(frozen=True)
class Choice(Kind):
    """One word of a fixed set, case-insensitive; parsed to its canonical spelling.

    ``not_yet`` lists words that name a planned feature: refused with "not supported yet"
    rather than "unknown", so a user knows it is coming and that it does nothing today.
    """

    options: tuple[str, ...]
    not_yet: tuple[str, ...] = ()

    def describe(self) -> str:
        return "one of " + ", ".join(self.options)

    def check_value(self, value: Any) -> bool:
        return value is None or value in self.options

    def parse_word(self, word: str, entry: Entry) -> str:
        lowered = word.strip().lower()
        for option in self.options:
            if option.lower() == lowered:
                return option
        for option in self.not_yet:
            if option.lower() == lowered:
                raise entry.error(f"{entry.key} = {option} is not supported yet; "
                                  f"expected {self.describe()}")
        raise entry.error(f"{entry.key} expects {self.describe()}, got {word.strip()!r}")

    def parse(self, entry: Entry) -> str:
        return self.parse_word(entry.value, entry)


@dataclass(frozen=True)
class ChoiceList(Kind):
    """A comma-separated, non-empty list of words of a fixed set."""

    choice: Choice

    def describe(self) -> str:
        return f"comma-separated, each {self.choice.describe()}"

    def check_value(self, value: Any) -> bool:
        return bool(value) and all(v in self.choice.options for v in value)

    def parse(self, entry: Entry) -> tuple[str, ...]:
        words = [w for w in entry.value.split(",")]
        if not entry.value.strip() or any(not w.strip() for w in words):
            raise entry.error(f"{entry.key} expects a comma-separated list, "
                              f"each {self.choice.describe()}, got {entry.value!r}")
        return tuple(self.choice.parse_word(w, entry) for w in words)


@dataclass(frozen=True)
class Boolean(Kind):
    """true or false; ``number_reason``: what to say when a number is given instead (a key
    whose original MOOS meaning was a number, as pNav's ``EKF_TIDE``)."""

    number_reason: str = ""
    label: ClassVar[str] = "true or false"

    def check_value(self, value: Any) -> bool:
        return isinstance(value, bool)

    def parse(self, entry: Entry) -> bool:
        v = entry.value.strip().lower()
        if v in ("true", "yes", "1", "on"):
            return True
        if v in ("false", "no", "0", "off"):
            return False
        if self.number_reason and _is_number(v):
            raise entry.error(f"{entry.key} expects true or false, got {entry.value.strip()}: "
                              f"{self.number_reason}")
        raise entry.error(f"{entry.key} expects true or false, got {entry.value!r}")


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


_WORD = re.compile(r"[A-Za-z0-9_.\-]+")


@dataclass(frozen=True)
class Names(Kind):
    """A comma-separated list of variable names (flags): no empty item, no spaces inside."""

    label: ClassVar[str] = "comma-separated variable names"

    def check_value(self, value: Any) -> bool:
        return isinstance(value, list)

    def parse(self, entry: Entry) -> list[str]:
        names = [n.strip() for n in entry.value.split(",")]
        if not names or any(not _WORD.fullmatch(n) for n in names):
            raise entry.error(
                f"{entry.key} expects comma-separated variable names, got {entry.value!r}"
            )
        return names


@dataclass(frozen=True)
class Word(Kind):
    """One word without spaces, commas, colons or '=' (a task's Name)."""

    label: ClassVar[str] = "one word"

    def check_value(self, value: Any) -> bool:
        return value is None or (isinstance(value, str) and bool(_WORD.fullmatch(value)))

    def parse(self, entry: Entry) -> str:
        word = entry.value.strip()
        if not _WORD.fullmatch(word):
            raise entry.error(f"{entry.key} must be one word of letters, digits, '_', '-' "
                              f"or '.', got {word!r}")
        return word


@dataclass(frozen=True)
class Text(Kind):
    """Free text on one line, non-empty and at most ``max_length`` characters."""

    max_length: int = 256
    label: ClassVar[str] = "text"

    def check_value(self, value: Any) -> bool:
        return isinstance(value, str) and 0 < len(value) <= self.max_length

    def parse(self, entry: Entry) -> str:
        text = entry.value.strip()
        if not text:
            raise entry.error(f"{entry.key} needs a value")
        if len(text) > self.max_length:
            raise entry.error(f"{entry.key} is longer than {self.max_length} characters")
        return text


NAME_MAX = 255
"""Bytes in one file or folder name (Linux and most file systems)."""
PATH_MAX = 4096
"""Bytes in a whole path (Linux)."""


@dataclass(frozen=True)
class PathName(Kind):
    """A file-system path: no NUL or control character, each name at most NAME_MAX bytes and
    the whole at most PATH_MAX. ``folder``: a folder the process writes into, so the path and
    every part of it that already exists must be a folder: an existing file or a device
    (``/dev/null``) there would fail only when the log opens, with a misleading error."""

    folder: bool = False
    label: ClassVar[str] = "a path"

    def describe(self) -> str:
        what = "a folder path (not an existing file or device)" if self.folder else "a path"
        return f"{what}, no control characters, names of at most {NAME_MAX} bytes"

    def check_value(self, value: Any) -> bool:
        return isinstance(value, str) and self._problem(value) is None

    def _problem(self, text: str) -> str | None:
        if not text:
            return "needs a value"
        if any(ord(c) < 32 or ord(c) == 127 for c in text):
            return "must not contain control characters (a NUL, a tab, an escape)"
        if len(text.encode()) > PATH_MAX:
            return f"is longer than {PATH_MAX} bytes"
        if any(len(part.encode()) > NAME_MAX for part in text.split("/")):
            return f"has a name longer than {NAME_MAX} bytes"
        if self.folder:
            return _not_a_folder(text)
        return None

    def parse(self, entry: Entry) -> str:
        text = entry.value.strip()
        problem = self._problem(text)
        if problem is not None:
            raise entry.error(f"{entry.key} {problem}, got {text[:80]!r}")
        return text


def _not_a_folder(text: str) -> str | None:
    """Why ``text`` cannot be a folder to write into: the deepest part of it that exists is
    a file or a device, not a folder (None when it can be)."""
    path = Path(text).expanduser()
    for part in (path, *path.parents):
        try:
            if not part.exists():
                continue
        except OSError:
            return f"cannot be checked ({part})"
        if part.is_dir():
            return None
        what = "an existing file" if part.is_file() else "a device or special file"
        return f"names {what} ({part}), not a folder"
    return None


@dataclass(frozen=True)
class FileStem(Kind):
    """The start of a file name: one word of letters, digits, '_', '-' or '.', short enough
    (``max_length``) that the time stamp and suffix added to it stay within NAME_MAX."""

    max_length: int = 200
    label: ClassVar[str] = "a file name stem"

    def describe(self) -> str:
        return (f"a file name stem: letters, digits, '_', '-' or '.', at most {self.max_length} "
                "characters")

    def check_value(self, value: Any) -> bool:
        return isinstance(value, str) and bool(_WORD.fullmatch(value)) and \
            len(value) <= self.max_length and value not in (".", "..")

    def parse(self, entry: Entry) -> str:
        text = entry.value.strip()
        if not self.check_value(text):
            raise entry.error(f"{entry.key} must be {self.describe()}, got {text[:80]!r}")
        return text


@dataclass(frozen=True)
class Point(Kind):
    """``x,y`` or ``x,y,z`` in metres of the local frame, each coordinate within ±limit."""

    limit: float = 100_000.0
    label: ClassVar[str] = "x,y[,z]"

    def describe(self) -> str:
        return f"x,y or x,y,z in metres, each within ±{_number_text(self.limit)}"

    def check_value(self, value: Any) -> bool:
        return isinstance(value, tuple) and all(
            v is None or (math.isfinite(v) and abs(v) <= self.limit) for v in value)

    def parse(self, entry: Entry) -> tuple[float, float, float | None]:
        parts = entry.value.split(",")
        try:
            [float(p) for p in parts]
        except ValueError:
            parts = []
        if len(parts) not in (2, 3):
            raise entry.error(f"{entry.key} expects x,y or x,y,z in metres, got {entry.value!r}")
        values = [float(p) for p in parts]
        if not all(math.isfinite(v) and abs(v) <= self.limit for v in values):
            raise entry.error(f"{entry.key} must be x,y[,z] in finite metres within "
                              f"±{_number_text(self.limit)}, got {entry.value.strip()!r}")
        return values[0], values[1], values[2] if len(values) == 3 else None


@dataclass(frozen=True)
class Refused(Kind):
    """A key the original MOOS pHelm or pNav reads but mavhelm cannot honour: any value is
    refused with ``reason``, so a mission never relies on a setting that does nothing."""

    reason: str

    def describe(self) -> str:
        return f"refused: {self.reason}"

    def check_value(self, value: Any) -> bool:
        return value is None

    def parse(self, entry: Entry) -> Any:
        raise entry.error(f"{entry.key} is not supported by mavhelm: {self.reason}")


@dataclass(frozen=True)
class AlwaysTrue(Boolean):
    """A MOOS switch for what mavhelm always does: true is accepted, false refused with
    ``reason`` (pNav's ``UseEKF``: the EKF runs whenever SENSOR_* lines are declared)."""

    reason: str = ""

    def describe(self) -> str:
        return f"true (false is refused: {self.reason})"

    def parse(self, entry: Entry) -> bool:
        if not super().parse(entry):
            raise entry.error(f"{entry.key} = false is not supported by mavhelm: {self.reason}")
        return True


@dataclass(frozen=True)
class Mapped(Kind):
    """One word of a fixed set, each standing for a value (MOOS's ``EKF_VEHICLE_TYPE =
    MOBILE`` for ``EKF_MOBILE = true``)."""

    values: tuple[tuple[str, Any], ...]

    def describe(self) -> str:
        return "one of " + ", ".join(word for word, _ in self.values)

    def check_value(self, value: Any) -> bool:
        return any(value == v for _, v in self.values)

    def parse(self, entry: Entry) -> Any:
        word = entry.value.strip().upper()
        for option, value in self.values:
            if option.upper() == word:
                return value
        raise entry.error(f"{entry.key} expects {self.describe()}, got {entry.value.strip()!r}")


@dataclass(frozen=True)
class Alias:
    """Another spelling of a setting, as the original MOOS source reads it; ``kind`` when the
    original writes the value differently (else the setting's own kind parses it)."""

    name: str
    kind: Kind | None = None

    @property
    def key(self) -> str:
        return self.name.lower()


@dataclass(frozen=True)
class Param:
    """One setting of a block, declared once.

    ``repeat``: the key may be written on several lines; the value is the list of the parsed
    lines (for a :class:`Names` kind, the lists are joined). ``attr`` is where a task or config
    keeps it (by default the name in snake case). ``aliases``: other spellings of the same
    setting (the original MOOS keywords); two spellings in one block must agree. ``unused``:
    why mavhelm accepts (and checks) this MOOS setting but has no use for it, said once on the
    console when a mission gives it (``ServerHost``: mavhelm has no MOOSDB).
    """

    name: str
    kind: Kind
    default: Any = REQUIRED
    unit: str = ""
    doc: str = ""
    repeat: bool = False
    attr: str = ""
    aliases: tuple[Alias, ...] = ()
    unused: str = ""

    @property
    def key(self) -> str:
        return self.name.lower()

    def __post_init__(self) -> None:
        if not self.doc and isinstance(self.kind, Refused):
            object.__setattr__(self, "doc", "a keyword of the original MOOS source, refused")
        elif not self.doc and self.unused:
            object.__setattr__(self, "doc", "MOOS boilerplate")

    def meaning(self) -> str:
        """The reference's meaning column: the doc, the aliases, and why it is not used."""
        text = self.doc
        if self.aliases:
            text += f" (also written {', '.join(f'`{a.name}`' for a in self.aliases)})"
        if self.unused:
            text += f"; accepted, not used: {self.unused}"
        return text

    @property
    def required(self) -> bool:
        return self.default is REQUIRED

    @property
    def attribute(self) -> str:
        if self.attr:
            return self.attr
        snake = re.sub(r"(?<=[a-z0-9])(?=[A-Z])", "_", self.name)
        return snake.lower()

    def accepts(self, value: Any) -> bool:
        """Whether a value held after reading is one this parameter allows: its default
        (None for an optional setting left out) or a value of its kind in range."""
        if self.repeat:
            return isinstance(value, list) and all(
                self.kind.check_value([v] if isinstance(self.kind, Names) else v)
                for v in value)
        return (not self.required and value == self.default) or self.kind.check_value(value)

    def describe_default(self) -> str:
        if self.required:
            return "required"
        if self.default is None:
            return "—"
        if isinstance(self.default, bool):
            return "true" if self.default else "false"
        if isinstance(self.default, float):
            return _number_text(self.default)
        if isinstance(self.default, tuple | list):
            return ",".join(str(v) for v in self.default) or "—"
        return str(self.default)


def _check_again(p: Param, first: Entry, entry: Entry, same: bool) -> None:
    """A setting given a second time: refused, unless written once in each of two spellings
    that agree (a MOOS file's ``EKF_SIGMA_XX`` and ``EKF_SIGMA_YY`` for one ``EKF_SIGMA_XY``)."""
    if first.key.lower() == entry.key.lower():
        raise entry.error(f"{entry.key} is already set at line {first.line}; "
                          "give each setting once")
    if not same:
        raise entry.error(f"{entry.key} disagrees with {first.key} at line {first.line}: "
                          f"both set {p.name}, which mavhelm holds once; give them one value")


@dataclass(frozen=True)
class Schema:
    """The settings of one kind of block (a task type, a ProcessConfig, the globals).

    ``unsupported`` lists key prefixes of planned features: refused with "not supported yet".
    A later parameter with the name of an earlier one replaces it (a task type narrowing a
    base property, as EndMission does for Priority).
    """

    owner: str
    params: tuple[Param, ...]
    unsupported: tuple[str, ...] = ()
    moos: tuple[Param, ...] = ()
    """MOOS boilerplate the block accepts too (``AppTick``, ``CommsTick``): read like the rest,
    documented once for every block rather than in this block's table; a parameter of
    ``params`` with the same name replaces it."""
    _by_key: dict[str, Param] = field(init=False, repr=False, compare=False)
    _spelt: dict[str, tuple[Param, Kind]] = field(init=False, repr=False, compare=False)
    _shown: frozenset[str] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        by_key: dict[str, Param] = {}
        for p in self.params:
            by_key[p.key] = p
        own = frozenset(by_key)
        for p in self.moos:
            by_key.setdefault(p.key, p)
        spelt: dict[str, tuple[Param, Kind]] = {}
        for p in by_key.values():
            for alias in p.aliases:
                spelt[alias.key] = (p, alias.kind or p.kind)
        for p in by_key.values():
            spelt[p.key] = (p, p.kind)
        object.__setattr__(self, "_by_key", by_key)
        object.__setattr__(self, "_spelt", spelt)
        object.__setattr__(self, "_shown", own)
        object.__setattr__(self, "params", tuple(p for p in by_key.values() if p.key in own))
        object.__setattr__(self, "moos", tuple(p for p in by_key.values() if p.key not in own))

    def extend(self, owner: str, params: Iterable[Param],
               unsupported: Sequence[str] = ()) -> Schema:
        return Schema(owner, (*self.params, *params), (*self.unsupported, *unsupported),
                      self.moos)

    def every(self) -> tuple[Param, ...]:
        """Every setting the block accepts: its own, then the MOOS boilerplate."""
        return (*self.params, *self.moos)

    def param(self, name: str) -> Param | None:
        """The setting a key names, by its name or one of its aliases."""
        found = self._spelt.get(name.lower())
        return None if found is None else found[0]

    def parse_entry(self, entry: Entry) -> tuple[Param, Any]:
        """The setting one entry gives and its value, or a located refusal."""
        spelt = self._spelt.get(entry.key.lower())
        if spelt is None:
            raise self.refuse_unknown(entry)
        param, kind = spelt
        return param, kind.parse(entry)

    def unused_entries(self, block: Block) -> list[tuple[Entry, Param]]:
        """The entries of ``block`` that give a setting mavhelm accepts but does not use."""
        found = [(e, self.param(e.key)) for e in block.entries]
        return [(e, p) for e, p in found if p is not None and p.unused]

    def known(self) -> str:
        """The settings a user may give (not the ones refused with a reason)."""
        return ", ".join(p.name for p in self.params if not isinstance(p.kind, Refused))

    def refuse_unknown(self, entry: Entry) -> MissionError:
        key = entry.key.upper()
        for prefix in self.unsupported:
            if key.startswith(prefix.upper()):
                return entry.error(f"{entry.key} is not supported yet ({self.owner} has no "
                                   f"{prefix.rstrip('_')} setting today); remove it")
        if not self.params:
            return entry.error(f"unknown setting {entry.key!r}: {self.owner} takes no settings")
        names = {p.key: p.name for p in self.params if not isinstance(p.kind, Refused)}
        close = difflib.get_close_matches(entry.key.lower(), names, n=1, cutoff=0.75)
        hint = f"did you mean {names[close[0]]}? " if close else ""
        return entry.error(f"unknown setting {entry.key!r} for {self.owner} "
                           f"({hint}known: {self.known()})")

    def read(self, block: Block, *, skip: Iterable[str] = (),
             owner: str | None = None) -> dict[str, Any]:
        """Parse every entry of ``block``; return attribute → value for every parameter of
        its own (the MOOS boilerplate is checked, not returned).

        ``skip`` names keys another reader owns (the parser's TaskFile). Raises a located
        MissionError on the first entry it refuses, or on the block if a required key is
        missing (``owner`` names the block in that message).
        """
        skipped = {k.lower() for k in skip}
        seen: dict[str, Entry] = {}
        values: dict[str, Any] = {}
        for entry in block.entries:
            key = entry.key.lower()
            if key in skipped:
                continue
            p, value = self.parse_entry(entry)
            if p.key not in self._shown:  # MOOS boilerplate: checked, said, not kept
                first = seen.get(p.key)
                if first is not None and not p.repeat:
                    _check_again(p, first, entry, False)
                seen[p.key] = entry
                continue
            if p.repeat:
                bucket = values.setdefault(p.attribute, [])
                if isinstance(p.kind, Names):
                    bucket.extend(value)
                else:
                    bucket.append(value)
            else:
                first = seen.get(p.key)
                if first is not None:
                    _check_again(p, first, entry, values[p.attribute] == value)
                values[p.attribute] = value
            seen[p.key] = entry
        for p in self.params:
            if p.attribute in values:
                continue
            if p.required:
                what = f" ({p.kind.describe()}{', ' + p.unit if p.unit else ''})"
                raise block.error(f"{owner or self.owner} needs {p.name}{what}")
            values[p.attribute] = list(p.default) if p.repeat else p.default
        return values

    def apply(self, target: object, block: Block, **kwargs: Any) -> None:
        """``read`` the block and set each value as an attribute of ``target``."""
        for name, value in self.read(block, **kwargs).items():
            setattr(target, name, value)

    def reference(self, title: str, intro: str = "") -> str:
        """A Markdown section documenting every parameter."""
        lines = [f"### {title}", ""]
        if intro:
            lines += [intro, ""]
        if not self.params:
            lines += ["No settings.", ""]
        else:
            lines += ["| parameter | unit | default | accepted | meaning |",
                      "| --- | --- | --- | --- | --- |"]
            for p in self.params:
                accepted = p.kind.describe() + ("; may repeat" if p.repeat else "")
                cells = (f"`{p.name}`", p.unit or "—", p.describe_default(), accepted,
                         p.meaning())
                lines.append("| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |")
            lines.append("")
        if self.moos:
            names = ", ".join(f"`{p.name}`" for p in self.moos)
            lines += [f"Also accepts the MOOS boilerplate {names} (see MOOS missions).", ""]
        if self.unsupported:
            names = ", ".join(f"`{u}*`" for u in self.unsupported)
            lines += [f"Refused as not supported yet: {names}.", ""]
        return "\n".join(lines)
