"""Fault scenarios for the simulator: what goes wrong, when, and the seed that makes it repeatable.

A scenario is a small line-based text file (``.scn``) so a field engineer can write down "the GPS
dropped out for a minute and the beacon on the pier was multipathing" and replay it bit for bit::

    # harbour test, 2026-11-23
    seed = 42
    gps_outage      from 120 to 180
    gps_jump        at 300 dx=25 dy=-10            # instant: a 1 s window unless "for D"
    range_outlier   from 0 to 600 prob=0.05 sigma=30 beacon=2
    serial_garbage  always port=nmea_gps prob=0.01
    sensor_latency  from 60 sensor=dvl delay=0.4 jitter=0.1   // open-ended window

Lines: ``seed = <int>``, ``name = <text>``, or ``<kind> <window> key=value ...``. Windows:
``from A to B``, ``from A for D``, ``from A`` (until the end), ``at T`` (``[T, T+1)``),
``at T for D``, ``always``. Times are simulation seconds. ``#`` and ``//`` start comments.
The MAVLink-side kinds are applied by the simulator core, the serial-side ones by
:mod:`mavhelm.sitl.serial_sensors`; both draw randomness only from :meth:`Scenario.rng`.
"""

from __future__ import annotations

import math
import os
import re
import zlib
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mavhelm.core.errors import LocatedError

#: Length of the window of an instant fault written ``at T`` with no ``for D``.
INSTANT_S = 1.0

# Parameter types: "prob" in [0, 1], "num" any finite number, "pos" >= 0 (inf allowed for
# nothing), "name" a free identifier kept as a string (port / sensor / beacon names).
_PROB, _NUM, _POS, _NAME = "prob", "num", "pos", "name"


@dataclass(frozen=True)
class FaultKind:
    """Schema of one fault kind: which parameters it needs and who implements it."""

    required: dict[str, str]
    optional: dict[str, str] = field(default_factory=dict)
    side: str = "mavlink"  # "mavlink" (simulator core) or "serial" (serial_sensors)
    doc: str = ""


#: Every fault kind the simulator knows, with its parameters. Unknown kinds are errors.
FAULT_KINDS: dict[str, FaultKind] = {
    # --- MAVLink side (simulator core) ---
    "gps_outage": FaultKind({}, doc="autopilot GPS reports no fix"),
    "gps_jump": FaultKind({"dx": _NUM, "dy": _NUM}, doc="GPS position offset by dx,dy metres"),
    "gps_outlier": FaultKind(
        {"prob": _PROB, "sigma": _POS}, doc="each GPS fix is, with prob, off by N(0, sigma) m"
    ),
    "compass_bias": FaultKind({"deg": _NUM}, doc="compass/attitude heading offset, degrees"),
    "link_drop": FaultKind({}, {"link": _NUM}, doc="link (index, default all) loses all traffic"),
    "link_stall": FaultKind({}, {"link": _NUM}, doc="link holds traffic, delivers it at the end"),
    "link_garbage": FaultKind({"prob": _PROB}, {"link": _NUM}, doc="random bytes injected"),
    "link_duplicate": FaultKind({"prob": _PROB}, {"link": _NUM}, doc="messages sent twice"),
    "link_reorder": FaultKind({"prob": _PROB}, {"link": _NUM}, doc="messages swapped in order"),
    # sensor_latency is shared: the simulator core handles MAVLink sensor names, the serial
    # ports handle their own names; each side ignores names it does not know.
    "sensor_latency": FaultKind(
        {"sensor": _NAME, "delay": _POS},
        {"jitter": _POS},
        side="both",
        doc="sensor output delayed by delay + U(0, jitter) s (order kept)",
    ),
    # --- serial side (serial_sensors) ---
    "serial_garbage": FaultKind(
        {"port": _NAME, "prob": _PROB}, side="serial", doc="random bytes inserted in a line"
    ),
    "serial_truncate": FaultKind(
        {"port": _NAME, "prob": _PROB}, side="serial", doc="line cut short, no checksum/EOL"
    ),
    "range_outlier": FaultKind(
        {"prob": _PROB, "sigma": _POS},
        {"beacon": _NAME},
        side="serial",
        doc="a range is, with prob, off by |N(0, sigma)| m (always long)",
    ),
    "range_multipath": FaultKind(
        {"bias": _NUM},
        {"beacon": _NAME},
        side="serial",
        doc="ranges read bias metres long (reflected path)",
    ),
    "nmea_gps_outage": FaultKind(
        {}, {"port": _NAME}, side="serial", doc="NMEA GPS sends no-fix sentences"
    ),
    "depth_dropout": FaultKind(
        {}, {"port": _NAME, "prob": _PROB}, side="serial", doc="echo sounder loses bottom"
    ),
}


