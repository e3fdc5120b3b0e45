"""Garbage is collected between ticks, not inside them (mavhelm.core.collector)."""

from __future__ import annotations

import gc
from pathlib import Path

import pytest

from mavhelm.core.collector import IdleCollector, due_generation
from mavhelm.demo.harness import SimulatedRun

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


class Cycle:
    def __init__(self) -> None:
        self.me = self


@pytest.fixture
def collections():
    """The generations of the collections that ran while the fixture was held."""
    seen: list[int] = []

    def callback(phase: str, info: dict) -> None:
        if phase == "start":
            seen.append(info["generation"])

    gc.callbacks.append(callback)
    try:
        yield seen
    finally:
        gc.callbacks.remove(callback)


def test_garbage_waits_for_the_idle_time_and_is_then_collected(collections):
    collector = IdleCollector()
    try:
        collector.idle()  # takes over: the start-up's objects frozen, automatic off
        assert not gc.isenabled()
        collections.clear()
        threshold = gc.get_threshold()[0]
        for _ in range(3 * threshold):
            Cycle()  # unreachable at once, freed only by a collection
        assert collections == [], "the automatic collector ran inside the 'tick'"
        assert due_generation() is not None
        collector.idle()
        assert collections, "the idle time collected nothing"
        assert collector.collections[0] + collector.collections[1] \
            + collector.collections[2] == 1
        assert due_generation() is None
    finally:
        collector.close()
    assert gc.isenabled()


def test_the_automatic_collector_comes_back_after_the_last_holder():
    first, second = IdleCollector(), IdleCollector()
    try:
        first.idle()
        second.idle()
        first.close()
        assert not gc.isenabled(), "one companion closing gave back what another holds"
    finally:
        second.close()
        first.close()
    assert gc.isenabled()


def test_a_loop_that_never_idles_keeps_the_automatic_collector():
    collector = IdleCollector()
    collector.close()
    assert gc.isenabled()


@pytest.mark.slow
def test_the_companion_collects_after_its_ticks_never_in_them(collections):
    """The simulated demo: every collection once the companion has taken over falls between
    two ticks, and some do."""
    with SimulatedRun.start(EXAMPLES / "demo.moos", fast_start=True) as run:
        companion = run.companion
        inside: list[int] = []
        tick = companion.tick

        def watched_tick(now: float) -> None:
            before = len(collections)
            tick(now)
            inside.extend(collections[before:])

        companion.tick = watched_tick  # type: ignore[method-assign]
        run.run_for(1.0)
        collections.clear()
        run.run_for(120.0)
        assert not gc.isenabled()
        assert inside == [], f"collections of generation {inside} ran inside a tick"
        assert collections, "nothing was collected in two minutes of ticks"
        assert sum(companion.collector.collections) == len(collections)
    assert gc.isenabled()


@pytest.mark.slow
def test_the_logs_are_written_after_each_tick_not_in_it(tmp_path):
    """The .alog (and pNav's .olog/.xlog) grow in the idle time after a tick, so a tick's
    lines are on disk before the loop sleeps, and never while the tick runs."""
    alog = tmp_path / "demo.alog"
    with SimulatedRun.start(EXAMPLES / "demo.moos", alog_path=alog) as run:
        companion = run.companion
        grew_inside: list[int] = []
        grew_after: list[int] = []
        tick, idle = companion.tick, companion.idle

        def watched_tick(now: float) -> None:
            before = alog.stat().st_size
            tick(now)
            grew_inside.append(alog.stat().st_size - before)

        def watched_idle() -> None:
            before = alog.stat().st_size
            idle()
            grew_after.append(alog.stat().st_size - before)

        companion.tick = watched_tick  # type: ignore[method-assign]
        companion.idle = watched_idle  # type: ignore[method-assign]
        run.hand_over()
        run.run_for(5.0)
        assert grew_inside and not any(grew_inside), "the log was written inside a tick"
        assert all(n > 0 for n in grew_after[-40:]), "a tick's lines waited past its idle time"
        names = {line.split()[1] for line in alog.read_text().splitlines()
                 if line and not line.startswith("%")}
        assert {"NAV_X", "DESIRED_RUDDER", "HELM_STATE"} <= names
