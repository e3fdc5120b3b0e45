"""Putting tuned gains into a mission file: the same text, with only the tuned values changed.

Each value goes on the line that already sets it (its indentation and comment kept), or, if
the block does not set it, on a new line just inside the block's ``{``. Task blocks read from a
``TaskFile`` are in another file and are left alone (the runner says so).
"""

from __future__ import annotations

import re
from collections.abc import Callable

from mavhelm.core.mission import Block, Mission, parse_mission

TUNED_TASKS = ("trackline", "survey")


def _opening_line(lines: list[str], block: Block) -> int:
    """0-based index of the line holding the block's ``{``."""
    for i in range(block.line - 1, min(len(lines), block.line + 1)):
        if "{" in lines[i].split("//")[0]:
            return i
    raise ValueError(f"{block.file}:{block.line}: no '{{' for {block.kind} {block.name}")


def _set(lines: list[str], inserts: dict[int, list[str]], block: Block, key: str,
         value: str) -> None:
    entry = block.entry(key)
    if entry is not None:
        i = entry.line - 1
        lines[i] = re.sub(r"(=\s*)([^/]*?)(\s*(//.*)?)$", lambda m: m.group(1) + value
                          + m.group(3), lines[i], count=1)
        return
    opening = _opening_line(lines, block)
    indent = " " * (len(lines[opening]) - len(lines[opening].lstrip()) + 4)
    inserts.setdefault(opening, []).append(f"{indent}{key} = {value}")


def _tasks(mission: Mission) -> list[Block]:
    helm = mission.process("pHelm")
    blocks = [*(helm.tasks if helm is not None else []), *mission.tasks]
    seen: set[int] = set()
    out = []
    for b in blocks:
        if id(b) in seen or b.file != mission.path or b.name.lower() not in TUNED_TASKS:
            continue
        seen.add(id(b))
        out.append(b)
    return out


def rewrite(text: str, file: str, *, yaw_kp: float, yaw_kd: float, max_turn_rate: float,
            lead_for: Callable[[float | None], float], line_kp: float, line_kd: float) -> str:
    """The mission text with the tuned values; the result is parsed again to be sure."""
    mission = parse_mission(text, file)
    lines = text.splitlines()
    inserts: dict[int, list[str]] = {}
    helm = mission.process("pHelm")
    link = mission.process("iMAVLink")
    if helm is None:
        raise ValueError(f"{file}: no pHelm block to put the heading gains in")
    _set(lines, inserts, helm, "YAW_PID_KP", f"{yaw_kp:g}")
    _set(lines, inserts, helm, "YAW_PID_KD", f"{yaw_kd:g}")
    _set(lines, inserts, helm, "LINE_PID_KP", f"{line_kp:g}")
    _set(lines, inserts, helm, "LINE_PID_KD", f"{line_kd:g}")
    tail: list[str] = []
    if link is None:
        tail = ["ProcessConfig = iMAVLink", "{", f"    MaxTurnRate = {max_turn_rate:g}", "}"]
    else:
        _set(lines, inserts, link, "MaxTurnRate", f"{max_turn_rate:g}")
    for task in _tasks(mission):
        thrust = task.entry("Thrust")
        lead = lead_for(None if thrust is None else thrust.as_float())
        _set(lines, inserts, task, "Lead", f"{lead:g}")
    out: list[str] = []
    for i, line in enumerate(lines):
        out.append(line)
        out += inserts.get(i, [])
    result = "\n".join([*out, *tail]) + "\n"
    parse_mission(result, file)
    return result
