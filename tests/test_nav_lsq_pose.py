"""The five-state LSQ (spec 2.2): besides X and Y from the ranges, the heading and the depth
(and Z) from the orientation and depth readings of the same window, so ``LSQ`` in the Yaw,
Depth and Z queues is fed."""

from __future__ import annotations

import math

import pytest

from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock
from mavhelm.core.mission import parse_mission
from mavhelm.nav.navigator import Navigator

MISSION = """
ProcessConfig = pNav
{
    X     = LSQ @ 5
    Y     = LSQ @ 5
    Z     = LSQ @ 5
    Depth = LSQ @ 5
    Yaw   = LSQ @ 5
    SENSOR_RANGE       = R -> ranger @ 0,0,0 ~ 0.3
    SENSOR_ORIENTATION = C -> compass ~ 1
    SENSOR_DEPTH       = P -> pressure @ 0,0,-0.5 ~ 0.05
    BEACON = 1 @ 0,0,-20
    BEACON = 2 @ 100,0,-20
    BEACON = 3 @ 0,100,-20
    LSQTimeOut = NEVER
}
"""


def test_lsq_feeds_the_yaw_depth_and_z_queues() -> None:
    block = parse_mission(MISSION, "m.moos").process("pNav")
    assert block is not None
    clock = SimClock(0.0)
    bus = Bus(clock)
    nav = Navigator.from_block(bus, block)
    bus.subscribe(nav.name, nav.subscriptions())
    bus.subscribe("test", {"NAV_X", "NAV_Y", "NAV_Z", "NAV_DEPTH", "NAV_YAW", "NAV_HEADING",
                           "NAV_YAW_SOURCE", "NAV_DEPTH_SOURCE"})
    truth, depth, yaw = (30.0, 40.0, -12.0), 12.0, math.radians(-30.0)  # heading 30°
    beacons = {"1": (0.0, 0.0, -20.0), "2": (100.0, 0.0, -20.0), "3": (0.0, 100.0, -20.0)}
    last: dict[str, Message] = {}
    for k in range(60):
        t = 0.5 * k
        clock.set(t)
        name = "123"[k % 3]
        bx, by, bz = beacons[name]
        # the ranges are slant ranges in the vehicle's plane: the beacons' z is relative to it
        bus.notify(f"R_RANGE_{name}", math.hypot(truth[0] - bx, truth[1] - by, bz), "log", t)
        bus.notify("C_YAW", yaw, "log", t)
        bus.notify("P_DEPTH", depth, "log", t)
        nav.on_mail(bus.fetch(nav.name), t)
        nav.iterate(t)
        last.update({m.name: m for m in bus.fetch("test")})
    assert last["NAV_X"].double == pytest.approx(truth[0], abs=0.01)
    assert last["NAV_Y"].double == pytest.approx(truth[1], abs=0.01)
    assert last["NAV_YAW"].double == pytest.approx(yaw, abs=1e-9)
    assert last["NAV_HEADING"].double == pytest.approx(30.0, abs=1e-6)
    assert last["NAV_DEPTH"].double == pytest.approx(depth)
    # Z of the vehicle's origin, up: the surface (no tide) less the depth, less the sensor's
    # place 0.5 m below the origin
    assert last["NAV_Z"].double == pytest.approx(-depth + 0.5)
    assert last["NAV_YAW_SOURCE"].value == "LSQ" and last["NAV_DEPTH_SOURCE"].value == "LSQ"
