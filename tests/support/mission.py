"""The standard test mission, written from the parts a test changes.

Every mission the helm accepts has the same skeleton: the origin, an iMAVLink block, a pNav
block, and a pHelm block whose tasks end with an OverallTimeOut that starts an EndMission. A
test names only what it changes: the origin, iMAVLink's options, extra blocks (iSerial ...),
pNav's queues, pHelm's options and the tasks, and OverallTimeOut's limit.

The text starts with a comment line, so its first setting is on line 2, as in the triple-quoted
texts (which start with a newline) that tests used to write; a test asserting ``file:line``
keeps its line.
"""

from __future__ import annotations

import textwrap
from collections.abc import Iterable, Mapping

ORIGIN = (56.4120, -5.4760)
"""The tests' usual origin (and the simulator's usual home): off Oban."""

NAV: dict[str, str] = {"X": "GPS @ 2.0", "Y": "GPS @ 2.0", "Yaw": "INS @ 1.0"}
"""pNav on the autopilot's GPS and attitude alone: what a mission that does not test
navigation needs."""

NAV_AP_FALLBACK: dict[str, str] = {"X": "GPS @ 2.0, AP @ 2.0", "Y": "GPS @ 2.0, AP @ 2.0",
                                   "Yaw": "INS @ 1.0, AP @ 2.0", "Speed": "GPS @ 2.0, AP @ 2.0"}
"""pNav on GPS and attitude with the autopilot's own estimate (AP_*) as the fall-back."""

EKF_GPS_COMPASS = """
  X = EKF @ 2
  Y = EKF @ 2
  Yaw = EKF @ 2
  Speed = EKF @ 2
  SENSOR_XY = GPS -> gps @ 0,0,0 ~ 2.0
  SENSOR_ORIENTATION = INS -> compass @ 0,0,0 ~ 1.0
"""
"""A pNav block's lines: the EKF on the autopilot's GPS (2 m) and compass (1°)."""

Options = Mapping[str, object] | Iterable[tuple[str, object]]
"""A block's settings: a mapping, or (key, value) pairs where a key repeats (``Stream``)."""

HEADER = "// a test mission (tests/support/mission.py)"


def _lines(options: Options, indent: str = "    ") -> list[str]:
    pairs = options.items() if isinstance(options, Mapping) else options
    return [f"{indent}{key} = {value}" for key, value in pairs]


def block(name: str, options: Options | str = ()) -> str:
    """``ProcessConfig = name { ... }`` with these settings (or these raw lines)."""
    body = (textwrap.indent(textwrap.dedent(options).strip("\n"), "    ").split("\n")
            if isinstance(options, str) else _lines(options))
    return "\n".join([f"ProcessConfig = {name}", "{", *[b for b in body if b], "}"])


def _task(kind: str, options: Options) -> list[str]:
    return ["    Task = " + kind, "    {", *_lines(options, " " * 8), "    }"]


def mission_text(tasks: str = "", *, origin: tuple[float, float] = ORIGIN,
                 imavlink: Options | None = None, blocks: str = "",
                 nav: Options | str = NAV, helm: Options = (),
                 overall_timeout: float | str = 3600, clock_name: str | None = None,
                 end_name: str | None = None) -> str:
    """The mission text: ``tasks`` (Task blocks, any indentation) in pHelm after ``helm``'s
    settings, followed by ``OverallTimeOut`` (``overall_timeout`` s, named ``clock_name``)
    whose FinishFlag starts ``EndMission`` (named ``end_name``). ``imavlink=None`` leaves the
    iMAVLink block out (its defaults apply); ``blocks`` is written between it and pNav."""
    lat, lon = origin
    parts = [HEADER, f"LatOrigin = {lat}", f"LongOrigin = {lon}"]
    if imavlink is not None:
        parts.append(block("iMAVLink", imavlink))
    if blocks.strip():
        parts.append(textwrap.dedent(blocks).strip("\n"))
    parts.append(block("pNav", nav))
    clock = [("Name", clock_name)] if clock_name else []
    end = [("Name", end_name)] if end_name else []
    helm_lines = [
        "ProcessConfig = pHelm", "{", *_lines(helm),
        *([textwrap.indent(textwrap.dedent(tasks).strip("\n"), "    ")] if tasks.strip() else []),
        *_task("OverallTimeOut", [*clock, ("TimeOut", overall_timeout),
                                  ("FinishFlag", "EndMission")]),
        *_task("EndMission", [*end, ("StartFlag", "EndMission")]),
        "}"]
    parts.append("\n".join(helm_lines))
    return "\n".join(parts) + "\n"
