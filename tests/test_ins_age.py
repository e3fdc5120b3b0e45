"""Late telemetry on the autopilot's clock: the bridge posts ``INS_AGE`` with each ATTITUDE
(how much later than its time_boot_ms it was heard, against the least late recent message),
and the tune places each turn-rate sample that much earlier, when the autopilot took it; the
loop's design then adds back how old the turn rate is when the helm steers on it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.bridge.lateness import MAX_LATE_S, WINDOW_S, Lateness, sane
from mavhelm.companion.tune import TuneWatch
from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock
from mavhelm.core.geodesy import Origin
from mavhelm.tuning.identify import Recording
from mavhelm.tuning.manoeuvre import Box
from mavhelm.tuning.model import Series, YawModel, fit_yaw, simulate_lag
from tests.support.bridge_rig import BridgeRig

ORIGIN = Origin(56.4120, -5.4760)


def test_lateness_is_against_the_least_late_message_of_the_window() -> None:
    late = Lateness()
    assert late.heard(1000.0, 10.0) == 0.0           # the first lines the clocks up
    assert late.heard(1000.2, 10.1) == pytest.approx(0.1)   # a batch: heard 0.1 s late
    assert late.heard(1000.2, 10.2) == pytest.approx(0.0)
    assert late.heard(1000.45, 10.3) == pytest.approx(0.15)
    # one heard earlier relative to its time than any before: the clocks line up on it
    assert late.heard(1000.48, 10.5) == 0.0
    assert late.heard(1000.6, 10.55) == pytest.approx(0.07)
    # the least late ages out of the window: a later one takes its place
    assert late.heard(1000.6 + WINDOW_S + 1.0, 10.55 + WINDOW_S + 0.9) == 0.0
    # the autopilot rebooted: its clock went back, the clocks line up anew
    assert late.heard(1010.0, 0.5) == 0.0
    assert late.heard(1010.3, 0.7) == pytest.approx(0.1)


def test_sane_keeps_a_lateness_to_correct_by() -> None:
    assert sane(0.1) == 0.1
    assert sane(None) is None
    assert sane(MAX_LATE_S + 0.1) is None
    assert sane(-0.01) is None


def test_the_bridge_posts_ins_age_with_each_attitude_before_its_turn_rate() -> None:
    rig = BridgeRig()

    def attitude(time_boot_ms: int, yawspeed: float = 0.2) -> list[Message]:
        rig.hear(mavlink.MAVLink_attitude_message(time_boot_ms, 0.0, 0.0, 0.5, 0.0, 0.0,
                                                  yawspeed))
        return [m for m in rig.posted() if m.name.startswith("INS_")]

    first = attitude(60_000)
    assert [m.name for m in first][:1] == ["INS_AGE"]
    assert first[0].value == 0.0
    # two read in one batch at the same stamp: the first was sent 0.1 s before the second
    rig.clock.advance(0.2)
    older, newer = attitude(60_100), attitude(60_200)
    age = {m.name: m for m in older}["INS_AGE"]
    assert age.value == pytest.approx(0.1)
    assert age.time == {m.name: m for m in older}["INS_YAW_VEL"].time  # one stamp
    assert {m.name: m.value for m in newer}["INS_AGE"] == pytest.approx(0.0)
    # heard seconds after its time (a stall): no age to correct by
    rig.clock.advance(3.0)
    assert "INS_AGE" not in {m.name for m in attitude(60_300)}
    # a message without an autopilot clock leaves no lateness for the next handler
    rig.boat_heartbeat()
    assert rig.bridge.state.late is None


def test_the_watch_places_each_turn_rate_when_the_autopilot_took_it() -> None:
    bus = Bus(SimClock(0.0))
    watch = TuneWatch(bus, Box(-50.0, -50.0, 50.0, 50.0))
    watch.on_mail([Message("HELM_STATE", "ONLINE", 1.0, "pHelm")], 1.0)
    watch.on_mail([Message("INS_AGE", 0.1, 2.0, "iMAVLink"),
                   Message("INS_YAW_VEL", -math.radians(10.0), 2.0, "iMAVLink"),
                   Message("INS_AGE", 0.0, 2.0, "iMAVLink"),
                   Message("INS_YAW_VEL", -math.radians(20.0), 2.0, "iMAVLink"),
                   # a turn rate without an age of its stamp stays where it was heard
                   Message("INS_YAW_VEL", -math.radians(30.0), 2.3, "iMAVLink")], 2.3)
    got = watch.recording.turn_rate
    assert [t for t, _ in got] == pytest.approx([1.9, 2.0, 2.3])
    assert [r for _, r in got] == pytest.approx([10.0, 20.0, 30.0])
    assert watch.recording.turn_rate_age == [(2.0, 0.1), (2.0, 0.0), (2.3, 0.0)]


def test_latency_is_the_age_of_the_newest_turn_rate_at_each_command() -> None:
    rec = Recording(turn_command=[(2.0, 0.0), (2.1, 0.0), (2.2, 0.0)],
                    turn_rate_age=[(2.0, 0.1), (2.0, 0.0), (2.2, 0.1), (2.2, 0.0)])
    # at 2.0 the newest was taken at 2.0 (age 0), at 2.1 the same (0.1), at 2.2 at 2.2 (0)
    assert rec.latency() == pytest.approx(0.1 / 3)
    assert Recording(turn_command=[(1.0, 0.0)]).latency() == 0.0
    assert YawModel(1.0, 0.2, 0.1, 60.0, 1.0, latency=0.05).loop_delay == pytest.approx(0.15)


def test_placing_batched_samples_when_taken_removes_their_residual() -> None:
    """A vehicle of known response, its turn rate heard in pairs every 0.2 s (the first 0.1 s
    old): fitted at the stamps it leaves a residual the placed samples do not."""
    t_cmd = np.arange(0.0, 40.0, 0.1)
    turn = np.where((t_cmd // 3) % 2 == 0, 60.0, -60.0) * (t_cmd >= 2.0)
    taken = np.arange(0.05, 40.0, 0.1)
    rate = simulate_lag(Series(t_cmd, turn), taken, 1.0, 0.15, 0.1, 60.0, accel=170.0)
    heard = np.ceil((taken - 0.05) / 0.2 - 1e-9) * 0.2 + 0.05
    stamped = fit_yaw(Series(t_cmd, turn), Series(heard, rate))
    placed = fit_yaw(Series(t_cmd, turn), Series(taken, rate))
    assert placed.rms < 1.0
    assert stamped.rms > 3.0 * placed.rms
    assert placed.delay == pytest.approx(0.1, abs=0.05)
