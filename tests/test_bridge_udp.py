"""The bridge on a UDP link (``udpin:``), fed by the simulator's ``--out udp:HOST:PORT`` output,
the way a companion behind mavlink-router or a SITL ``--out`` would be connected."""

from __future__ import annotations

import time

from mavhelm.companion.bridge import BridgeConfig, MavlinkBridge
from mavhelm.core.bus import Bus
from mavhelm.core.clock import SimClock
from mavhelm.core.geodesy import Origin
from mavhelm.sitl.simulator import Simulator
from tests.support.ports import free_udp_port

HOME = Origin(56.4120, -5.4760)


def test_bridge_over_udp_hears_the_autopilot_and_is_heard():
    port = free_udp_port()
    clock = SimClock(0.0)
    bus = Bus(clock)
    bridge = MavlinkBridge(bus, BridgeConfig(connect=f"udpin:127.0.0.1:{port}"), HOME)
    sim = Simulator(clock, ports=(), udp_out=[("127.0.0.1", port)], home=HOME, fast_start=True)
    bus.subscribe("test", ["*"])
    heard: dict[str, float | str] = {}
    try:
        deadline = time.monotonic() + 20.0
        while time.monotonic() < deadline and "GPS_X" not in heard:
            now = clock.advance(0.1)
            sim.step(now)
            time.sleep(0.002)  # UDP on loopback: let the datagrams land
            bridge.receive(now)
            bridge.send([], now)
            heard.update((m.name, m.value) for m in bus.fetch("test"))
        assert heard.get("AP_MODE") == "MANUAL"
        assert abs(heard["GPS_X"]) < 5.0 and abs(heard["GPS_Y"]) < 5.0
        sim.step(clock.advance(0.1))
        udp_link = sim.links[0]
        assert (1, 191) in udp_link.systems_seen, "the companion's heartbeat reached the autopilot"
        assert udp_link.received.get("COMMAND_LONG", 0) >= 1, "stream requests went out over UDP"
    finally:
        bridge.close()
        sim.close()
