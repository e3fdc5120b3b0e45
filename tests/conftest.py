"""Fixtures shared by several test modules.

Task rigs (test_tasks_*): ``tblock``, ``msg`` and ``nav_at`` are ``support.task_rig``'s
``task_block`` (a mission ``Task`` block, each entry on its own line, so refusals can be
checked at file:line), ``message`` and ``nav_at`` (a NavState that heard NAV_* values).

Simulator rig (test_sitl_*): ``rig`` is a ``support.sitl_rig.Rig`` with the default settings, closed
after the test. Tests that need other settings build ``Rig(...)`` from sitl_rig themselves.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING

import pytest

from mavhelm.core.bus import Message
from mavhelm.core.mission import Block
from mavhelm.tasks.base import NavState
from tests.support import task_rig

if TYPE_CHECKING:
    from tests.support.sitl_rig import Rig


@pytest.fixture
def tblock() -> Callable[..., Block]:
    """``tblock(kind, *(key, value), file="t.moos", line=60)``: a Task block at file:line, its
    entries on the lines after it."""
    return task_rig.task_block


@pytest.fixture
def msg() -> Callable[[str, float | str, float], Message]:
    """``msg(name, value, t)``: a bus message from source "test"."""
    return task_rig.message


@pytest.fixture
def nav_at() -> Callable[..., NavState]:
    """``nav_at(t, x=.., heading=..)``: a NavState that heard NAV_X, NAV_HEADING... at time t."""
    return task_rig.nav_at


@pytest.fixture
def rig() -> Iterator[Rig]:
    """A default simulator rig (three TCP ports, fast start), closed after the test."""
    from tests.support.sitl_rig import (
        Rig,  # imported here: only the simulator tests pay for the simulator
    )

    r = Rig()
    yield r
    r.close()


@pytest.fixture
def real_sitl(tmp_path) -> Iterator[Callable[..., object]]:
    """``real_sitl(model="motorboat", speedup=10, params={...}, ...)``: a started
    ``ardupilot.RealSitl`` (the real ArduPilot binary named by MAVHELM_ARDUPILOT) in its own
    folder under tmp_path; every one started is stopped after the test. Skips when
    MAVHELM_ARDUPILOT is unset; fails when it is set but wrong."""
    from tests.support.ardupilot import SKIP_REASON, RealSitl, ardupilot_binary

    binary = ardupilot_binary()
    if binary is None:
        pytest.skip(SKIP_REASON)
    started: list[RealSitl] = []

    def start(**kwargs) -> RealSitl:
        sitl = RealSitl(tmp_path / f"ardupilot{len(started)}", binary=binary, **kwargs)
        started.append(sitl)
        return sitl.start()

    yield start
    for sitl in reversed(started):
        sitl.stop()
