"""A MAVLink bridge on a bus with a simulated clock, fed frames as an autopilot sends them
(encoded and decoded by pymavlink), for tests of what the bridge posts."""

from __future__ import annotations

import socket
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.bridge import BridgeConfig, MavlinkBridge
from mavhelm.companion.bridge.handlers import handle
from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock
from mavhelm.core.geodesy import Origin
from tests.support.ports import free_udp_port

ORIGIN = Origin(56.4120, -5.4760)


@dataclass
class BridgeRig:
    clock: SimClock = field(default_factory=lambda: SimClock(100.0))
    autopilot: mavlink.MAVLink = field(
        default_factory=lambda: mavlink.MAVLink(None, srcSystem=1, srcComponent=1))

    def __post_init__(self) -> None:
        self.bus = Bus(self.clock)
        self.bus.subscribe("test", ["*"])
        self.bridge = MavlinkBridge(
            self.bus, BridgeConfig(connect=f"udpin:127.0.0.1:{free_udp_port()}"), ORIGIN)

    def hear(self, msg: mavlink.MAVLink_message) -> None:
        """The autopilot's frame, as the link decodes it, handled now."""
        decoded = mavlink.MAVLink(None).decode(bytearray(msg.pack(self.autopilot)))
        handle(self.bridge, decoded, self.clock.now())

    def boat_heartbeat(self) -> None:
        self.hear(mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_SURFACE_BOAT, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 15, 4, 3))

    def posted(self) -> list[Message]:
        return self.bus.fetch("test")


class UdpLinkRig:
    """A bridge on ``udpin:`` that has bound its port (a simulated clock, every post kept for
    ``test``), and the autopilot's (1/1) UDP socket to it: frames go through the link."""

    def __init__(self) -> None:
        port = free_udp_port()
        self.clock = SimClock(100.0)
        self.bus = Bus(self.clock)
        self.bus.subscribe("test", ["*"])
        self.bridge = MavlinkBridge(self.bus, BridgeConfig(connect=f"udpin:127.0.0.1:{port}"),
                                    ORIGIN)
        self.bridge.receive(self.clock.now())  # binds the port
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.address = ("127.0.0.1", port)
        self.autopilot = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)

    def close(self) -> None:
        self.sock.close()
        self.bridge.close()
