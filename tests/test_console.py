"""The operator's console: one timestamped line per event, repeats held back and counted."""

from __future__ import annotations

from mavhelm.companion.console import StatusConsole
from mavhelm.core.bus import Bus
from mavhelm.core.clock import SimClock


def rig():
    clock = SimClock(0.0)
    bus = Bus(clock)
    lines: list[str] = []
    console = StatusConsole(bus, lines.append, quiet_s=5.0)
    bus.subscribe(console.name, console.subscriptions())

    def tick(t: float, **posts) -> list[str]:
        clock.advance(t - clock.now())
        for name, value in posts.items():
            bus.notify(name, value, "test")
        before = len(lines)
        console.take(bus.fetch(console.name), clock.now())
        return lines[before:]

    return tick


def test_events_become_lines_and_other_traffic_does_not():
    tick = rig()
    assert tick(1.0, NAV_X=3.0, DESIRED_THRUST=50.0) == []
    assert tick(2.0, AP_LINK=1.0) == ["t+     2.0s  autopilot link up"]
    assert tick(3.0, AP_MODE="GUIDED") == ["t+     3.0s  autopilot mode GUIDED"]
    assert tick(4.0, HELM_STATUS="online: armed in GUIDED") == [
        "t+     4.0s  helm online: armed in GUIDED"]
    assert tick(5.0, TASK_ENDED="South:timeout") == ["t+     5.0s  task South ended: timeout"]
    assert tick(6.0, Leg_ERROR="starved") == ["t+     6.0s  Leg_ERROR: starved"]
    assert tick(7.0, MAVLINK_OUTPUT_REFUSED="DESIRED_THRUST=nan") == [
        "t+     7.0s  MAVLINK_OUTPUT_REFUSED: DESIRED_THRUST=nan"]


def test_a_repeated_line_is_held_back_then_counted():
    tick = rig()
    assert len(tick(0.0, GPS_WARNING="flaky")) == 1
    assert tick(1.0, GPS_WARNING="flaky") == []
    assert tick(2.0, GPS_WARNING="flaky") == []
    assert tick(6.0, GPS_WARNING="flaky") == [
        "t+     6.0s  GPS_WARNING: flaky  (and 2 more like it)"]


def _mission_ended(now: float) -> tuple[SimClock, Bus, StatusConsole, list[str]]:
    """A console on its bus at ``now``, MISSION_ENDED posted and not yet fetched."""
    clock = SimClock(now)
    bus = Bus(clock)
    lines: list[str] = []
    console = StatusConsole(bus, lines.append)
    bus.subscribe(console.name, console.subscriptions())
    bus.notify("MISSION_ENDED", "AllStop", "pHelm")
    return clock, bus, console, lines


def test_wall_clock_times_are_shown_as_time_of_day():
    clock, bus, console, lines = _mission_ended(1_764_500_000.25)
    console.take(bus.fetch(console.name), clock.now())
    assert lines == ["10:53:20.2  MISSION ENDED (AllStop holds the vehicle)"]


def test_the_helms_events_reach_the_ground_station_with_severities_and_a_rate_limit():
    clock = SimClock(0.0)
    bus = Bus(clock)
    sent: list[tuple[str, int]] = []
    console = StatusConsole(bus, None, statustext=lambda text, sev: sent.append((text, sev)))
    bus.subscribe(console.name, console.subscriptions())

    def post(**values) -> list[tuple[str, int]]:
        for name, value in values.items():
            bus.notify(name, value, "test")
        before = len(sent)
        console.take(bus.fetch(console.name), clock.now())
        return sent[before:]

    assert post(AP_MODE="GUIDED", AP_LINK=1.0, MAVLINK_LINK="open") == [], "the GCS knows those"
    assert post(HELM_STATUS="ONLINE: autopilot armed in GUIDED") == [
        ("helm ONLINE: autopilot armed in GUIDED", 5)]
    assert post(TASK_STARTED="South") == [("task South started", 6)]
    assert post(Leg_ERROR="starved") == [("Leg_ERROR: starved", 3)]
    clock.advance(10.0)
    burst = post(**{f"T{i}_WARNING": "x" for i in range(10)})
    assert len(burst) == 4 and all(sev == 4 for _, sev in burst), "4 lines a second at most"
    assert console.gcs_dropped == 6
    clock.advance(1.0)
    assert len(post(**{f"U{i}_WARNING": "y" for i in range(10)})) == 4


def test_states_posted_every_heartbeat_are_shown_only_when_they_change():
    tick = rig()
    assert tick(1.0, AP_MODE="MANUAL") == ["t+     1.0s  autopilot mode MANUAL"]
    assert tick(2.0, AP_MODE="MANUAL") == []
    assert tick(9.0, AP_MODE="MANUAL") == [], "not even after the quiet time"
    assert tick(9.5, AP_MODE="GUIDED") == ["t+     9.5s  autopilot mode GUIDED"]


def test_the_tick_only_hands_the_console_its_mail_the_idle_time_tells_it():
    """The console's lines wait for the loop's idle time, after the tick's commands are out."""
    clock, bus, console, lines = _mission_ended(0.0)
    console.on_mail(bus.fetch(console.name), clock.now())
    console.iterate(clock.now())
    assert lines == []
    console.idle()
    assert lines == ["t+     0.0s  MISSION ENDED (AllStop holds the vehicle)"]
    console.idle()
    assert len(lines) == 1, "told once"


def test_a_console_line_is_written_whole_so_a_stop_cannot_split_it(monkeypatch) -> None:
    """``print`` writes the text and its newline apart: a SIGTERM between the two (raising
    KeyboardInterrupt) left the line open, and ``mavhelm: stopped`` ran on after it. ``say``
    writes the line and its newline in one write."""
    import sys

    from mavhelm.companion.console import say

    class Recorder:
        def __init__(self) -> None:
            self.writes: list[str] = []

        def write(self, text: str) -> int:
            self.writes.append(text)
            return len(text)

        def flush(self) -> None:
            pass

    out = Recorder()
    monkeypatch.setattr(sys, "stdout", out)
    say("20:55:52.8  helm offline: no connection to the autopilot")
    assert out.writes == ["20:55:52.8  helm offline: no connection to the autopilot\n"]
