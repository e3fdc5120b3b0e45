"""A heading sensor that jumps (mavhelm.nav.heading_kick): a step between two readings further
than the vehicle turns in the time is the sensor's bias stepping, taken into the bias state,
the heading kept; turns, however fast a boat makes them, are not."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavhelm.core.bus import Message
from mavhelm.core.mission import parse_mission
from mavhelm.nav import heading_kick
from mavhelm.nav.filter_safety import HEADING
from mavhelm.nav.heading_kick import KICK_GAP, HeadingKick
from mavhelm.nav.replay import replay


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


MISSION = """
LatOrigin = 56.412
LongOrigin = -5.476
ProcessConfig = pNav
{
    X       = EKF @ 2
    Y       = EKF @ 2
    Heading = EKF @ 2
    SENSOR_XY          = GPS -> gps ~ 2
    SENSOR_ORIENTATION = HDG -> compass ~ 1
    FIXEDSIDESLIP      = 0 @ 0.3
    EKF_YAW_BIAS       = true
}
"""


def _box_with_a_jumping_compass(seconds: float = 300.0) -> list[Message]:
    """A boat at 3 m/s round a box (legs of 33 s, quarter turns of 10 s): 5 Hz GPS with 2 m
    of noise, a 10 Hz compass (1°) that reads 60° off for 12 s of every 50 (a motor), the
    truth."""
    rng = np.random.default_rng(11)
    out = []
    x = y = 0.0
    heading = 90.0
    for k in range(int(seconds * 10)):
        t = 5000.0 + 0.1 * k
        rate = 9.0 if (0.1 * k) % 43.0 >= 33.0 else 0.0  # deg/s clockwise
        heading = (heading + rate * 0.1) % 360.0
        x += 3.0 * math.sin(math.radians(heading)) * 0.1
        y += 3.0 * math.cos(math.radians(heading)) * 0.1
        jumped = 60.0 if (0.1 * k) % 50.0 >= 38.0 else 0.0
        out.append(Message("HDG_HEADING", (heading + jumped + rng.normal(0, 1.0)) % 360.0, t,
                           "log"))
        if k % 2 == 0:
            out += [Message("GPS_X", x + rng.normal(0, 2.0), t, "log"),
                    Message("GPS_Y", y + rng.normal(0, 2.0), t, "log"),
                    Message("TRUTH_X", x, t, "log"), Message("TRUTH_Y", y, t, "log")]
    return out


def test_a_compass_that_jumps_keeps_the_filter_on_its_gps(monkeypatch) -> None:
    """GPS and a compass jumping 60° now and then, no gyro: refused, the jumped readings
    let the heading's uncertainty grow and are taken a second later, the heading turned with
    them; the bias then learns the jump and is stale by as much when the compass jumps back.
    Taken as the bias stepping, each way, the heading holds."""
    block = parse_mission(MISSION, "box.moos").process("pNav")
    assert block is not None
    log = _box_with_a_jumping_compass()
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
