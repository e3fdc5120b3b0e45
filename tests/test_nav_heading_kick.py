"""A heading sensor that jumps (mavhelm.nav.heading_kick): a step between two readings further
than the vehicle turns in the time is the sensor's bias stepping, taken into the bias state,
the heading kept; turns, however fast a boat makes them, are not."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavhelm.core.mission import parse_mission
from mavhelm.nav import heading_kick
from mavhelm.nav.filter_safety import HEADING
from mavhelm.nav.heading_kick import KICK_GAP, HeadingKick
from mavhelm.nav.replay import replay
from tests.support import box_boat


def _readings(kick: HeadingKick, yaws: list[float], dt: float = 0.1, rate: float = 0.0,
              accepted: bool = True) -> list[float | None]:
    steps = []
    for k, z in enumerate(yaws):
        steps.append(kick.step("compass", k * dt, z, math.radians(1.0), rate, 0.05))
        kick.taken("compass", k * dt, z, accepted)
    return steps


def test_a_step_beyond_any_turn_is_a_kick_and_the_step_back_another() -> None:
    yaws = [0.0, 0.0, math.radians(60.0), math.radians(60.0), 0.0]
    steps = _readings(HeadingKick(), yaws)
    assert steps[:2] == [None, None] and steps[3] is None
    assert steps[2] == pytest.approx(math.radians(60.0))
    assert steps[4] == pytest.approx(math.radians(-60.0))


def test_a_fast_turn_is_no_kick() -> None:
    """A boat turning at 0.8 rad/s (the filter's rate says so): 4.6° a reading at 10 Hz."""
    yaws = [0.08 * k for k in range(20)]
    assert _readings(HeadingKick(), yaws, rate=0.8) == [None] * 20
    # nor the start of a turn the rate has not caught yet: 2.7 rad/s² from rest
    yaws = [0.5 * 2.7 * (0.1 * k) ** 2 for k in range(4)]
    assert _readings(HeadingKick(), yaws, rate=0.0) == [None] * 4


def test_no_kick_after_a_refused_reading_or_a_silence() -> None:
    kick = HeadingKick()
    assert _readings(kick, [0.0, 1.0], accepted=False) == [None, None]
    kick = HeadingKick()
    assert _readings(kick, [0.0, 1.0], dt=KICK_GAP + 0.1) == [None, None]


def test_a_compass_that_jumps_keeps_the_filter_on_its_gps(monkeypatch) -> None:
    """GPS and a compass jumping 60° now and then, no gyro: refused, the jumped readings
    let the heading's uncertainty grow and are taken a second later, the heading turned with
    them; the bias then learns the jump and is stale by as much when the compass jumps back.
    Taken as the bias stepping, each way, the heading holds."""
    block = parse_mission(box_boat.MISSION, "box.moos").process("pNav")
    assert block is not None
    noise = np.random.default_rng(12)
    # 60° off for 12 s of every 50 (a motor switched on), 1° of noise
    log = box_boat.box(lambda t, heading: heading + (60.0 if t % 50.0 >= 38.0 else 0.0)
                       + noise.normal(0, 1.0), seed=11)
    kicked = replay(block, log)
    said = [d for d in kicked.navigator.fusion.decisions
            if d.kind == HEADING and "jumped" in d.why]
    assert len(said) >= 8  # six jumps and six jumps back in 300 s
    monkeypatch.setattr(heading_kick, "KICK_MIN", math.inf)
    unkicked = replay(block, log)
    rms, before = kicked.accuracy().rms, unkicked.accuracy().rms
    print(f"\nEKF RMS {rms:.2f} m with the kicks taken as bias steps, {before:.2f} m without")
    assert rms < 1.5
    assert before > 2.0 * rms
