"""What the bridge has heard from the autopilot and the ground stations, shared by the
handlers that fill it in and the supervisor that decides from it."""

from __future__ import annotations

from dataclasses import dataclass, field

from mavhelm.companion.actuation import AutopilotView
from mavhelm.companion.bridge.lateness import Lateness


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
    boot_s: float | None = None
    """The autopilot's clock (s since boot) in the latest message that carried one: a
    message on the link was sent no earlier, so a GPS fix is at least that clock less its
    time_usec old."""
    lateness: Lateness = field(default_factory=Lateness)
    """How the autopilot's clock lines up with the companion's stamps."""
    late: float | None = None
    """How much later than its own time_boot_ms the message being handled was heard (s,
    ``Lateness``); None for a message without one."""
    heard_at: float | None = None
    """The companion's stamp of the message being handled."""
    gps_fix_usec: int | None = None
    """time_usec of the latest GPS fix posted. ArduPilot's GPS_RAW_INT stream is not in step
    with the receiver and now and then sends the same fix twice; a repeat is not a new
    position (posted again under a later stamp it reads as a vehicle that stopped, and a
    filter would count it twice)."""
    gps_repeats: int = 0
    """GPS_RAW_INT messages that repeated the fix before them, not posted."""

    def forget_autopilot(self) -> None:
        """A new or restored connection: nothing heard before it counts."""
        self.last_heartbeat = None
        self.mode = None
        self.armed = False
        self.signed = None
        self.signing_sent = False
        self.unsigned_heartbeats = 0
        self.view = AutopilotView()
        self.boot_s = None
        self.lateness = Lateness()
        self.late = None
        self.heard_at = None
        self.gps_fix_usec = None
