"""The MAVLink bridge: the autopilot seen as variables on the bus, and helm output sent back.

One concept a module: ``config`` (the iMAVLink block), ``handlers`` (one per incoming message
type), ``readings`` (sensor conversions), ``state`` (what has been heard), ``supervisor``
(link up, online, status; stream and parameter requests), ``output`` (the send path) and
``facade`` (``MavlinkBridge`` and its two apps).

It is one connection with two faces in the community's tick order: ``AutopilotInput`` runs
first (MAVLink in → ``GPS_*``, ``INS_*``, ``AP_*``, ``HELM_ONLINE``) and ``AutopilotOutput``
runs after the helm (``DESIRED_*`` → SET_ATTITUDE_TARGET), so a mode change that arrives in a
tick stops actuation in that same tick.

The helm is online only while the link is up (a HEARTBEAT from the autopilot within
``LinkTimeOut``), the autopilot is armed and its mode is one of ``OnlineModes``: the operator's
ground-station mode switch is the spec's iRemote. In GUIDED, ArduPilot ignores RC override, so
the ``guided`` actuation profile sends body yaw rate + thrust (type_mask 0x03), which Rover turns
into turn rate and speed = thrust × WP_SPEED.

What the autopilot's telemetry becomes (local frame of the mission's origin: X east, Y north):

====================  ================================================================
HEARTBEAT             ``AP_MODE`` (the mode's name in the table of the HEARTBEAT's type:
                      ArduSub's for a submarine, else Rover's), ``AP_ARMED`` 1/0
GPS_RAW_INT           ``GPS_FIX``; with a 3-D fix ``GPS_X``, ``GPS_Y`` (m), ``GPS_SPEED``
                      (m/s), ``GPS_HEADING`` (deg, course over ground), ``GPS_AGE`` (s, how
                      old the fix is on arrival, when time_usec is the autopilot's clock)
ATTITUDE              ``INS_YAW`` (rad, yaw = −heading), ``INS_HEADING`` (deg),
                      ``INS_PITCH``, ``INS_ROLL`` (rad), ``INS_YAW_VEL`` (rad/s),
                      ``INS_AGE`` (s, how much later than its time_boot_ms it was heard,
                      against the least late of the last few seconds' messages)
GLOBAL_POSITION_INT   ``AP_X``, ``AP_Y`` (m), ``AP_SPEED`` (m/s), ``AP_HEADING`` (deg),
                      ``AP_YAW`` (rad): the autopilot's EKF, while it has a position
on ArduSub: GLOBAL_   ``AP_DEPTH`` (m, down) and ``AP_Z`` (m, up; the surface is Z = 0, tide 0,
POSITION_INT,         spec 2.3.1) from relative_alt; ``VFR_DEPTH``/``VFR_Z`` from VFR_HUD's alt;
VFR_HUD,              ``BARO_DEPTH``/``BARO_Z`` from barometer 1's pressure, its surface pressure
SCALED_PRESSURE       (BARO1_GND_PRESS) and the water's specific gravity (BARO_SPEC_GRAV)
DISTANCE_SENSOR       pointing down (orientation 25, PITCH_270): ``AP_ALTITUDE`` (m above
                      the bottom, or the ground); any other way: ``AP_DISTANCE_<n>`` (m),
                      ``n`` the MAV_SENSOR_ORIENTATION number, as in ``RNGFNDx_ORIENT``
                      (``AP_DISTANCE_0`` forward, ``AP_DISTANCE_24`` up)
WHEEL_DISTANCE        ``WHEEL_VX_BODY`` (m/s, forward): the wheels' mean distance change
                      over the time since the previous message
SIMSTATE              ``TRUTH_X``, ``TRUTH_Y`` (m), ``TRUTH_HEADING`` (deg): a simulator's
                      ground truth, logged for accuracy reports on SITL
STATUSTEXT            ``AP_STATUSTEXT``; COMMAND_ACK: ``AP_COMMAND_ACK``
====================  ================================================================

DISTANCE_SENSOR, WHEEL_DISTANCE and SIMSTATE are not in the default streams (a boat without a
sounder would be warned about them every time): ArduPilot lists DISTANCE_SENSOR in its EXTRA3
stream, SIMSTATE in EXTRA1 and WHEEL_DISTANCE in EXTRA1 or EXTRA3 (by version), sent at its
SRn_EXTRA* rates; or ask with ``Stream = DISTANCE_SENSOR@5``. ArduPilot's SITL has a
rangefinder with ``RNGFND1_TYPE 100`` (``RNGFND1_ORIENT 25`` down; the rover model reads 1.0 m
down and forward, the motorboat has no data) and wheel encoders with ``WENC_TYPE 10``,
``WENC2_TYPE 10`` and ``WENC_POS_Y``/``WENC2_POS_Y`` set; but Rover 4.8-dev sends no
WHEEL_DISTANCE, in any stream, and refuses SET_MESSAGE_INTERVAL for it ("No ap_message for
mavlink id (9000)"), so wheel odometry from ArduPilot is untested against the binary.
A message whose values are not finite or are impossible is refused whole (``MAVLINK_ERROR``,
counted in ``MAVLINK_BAD_PACKETS``), like any other bad input.

What the autopilot streams on the companion's link and the bridge does not read (a default
ArduPilot link carries some 25 messages, 16 of them read by no one here: RAW_IMU, MEMINFO,
BATTERY_STATUS …) it is asked to stop, on that link only (``SET_MESSAGE_INTERVAL`` −1, once
the companion's own stream requests are acknowledged; ``LinkSupervisor.stop_unread``): the
link's bandwidth goes to what is read. A link recorded to a ``.tlog`` keeps every stream.
"""

from mavhelm.companion.bridge.config import (
    COMPANION_COMPONENT,
    DEFAULT_STREAMS,
    IMAVLINK_SCHEMA,
    BridgeConfig,
    make_actuation,
)
from mavhelm.companion.bridge.facade import AutopilotInput, AutopilotOutput, MavlinkBridge
from mavhelm.companion.bridge.handlers import CMD_REMOTE_FLAG, CMD_RESTART_HELM, FAR_FROM_ORIGIN_M
from mavhelm.companion.bridge.output import FLOAT32_MAX, NAMED_VALUES, STATUSTEXT_MAX
from mavhelm.companion.bridge.readings import (
    WHEEL_MAX_DISTANCE,
    WHEEL_MAX_INTERVAL_S,
    WHEEL_MAX_SPEED,
    WheelOdometry,
    distance_reading,
)
from mavhelm.companion.bridge.supervisor import STREAM_GRACE_S
from mavhelm.companion.mode_request import ROVER_MODE_NUMBERS, ROVER_MODES

__all__ = [
    "CMD_REMOTE_FLAG", "CMD_RESTART_HELM", "COMPANION_COMPONENT", "DEFAULT_STREAMS",
    "FAR_FROM_ORIGIN_M", "FLOAT32_MAX", "IMAVLINK_SCHEMA", "NAMED_VALUES", "ROVER_MODES",
    "ROVER_MODE_NUMBERS", "STATUSTEXT_MAX", "STREAM_GRACE_S", "WHEEL_MAX_DISTANCE",
    "WHEEL_MAX_INTERVAL_S", "WHEEL_MAX_SPEED", "AutopilotInput", "AutopilotOutput",
    "BridgeConfig", "MavlinkBridge", "WheelOdometry", "distance_reading", "make_actuation",
]
