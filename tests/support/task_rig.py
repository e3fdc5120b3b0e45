"""Building single tasks the way the mission loader does, for the task tests.

``task_block`` writes a mission ``Task`` block from (key, value) pairs, each entry on its own
line after the block's, so refusals can be checked at file:line; ``message`` is a bus message
and ``nav_at`` a NavState that heard NAV_* values at one time. conftest.py hands them to the
tests as the ``tblock``, ``msg`` and ``nav_at`` fixtures.
"""

from __future__ import annotations

from collections.abc import Callable

from mavhelm.core.bus import Message
from mavhelm.core.mission import Block, Entry, MissionError
from mavhelm.tasks.base import NavState
from mavhelm.tasks.registry import build_task

TBlock = Callable[..., Block]
"""``tblock(kind, *(key, value), file=..., line=...)``: what the ``tblock`` fixture gives."""


def task_block(kind: str, *pairs: tuple[str, str], file: str = "t.moos",
               line: int = 60) -> Block:
    """A Task block of type ``kind`` at file:line, its entries on the lines after it."""
    entries = [Entry(k, v, file, line + 1 + i) for i, (k, v) in enumerate(pairs)]
    return Block("Task", kind, file, line, entries)


def message(name: str, value: float | str, t: float) -> Message:
    """A bus message from source "test"."""
    return Message(name, value, t, "test")


def nav_at(t: float, **values: float) -> NavState:
    """A NavState that heard NAV_X, NAV_HEADING... (``x=..``, ``heading=..``) at time t."""
    nav = NavState()
    for name, v in values.items():
        nav.update(message(f"NAV_{name.upper()}", v, t))
    return nav


def refusal(tblock: TBlock, kind: str, *pairs: tuple[str, str]) -> str:
    """The loader's refusal of a ``kind`` task with these entries; fails if it is accepted."""
    try:
        build_task(tblock(kind, *pairs))
    except MissionError as err:
        return str(err)
    raise AssertionError(f"a {kind} task with {pairs} was accepted")