class ScenarioError(LocatedError):
    """A scenario file is wrong."""


@dataclass(frozen=True)
class Fault:
    """One fault: active while ``start <= t < end`` (times in simulation seconds)."""

    kind: str
    start: float
    end: float
    params: dict[str, float | str]

    def contains(self, t: float) -> bool:
        return self.start <= t < self.end

    def num(self, key: str, default: float | None = None) -> float:
        """A numeric parameter, or ``default`` when absent (KeyError if no default)."""
        if key not in self.params:
            if default is None:
                raise KeyError(f"{self.kind}: no parameter {key!r}")
            return default
        return float(self.params[key])

    def matches(self, **selector: object) -> bool:
        """True if, for every selector key the fault names, its value equals the selector's.

        A fault that does not name a key applies to all (``range_outlier`` with no ``beacon``
        hits every beacon).
        """
        for key, want in selector.items():
            if key in self.params and not _same(self.params[key], want):
                return False
        return True


def _same(a: object, b: object) -> bool:
    try:
        return float(a) == float(b)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return str(a) == str(b)


@dataclass
class Scenario:
    """A seed and a list of faults; the single source of randomness for a simulation run."""

    seed: int = 0
    faults: list[Fault] = field(default_factory=list)
    name: str = ""

    @classmethod
    def from_file(cls, path: str | os.PathLike[str]) -> Scenario:
        """Read a ``.scn`` file; errors name the file and line."""
        p = Path(path)
        try:
            text = p.read_text(encoding="utf-8")
        except OSError as exc:
            raise ScenarioError(str(p), 0, f"cannot read: {exc.strerror or exc}") from exc
        scenario = cls.from_text(text, name=str(p))
        if scenario.name == str(p):
            scenario.name = p.stem
        return scenario

    @classmethod
    def from_text(cls, text: str, name: str = "<text>") -> Scenario:
        """Parse scenario text; ``name`` is used in error messages and as the default name."""
        seed: int | None = None
        title: str | None = None
        faults: list[Fault] = []
        for lineno, raw in enumerate(text.splitlines(), start=1):
            line = _strip_comment(raw).strip()
            if not line:
                continue
            m = re.fullmatch(r"(\w+)\s*=\s*(.*)", line)
            if m and m.group(1).lower() in ("seed", "name"):
                key, value = m.group(1).lower(), m.group(2).strip()
                if key == "seed":
                    if seed is not None:
                        raise ScenarioError(name, lineno, "seed given twice")
                    if not re.fullmatch(r"\d+", value):
                        raise ScenarioError(
                            name, lineno, f"seed must be a non-negative integer, not {value!r}"
                        )
                    seed = int(value)
                else:
                    if not value:
                        raise ScenarioError(name, lineno, "empty name")
                    title = value
                continue
            faults.append(_parse_fault(line, name, lineno))
        return cls(seed=seed if seed is not None else 0, faults=faults, name=title or name)

    def active(self, kind: str, t: float) -> list[Fault]:
        """Faults of ``kind`` whose window contains ``t``, in file order."""
        if kind not in FAULT_KINDS:
            raise KeyError(f"unknown fault kind {kind!r}")
        return [f for f in self.faults if f.kind == kind and f.contains(t)]

    def active_matching(self, kind: str, t: float, **selector: object) -> list[Fault]:
        """Like :meth:`active`, keeping faults that apply to ``selector`` (see Fault.matches)."""
        return [f for f in self.active(kind, t) if f.matches(**selector)]

    def of_kind(self, kinds: Iterable[str]) -> list[Fault]:
        """All faults of the given kinds, whatever their window."""
        wanted = set(kinds)
        return [f for f in self.faults if f.kind in wanted]

    def rng(self, stream: str) -> np.random.Generator:
        """A fresh Generator for the named stream: same seed + name → same numbers, always.

        Streams are independent of each other and of how many other streams exist, so adding a
        sensor does not change another sensor's noise. Call once per stream and keep it.
        """
        key = zlib.crc32(stream.encode("utf-8"))
        return np.random.Generator(np.random.PCG64(np.random.SeedSequence([self.seed, key])))


