"""Fixtures shared by several test modules.

Task rigs (test_tasks_*): ``tblock``, ``msg`` and ``nav_at`` are ``support.task_rig``'s
``task_block`` (a mission ``Task`` block, each entry on its own line, so refusals can be
checked at file:line), ``message`` and ``nav_at`` (a NavState that heard NAV_* values).

Simulator rig (test_sitl_*): ``rig`` is a ``support.sitl_rig.Rig`` with the default settings, closed
after the test. Tests that need other settings build ``Rig(...)`` from sitl_rig themselves.

``make test`` runs the suite in two passes. The modules in ``LIVE`` run something against the
wall clock (a real or built-in SITL, a companion, a browser, a pty, a timed poll) or start
processes side by side; they carry the ``live`` mark and run one after another, alone on the
machine, as they were written for. The others are CPU-bound and run first on two workers
(``pytest -n 2 --dist loadfile``: each module whole, its fixtures made once). Hypothesis runs
without its per-example deadline: speed is measured by the benchmarks, not asserted here.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from typing import TYPE_CHECKING

import pytest
from hypothesis import settings

from mavhelm.core.bus import Message
from mavhelm.core.mission import Block
from mavhelm.tasks.base import NavState
from tests.support import task_rig

if TYPE_CHECKING:
    from tests.support.sitl_rig import Rig

settings.register_profile("mavhelm", deadline=None)
settings.load_profile("mavhelm")

LIVE: frozenset[str] = frozenset({
    "test_ardupilot_actuation", "test_ardupilot_companion", "test_ardupilot_signing",
    "test_ardupilot_sitl", "test_ardupilot_tune", "test_ardusub_figure1", "test_bridge_sensors",
    "test_bridge_serial", "test_bridge_udp", "test_bridge_unread_streams", "test_bus_clock",
    "test_check", "test_cli_realtime", "test_cli_signals", "test_conformance",
    "test_e2e_serial_nav", "test_fleet_view",
    "test_interop_mavproxy", "test_interop_mavsdk", "test_link", "test_nav_serial",
    "test_nav_sim", "test_remote", "test_serial_instruments", "test_sitl_braking",
    "test_sitl_core", "test_sitl_models", "test_sitl_modes", "test_sitl_protocol",
    "test_sitl_runner", "test_sitl_sensors_pty", "test_sitl_truth_feed",
    "test_sitl_vehicle_models", "test_tick_watch", "test_tlog", "test_tune_safety", "test_web",
    "test_web_browser",
    # several processes of their own side by side
    "test_plaza_faults", "test_nav_replay_jobs", "test_nav_sim_faults",
})
"""Test modules that run against the wall clock, or start processes side by side."""


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """The ``live`` mark on every test of the modules in ``LIVE``."""
    for item in items:
        if item.path.stem in LIVE:
            item.add_marker(pytest.mark.live)


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
