"""A tick that overruns its period is told to the operator: the rule as pure logic, then
``mavhelm run``'s loop with a real companion, its console and the STATUSTEXT it sends over a
loopback UDP link."""

from __future__ import annotations

import socket
import time

import pytest
from pymavlink import mavutil

from mavhelm.companion.tick_watch import LATE, REPORT, TickWatch

PERIOD = 0.1


def _tick(watch: TickWatch, at: float, took: float) -> str | None:
    return watch.finished(at, at + took)


def test_ticks_within_their_period_say_nothing() -> None:
    watch = TickWatch(PERIOD)
    assert all(_tick(watch, 0.1 * k, took) is None
               for k, took in enumerate([0.0, 0.05, 0.1, LATE * PERIOD, 0.149]))
    assert watch.overruns == 0


def test_the_first_overrun_is_said_at_once_with_what_it_took() -> None:
    watch = TickWatch(PERIOD)
    line = _tick(watch, 5.0, 0.42)
    assert line is not None and "behind" in line and "0.42 s" in line and "0.10 s" in line
    assert watch.overruns == 1 and watch.slowest == pytest.approx(0.42)


def test_a_spell_of_overruns_is_one_line_every_report_period() -> None:
    watch = TickWatch(PERIOD)
    lines = [(t, line) for k in range(400)
             if (line := _tick(watch, t := 0.2 * k, 0.18 if k != 77 else 0.9)) is not None]
    assert len(lines) == 8  # 80 s of overruns, one line each 10 s
    assert all(b - a >= REPORT for (a, _), (b, _) in zip(lines, lines[1:], strict=False))
    assert "still behind" in lines[1][1] and "the slowest 0.18 s" in lines[1][1]
    assert "the slowest 0.90 s" in lines[2][1]  # the 78th tick, 15.4 s in
    assert watch.overruns == 400


def test_a_new_spell_after_a_quiet_while_is_said_as_new() -> None:
    watch = TickWatch(PERIOD)
    assert _tick(watch, 0.0, 0.3) is not None
    assert _tick(watch, 5.0, 0.3) is None
    line = _tick(watch, 60.0, 0.3)
    assert line is not None and "still" not in line


def test_a_non_finite_time_is_no_overrun() -> None:
    watch = TickWatch(PERIOD)
    assert _tick(watch, 0.0, float("nan")) is None and watch.overruns == 0


def test_mavhelm_runs_loop_tells_the_console_and_the_ground_station(tmp_path) -> None:
    from mavhelm.cli import _tick_until_stopped
    from mavhelm.companion.companion import Companion
    from mavhelm.core.clock import WallClock
    from tests.support.mission import mission_text

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    station = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}")
    mission = tmp_path / "m.moos"
    mission.write_text(mission_text(imavlink={"Connect": f"udpout:127.0.0.1:{port}"}))
    console: list[str] = []
    companion = Companion.build(mission, WallClock(), echo=console.append)
    ticks = 0
    tick = companion.tick

    def slow_third_tick(now: float) -> None:
        nonlocal ticks
        ticks += 1
        tick(now)
        if ticks == 3:
            time.sleep(0.35)

    companion.tick = slow_third_tick  # type: ignore[method-assign]
    companion.mission_over = lambda: ticks >= 8  # type: ignore[method-assign]
    try:
        _tick_until_stopped(companion, WallClock(), exit_at_end=True)
        said = [line for line in console if "companion is behind" in line]
        assert len(said) == 1 and "period 0.10 s" in said[0], console
        texts = []
        deadline = time.monotonic() + 5.0
        while time.monotonic() < deadline:
            msg = station.recv_match(type="STATUSTEXT", blocking=True, timeout=0.2)
            if msg is not None:
                texts.append(msg.text)
                if any("companion is behind" in text for text in texts):
                    break
        assert any("companion is behind" in text for text in texts), texts
    finally:
        companion.close()
        station.close()
