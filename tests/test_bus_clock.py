"""The bus (spec 1.1's database in one process) and the clocks every app shares."""

from __future__ import annotations

import pytest

from mavhelm.core.app import App
from mavhelm.core.bus import Bus
from mavhelm.core.clock import SimClock
from mavhelm.core.community import Community


def test_mail_goes_to_subscribers_in_posting_order_once():
    clock = SimClock(5.0)
    bus = Bus(clock)
    bus.subscribe("helm", ["NAV_X", "GoNorth"])
    bus.subscribe("logger", ["*"])
    bus.notify("NAV_X", 3, "pNav")
    bus.notify("NAV_Y", 4.0, "pNav")
    bus.notify("GoNorth", "DONE", "pHelm", time=4.5)
    helm = bus.fetch("helm")
    assert [(m.name, m.value, m.time, m.source) for m in helm] == [
        ("NAV_X", 3.0, 5.0, "pNav"), ("GoNorth", "DONE", 4.5, "pHelm")]
    assert helm[0].is_double and isinstance(helm[0].value, float)
    assert not helm[1].is_double and helm[1].string == "DONE"
    with pytest.raises(TypeError):
        _ = helm[1].double
    assert [m.name for m in bus.fetch("logger")] == ["NAV_X", "NAV_Y", "GoNorth"]
    assert bus.fetch("helm") == [], "mail is delivered once"
    assert bus.latest("NAV_Y").double == 4.0


def test_a_subscriber_also_named_explicitly_gets_one_copy_not_two():
    bus = Bus(SimClock())
    bus.subscribe("logger", ["*", "NAV_X"])
    bus.notify("NAV_X", 1.0, "pNav")
    assert len(bus.fetch("logger")) == 1


def test_sim_clock_only_moves_forward():
    clock = SimClock(10.0)
    assert clock.advance(0.5) == 10.5
    clock.set(12.0)
    assert clock.now() == 12.0
    with pytest.raises(ValueError):
        clock.advance(-1.0)
    with pytest.raises(ValueError):
        clock.set(11.0)


class Recorder(App):
    def __init__(self, bus: Bus, name: str, post: str | None, wants: set[str]) -> None:
        super().__init__(bus)
        self.name = name
        self.post = post
        self.wants = wants
        self.heard: list[list[str]] = []

    def subscriptions(self) -> set[str]:
        return self.wants

    def on_mail(self, mail, now):
        self.heard.append([m.name for m in mail])

    def iterate(self, now):
        if self.post:
            self.notify(self.post, now)


def test_community_order_makes_one_tick_from_sensor_to_actuator():
    """What an earlier app posts is in a later app's mail in the same tick."""
    clock = SimClock()
    bus = Bus(clock)
    sensor = Recorder(bus, "sensor", "GPS_X", set())
    nav = Recorder(bus, "nav", "NAV_X", {"GPS_X"})
    helm = Recorder(bus, "helm", None, {"NAV_X"})
    community = Community(bus, [sensor, nav, helm])
    community.tick(clock.advance(0.1))
    assert nav.heard == [["GPS_X"]] and helm.heard == [["NAV_X"]]


class FakeWall:
    def __init__(self) -> None:
        self.t = 50.0

    def __call__(self) -> float:
        return self.t


def test_autopilot_clock_follows_a_sped_up_autopilot():
    from mavhelm.core.clock import AutopilotClock

    wall = FakeWall()
    clock = AutopilotClock(wall, epoch=1000.0)
    assert clock.now() == 1000.0
    wall.t += 1.0
    assert clock.now() == 1001.0, "before any stamp: wall rate"
    for i in range(30):  # the autopilot runs 20x: 2 s of its time per 0.1 s of wall time
        clock.observe(10.0 + 2.0 * i)
        wall.t += 0.1
    assert clock.warp == pytest.approx(20.0)
    at = clock.now()
    wall.t += 0.5
    assert clock.now() == pytest.approx(at + 10.0), "silent autopilot: the measured rate"
    clock.observe(10.0 + 2.0 * 30)  # a stamp behind the extrapolation: time does not go back
    assert clock.now() >= at + 10.0 - 1e-9
    before = clock.now()
    clock.observe(0.5)  # rebooted: stamps restart from zero
    wall.t += 0.1
    assert clock.now() >= before
    clock.observe(2.5)
    assert clock.now() >= before


def _read_a_stalling_link(clock, wall: FakeWall, stall_at: float, stall_s: float,
                          warp: float = 10.0, until: float = 8.0) -> tuple[float, float]:
    """A companion reading a ``warp``x autopilot every 0.1 s of wall time (ten stamps a read,
    the newest just sent), but once not for ``stall_s``: that read brings the whole backlog.
    Returns how far the clock ran ahead of the autopilot at worst (autopilot seconds),
    watched every 10 ms of wall time, and the newest stamp sent."""
    start, sent, worst = wall.t, -0.1, 0.0
    clock.observe(100.0 + sent)
    offset = clock.now() - (100.0 + sent)
    next_read = start
    while wall.t - start < until:
        if wall.t >= next_read - 1e-9:
            newest = warp * (wall.t - start)
            while sent < newest:
                sent = min(newest, sent + 0.1 * warp / 10)
                clock.observe(100.0 + sent)
            stalled = stall_at <= wall.t - start < stall_at + 0.1
            next_read = wall.t + (stall_s if stalled else 0.1)
        truth = offset + 100.0 + warp * (wall.t - start)
        worst = max(worst, clock.now() - truth)
        wall.t += 0.01
    return worst, 100.0 + sent


