"""What the bridge has heard from the autopilot and the ground stations, shared by the
handlers that fill it in and the supervisor that decides from it."""

from __future__ import annotations

from dataclasses import dataclass, field

from mavhelm.companion.actuation import AutopilotView

BOOT_OFFSET_STEP = 1.0
"""s: an offset between the clocks this much larger than the least is a new clock (the
autopilot rebooted, the companion's clock was set), taken as it is."""


@dataclass
class AutopilotState:
    mode: str | None = None
    vehicle_type: int | None = None
    """The autopilot's HEARTBEAT type (MAV_TYPE): which mode table and actuation apply."""
    armed: bool = False
    last_heartbeat: float | None = None
    """When the autopilot's latest HEARTBEAT was heard on this connection."""
    ekf_position_ok: bool | None = None
    view: AutopilotView = field(default_factory=AutopilotView)
    heard: set[str] = field(default_factory=set)
    """Message types heard from the autopilot since the link came up."""
    last_statustext: str = ""
    gcs_heard_at: float | None = None
    """When a ground station's HEARTBEAT was last heard (ArduPilot forwards them)."""
    streams_acked: bool = False
    warned_far: bool = False
    signed: bool | None = None
    """Whether the autopilot's latest HEARTBEAT was validly signed (None: none heard)."""
    signing_sent: bool = False
    """SETUP_SIGNING has been sent on this connection."""
    unsigned_heartbeats: int = 0
    """The autopilot's HEARTBEATs without a valid signature on this connection."""
    guests: dict[str, tuple[int, int]] = field(default_factory=dict)
    """job@client → (system, component) of guests that asked over MAVLink."""
    boot_offset: float | None = None
    """The bridge's clock less the autopilot's (s since boot), the least over the messages
    that carried ``time_boot_ms`` (latency only adds to it): the autopilot's clock at any
    arrival, whatever order a batch's messages come in, for a GPS fix's age."""

    def observe_boot(self, now: float, boot_s: float) -> None:
        """A message sent at ``boot_s`` on the autopilot's clock arrived at ``now``."""
        offset = now - boot_s
        if self.boot_offset is None or offset < self.boot_offset \
                or offset > self.boot_offset + BOOT_OFFSET_STEP:
            self.boot_offset = offset

    def autopilot_clock(self, now: float) -> float | None:
        """The autopilot's clock (s since boot) at ``now``; None before it is heard."""
        return None if self.boot_offset is None else now - self.boot_offset

    def forget_autopilot(self) -> None:
        """A new or restored connection: nothing heard before it counts."""
        self.last_heartbeat = None
        self.mode = None
        self.armed = False
        self.signed = None
        self.signing_sent = False
        self.unsigned_heartbeats = 0
        self.view = AutopilotView()
        self.boot_offset = None