def _strip_comment(line: str) -> str:
    cut = len(line)
    for marker in ("#", "//"):
        i = line.find(marker)
        if i != -1:
            cut = min(cut, i)
    return line[:cut]


def _number(text: str, source: str, lineno: int, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise ScenarioError(source, lineno, f"{what}: {text!r} is not a number") from None
    if math.isnan(value):
        raise ScenarioError(source, lineno, f"{what}: NaN is not allowed")
    return value


def _parse_window(words: list[str], source: str, lineno: int) -> tuple[float, float, list[str]]:
    """Consume the time window at the front of ``words``; return (start, end, rest)."""
    if not words:
        raise ScenarioError(source, lineno, "missing time window (from A to B | at T | always)")
    head = words[0].lower()
    if head == "always":
        return 0.0, math.inf, words[1:]
    if head not in ("from", "at"):
        raise ScenarioError(
            source, lineno, f"expected 'from', 'at' or 'always', found {words[0]!r}"
        )
    if len(words) < 2 or "=" in words[1]:
        raise ScenarioError(source, lineno, f"'{head}' needs a time")
    start = _number(words[1], source, lineno, f"'{head}' time")
    if start < 0 or math.isinf(start):
        raise ScenarioError(source, lineno, f"start time must be finite and >= 0, got {start}")
    rest = words[2:]
    end = math.inf if head == "from" else start + INSTANT_S
    if rest and rest[0].lower() in ("to", "for"):
        word = rest[0].lower()
        if head == "at" and word == "to":
            raise ScenarioError(source, lineno, "'at T' takes 'for D', not 'to'")
        if len(rest) < 2 or "=" in rest[1]:
            raise ScenarioError(source, lineno, f"'{word}' needs a time")
        value = _number(rest[1], source, lineno, f"'{word}' time")
        end = value if word == "to" else start + value
        if end <= start:
            raise ScenarioError(source, lineno, f"window ends ({end:g}) before it starts")
        rest = rest[2:]
    return start, end, rest


def _parse_fault(line: str, source: str, lineno: int) -> Fault:
    words = line.split()
    kind = words[0].lower()
    if kind not in FAULT_KINDS:
        known = ", ".join(sorted(FAULT_KINDS))
        raise ScenarioError(source, lineno, f"unknown fault kind {words[0]!r} (known: {known})")
    schema = FAULT_KINDS[kind]
    start, end, rest = _parse_window(words[1:], source, lineno)
    params: dict[str, float | str] = {}
    allowed = {**schema.required, **schema.optional}
    for word in rest:
        key, eq, value = word.partition("=")
        key = key.lower()
        if not eq or not key or not value:
            raise ScenarioError(source, lineno, f"expected key=value, found {word!r}")
        if key not in allowed:
            names = ", ".join(sorted(allowed)) or "none"
            raise ScenarioError(
                source, lineno, f"{kind} has no parameter {key!r} (parameters: {names})"
            )
        if key in params:
            raise ScenarioError(source, lineno, f"parameter {key!r} given twice")
        ptype = allowed[key]
        if ptype == _NAME:
            params[key] = value
            continue
        number = _number(value, source, lineno, key)
        if ptype == _PROB and not 0.0 <= number <= 1.0:
            raise ScenarioError(source, lineno, f"{key} must be in [0, 1], got {number:g}")
        if ptype == _POS and number < 0:
            raise ScenarioError(source, lineno, f"{key} must be >= 0, got {number:g}")
        if ptype in (_NUM, _PROB) and math.isinf(number):
            raise ScenarioError(source, lineno, f"{key} must be finite")
        params[key] = number
    missing = [k for k in schema.required if k not in params]
    if missing:
        raise ScenarioError(source, lineno, f"{kind} needs {', '.join(missing)}")
    return Fault(kind=kind, start=start, end=end, params=params)