@pytest.mark.parametrize("stall_s", [0.5, 3.0, 20.0])
def test_a_stall_does_not_send_the_autopilot_clock_ahead(stall_s):
    """CI, the real SITL at x10: one tick of the tuned mission's flight took 197 autopilot
    seconds and its 120 s time-out fired. A stall does that to a rate measured on every
    stamp: the backlog's old stamps, read 0.1 s before fresh ones, make it several times too
    high, and the clock runs ahead between reads (here 9 s after a 3 s stall, 89 s after a
    20 s one) and never comes back. Each read now counts once, by its newest stamp."""
    from mavhelm.core.clock import AutopilotClock

    wall = FakeWall()
    clock = AutopilotClock(wall, epoch=1000.0)
    worst, _ = _read_a_stalling_link(clock, wall, stall_at=1.0, stall_s=stall_s,
                                  until=stall_s + 4.0)
    assert worst < 1.5, f"ran {worst:.1f} autopilot seconds ahead"
    assert clock.warp == pytest.approx(10.0, rel=0.05)


def test_the_rate_follows_an_autopilot_that_slows_down():
    """The envelope's slope is a least: a real change of rate (a loaded SITL dropping from
    x10 to x2) is followed within the window, not held at the old rate."""
    from mavhelm.core.clock import AutopilotClock

    wall = FakeWall()
    clock = AutopilotClock(wall, epoch=1000.0)
    _, boot = _read_a_stalling_link(clock, wall, stall_at=99.0, stall_s=0.0, until=3.0)
    assert clock.warp == pytest.approx(10.0, rel=0.02)
    for _ in range(30):
        wall.t += 0.1
        boot += 0.2
        clock.observe(boot)
    assert clock.warp == pytest.approx(2.0, rel=0.02)


def test_autopilot_clock_sleeps_in_autopilot_time():
    from mavhelm.core.clock import AutopilotClock

    clock = AutopilotClock()
    clock.warp, clock.rate_known = 50.0, True
    t0 = clock.now()
    clock.sleep_until(t0 + 1.0)  # one autopilot second at 50x is 20 ms of wall time
    assert clock.now() >= t0 + 1.0


def test_until_the_rate_is_measured_the_clock_polls():
    """At start-up an unknown rate is not taken for 1x: the loop wakes every 10 ms to read
    the link (a SITL at 20x would otherwise be read two autopilot seconds at a time)."""
    import time

    from mavhelm.core.clock import AutopilotClock

    clock = AutopilotClock()
    assert not clock.rate_known
    t0 = time.monotonic()
    clock.sleep_until(clock.now() + 1.0)
    assert time.monotonic() - t0 < 0.1


def test_a_clock_ahead_of_the_autopilot_does_not_stop_the_ticks():
    """Overshoot (the rate measured on a burst) freezes now() until the stamps catch up; the
    tick loop still wakes after one period's wall time, so it goes on reading the link."""
    import time

    from mavhelm.core.clock import AutopilotClock

    clock = AutopilotClock()
    clock.observe(0.0)
    clock.warp, clock.rate_known = 10.0, True
    clock._last_now = clock.now() + 5.0  # ran 5 autopilot seconds ahead
    t0 = time.monotonic()
    clock.sleep_until(clock.now() + 0.1)
    assert time.monotonic() - t0 < 0.25  # 0.1 s at 10x is 10 ms; frozen would be 0.5 s


def test_a_rate_measured_far_too_low_does_not_keep_the_companion_from_its_link():
    """A 0.01x rate would make one 0.1 s tick a 10 s wait on the wall clock, and the link
    unread all that while: one wait is half a wall second at most."""
    import time

    from mavhelm.core.clock import AutopilotClock

    clock = AutopilotClock()
    clock.observe(0.0)
    clock.warp, clock.rate_known = 0.01, True
    t0 = time.monotonic()
    clock.sleep_until(clock.now() + 0.1)
    assert time.monotonic() - t0 < AutopilotClock.MAX_WAIT_S + 0.25


def test_backoff_doubles_to_its_ceiling_and_resets_on_success():
    from mavhelm.core.backoff import Backoff

    b = Backoff(first_s=1.0, max_s=8.0)
    assert b.due(0.0)
    waits = [b.failed(t) for t in (0.0, 1.0, 3.0, 7.0, 15.0, 23.0)]
    assert waits == [1.0, 2.0, 4.0, 8.0, 8.0, 8.0]
    assert not b.due(30.9) and b.due(31.0)
    b.succeeded()
    assert b.due(0.0) and b.failed(40.0) == 1.0
    with pytest.raises(ValueError):
        Backoff(first_s=0.0)
