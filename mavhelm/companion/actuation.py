"""How the helm's RUDDER, THRUST and ELEVATOR reach ArduPilot: one class per actuation profile.

Shaped like ArduPilot's own modes: a small base with yes/no questions (``refusal``: why the
helm may not drive now) and the actions (``drive``, ``release``), one subclass per profile.

- ``guided``: SET_ATTITUDE_TARGET with body yaw rate + thrust (type_mask 0x03) in GUIDED,
  which Rover turns into a turn rate and a speed of thrust × WP_SPEED. No release is needed:
  ArduPilot stops by itself 3 s after the last target, and leaving GUIDED ends it at once.
- ``guided`` on ArduSub (HEARTBEAT type SUBMARINE; the bridge picks this profile when it sees
  one): ``SubGuided``, below.
- ``rc_override``: RC_CHANNELS_OVERRIDE on the steering and throttle channels (RCMAP_ROLL,
  RCMAP_THROTTLE, scaled by their RCn_MIN/TRIM/MAX), for vehicles run in MANUAL. ArduPilot
  obeys it only from the system id in MAV_GCS_SYSID, so the companion must speak with that id;
  it reads the parameter and refuses to engage on a mismatch. MANUAL is also the human's
  mode, so engaging needs an explicit signal — an RC switch (``EngageChannel`` above
  ``EngagePWM``) — and the helm releases every channel it drove (0 = back to the radio) the
  moment it goes offline for any reason. Overrides are refreshed every tick, well within
  RC_OVERRIDE_TIME (3 s). ArduPilot counts an accepted RC override as a sign of life from
  the ground station (GCS_Common.cpp, handle_rc_channels_override), so while the companion
  drives, ArduPilot's own GCS failsafe cannot see the operator's station fall silent: the
  profile watches the ground station's HEARTBEAT itself and goes offline (releasing) when it
  is silent for ``GcsTimeOut``, after which ArduPilot's failsafe works as configured.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mavlink

ATTITUDE_RATE_AND_THRUST = 0x03
RC_IGNORE = 0xFFFF
"""RC_CHANNELS_OVERRIDE: leave this channel alone."""
RC_RELEASE = 0
"""RC_CHANNELS_OVERRIDE, channels 1–8: give this channel back to the radio at once."""
RC_RELEASE_HIGH = 0xFFFE
"""The same for channels 9–18, where 0 means "ignore"."""
RELEASE_REPEATS = 3
"""Release messages sent on going offline, so one lost packet cannot leave an override."""


@dataclass
class AutopilotView:
    """What the bridge knows of the autopilot that a profile's decisions depend on."""

    params: dict[str, float] = field(default_factory=dict)
    rc: list[int] = field(default_factory=list)
    """RC_CHANNELS as the autopilot sees them (radio, or override where one is active)."""
    gcs_silent_s: float = math.inf
    """Seconds since a ground station's HEARTBEAT was last heard (forwarded by ArduPilot)."""


def rudder_to_turn_rate(rudder: float, max_rudder: float, max_turn_rate: float) -> float:
    """Degrees of rudder to a body turn rate (deg/s, positive clockwise), saturated."""
    fraction = max(-1.0, min(1.0, rudder / max_rudder)) if max_rudder > 0 else 0.0
    return fraction * max_turn_rate


class Actuation:
    """The base: a profile says why it may not drive, drives, and releases."""

    name = "actuation"

    def wanted_params(self) -> tuple[str, ...]:
        """Autopilot parameters this profile needs before it may engage."""
        return ()

    def refusal(self, view: AutopilotView) -> str | None:
        """Why the helm may not drive now (beyond link, arming and mode), or None."""
        return None

    def drive(self, mav: mavlink.MAVLink, view: AutopilotView, rudder: float, thrust: float,
              boot_ms: int, elevator: float = 0.0) -> dict[str, float]:
        """Send one tick's command (rudder and elevator in degrees, thrust in percent, all
        already checked finite and in range); return what was sent, for the bus (AP_CMD_*).
        A surface vehicle's profile ignores the elevator."""
        raise NotImplementedError

    def release(self, mav: mavlink.MAVLink) -> None:
        """The helm has just gone offline: hand the actuators back."""


@dataclass
class Guided(Actuation):
    target_system: int
    target_component: int
    max_rudder: float
    max_turn_rate: float
    name = "guided"

    def drive(self, mav: mavlink.MAVLink, view: AutopilotView, rudder: float, thrust: float,
              boot_ms: int, elevator: float = 0.0) -> dict[str, float]:
        yaw_rate = math.radians(rudder_to_turn_rate(rudder, self.max_rudder,
                                                    self.max_turn_rate))
        fraction = thrust / 100.0
        mav.set_attitude_target_send(boot_ms, self.target_system, self.target_component,
                                     ATTITUDE_RATE_AND_THRUST, [1.0, 0.0, 0.0, 0.0], 0.0, 0.0,
                                     yaw_rate, fraction)
        return {"AP_CMD_YAW_RATE": yaw_rate, "AP_CMD_THRUST": fraction}


BODY_VELOCITY_AND_YAW_RATE = (
    mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_Y_IGNORE
    | mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE
    | mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE
    | mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE)
"""SET_POSITION_TARGET_LOCAL_NED: velocity and yaw rate only (ArduSub's guided_set_velocity)."""


SUB_PRESSURE_PARAMS = ("BARO1_GND_PRESS", "BARO_SPEC_GRAV")
"""ArduSub's depth sensor (barometer 1): its pressure at the surface (Pa) and the specific
gravity of the water it is in (1.0 fresh, 1.024 sea)."""


@dataclass
class SubGuided(Actuation):
    """ArduSub in GUIDED: SET_POSITION_TARGET_LOCAL_NED in MAV_FRAME_BODY_NED with a velocity
    (forward, 0 across, down) and a yaw rate; position, acceleration and yaw ignored.

    Why this message: ArduSub's GCS_MAVLINK_Sub::handle_message takes a velocity-only target
    with a yaw rate to ``guided_set_velocity`` (mode_guided.cpp), which holds that velocity in
    three axes with its own position controller and turns at the rate: the helm's three
    actuators each have an input. The alternatives each miss one: SET_ATTITUDE_TARGET in
    GUIDED gives attitude and a climb rate but no forward thrust; SET_POSITION_TARGET_GLOBAL_INT
    takes positions (the helm steers, it does not pick points); MANUAL_CONTROL in ALT_HOLD is
    obeyed only from the ground station's system id (MAV_GCS_SYSID) and counts as the pilot's
    input for ArduSub's pilot-input failsafe, so a companion using it would hide a lost operator.
    ArduSub stops on its own (velocity 0, depth held) 3 s after the last target
    (GUIDED_VEL_TIMEOUT_MS), and leaving GUIDED ends it at once.

    The vectored frame has no elevator: the helm's elevator (the depth-by-pitch controller's
    output, positive dives) becomes a vertical speed, full elevator (MAXELEVATOR) being
    ``max_depth_rate`` down; thrust becomes forward speed, full thrust being ``max_speed``;
    rudder becomes a turn rate as on Rover. ArduSub holds its pitch level itself, so the
    pitch loop's input stays near zero and the cascade acts on depth as a proportional
    vertical-speed demand. Measured on the ArduSub SITL (vectored, ×10): 1 m/s ahead, 0.5 m/s
    down and 10°/s together turned, dived and advanced as asked, and with the velocity
    stopped it held its depth within 5 cm.
    """

    target_system: int
    target_component: int
    max_rudder: float
    max_turn_rate: float
    max_elevator: float
    max_speed: float
    max_depth_rate: float
    name = "sub_guided"

    def wanted_params(self) -> tuple[str, ...]:
        """Not needed to drive, but to read depth from the pressure sensor (the bridge's
        SCALED_PRESSURE handler): its surface pressure and the water's specific gravity."""
        return SUB_PRESSURE_PARAMS

    def drive(self, mav: mavlink.MAVLink, view: AutopilotView, rudder: float, thrust: float,
              boot_ms: int, elevator: float = 0.0) -> dict[str, float]:
        yaw_rate = math.radians(rudder_to_turn_rate(rudder, self.max_rudder,
                                                    self.max_turn_rate))
        forward = max(-1.0, min(1.0, thrust / 100.0)) * self.max_speed
        down = (max(-1.0, min(1.0, elevator / self.max_elevator)) * self.max_depth_rate
                if self.max_elevator > 0 else 0.0)
        mav.set_position_target_local_ned_send(
            boot_ms, self.target_system, self.target_component, mavlink.MAV_FRAME_BODY_NED,
            BODY_VELOCITY_AND_YAW_RATE, 0.0, 0.0, 0.0, forward, 0.0, down, 0.0, 0.0, 0.0,
            0.0, yaw_rate)
        return {"AP_CMD_YAW_RATE": yaw_rate, "AP_CMD_VX": forward, "AP_CMD_VZ": down}


DEFAULT_STEER_CHANNEL = 1
DEFAULT_THROTTLE_CHANNEL = 3
"""ArduPilot's default RCMAP_ROLL and RCMAP_THROTTLE."""

GCS_SYSID_PARAMS = ("MAV_GCS_SYSID", "SYSID_MYGCS")
"""ArduPilot 4.7+ names it MAV_GCS_SYSID; older firmware SYSID_MYGCS."""


def engage_clash(params: Mapping[str, float], engage_channel: int) -> str | None:
    """Why the autopilot's RCMAP forbids engaging: steering or throttle on the engage
    channel, where the override would hold the very switch that engages the helm."""
    for what, param in (("steering", "RCMAP_ROLL"), ("throttle", "RCMAP_THROTTLE")):
        if param in params and int(params[param]) == engage_channel:
            return (f"the autopilot's {param} = {engage_channel} puts {what} on the engage "
                    f"switch RC{engage_channel}: the RC override would drive the switch that "
                    "engages the helm; move EngageChannel in iMAVLink (or the autopilot's "
                    "RCMAP)")
    return None


@dataclass
class RcOverride(Actuation):
    target_system: int
    target_component: int
    max_rudder: float
    system_id: int
    engage_channel: int
    engage_pwm: int
    gcs_timeout: float = 5.0
    name = "rc_override"
    driven: set[int] = field(default_factory=set)

    def wanted_params(self) -> tuple[str, ...]:
        names = ["RCMAP_ROLL", "RCMAP_THROTTLE", *GCS_SYSID_PARAMS]
        # the default RCMAP's channels; the mapped channels are asked for once known
        for ch in (DEFAULT_STEER_CHANNEL, DEFAULT_THROTTLE_CHANNEL):
            names += [f"RC{ch}_MIN", f"RC{ch}_TRIM", f"RC{ch}_MAX"]
        return tuple(names)

    def channels(self, params: Mapping[str, float]) -> tuple[int, int] | None:
        if "RCMAP_ROLL" not in params or "RCMAP_THROTTLE" not in params:
            return None
        return int(params["RCMAP_ROLL"]), int(params["RCMAP_THROTTLE"])

    def missing(self, params: Mapping[str, float]) -> list[str]:
        """Parameters still needed before the profile can compute PWM."""
        need = ["RCMAP_ROLL", "RCMAP_THROTTLE"]
        channels = self.channels(params)
        if channels is not None:
            need += [f"RC{ch}_{k}" for ch in channels for k in ("MIN", "TRIM", "MAX")]
        missing = [n for n in need if n not in params]
        if not any(n in params for n in GCS_SYSID_PARAMS):
            missing.append(GCS_SYSID_PARAMS[0])
        return missing

    def refusal(self, view: AutopilotView) -> str | None:
        clash = engage_clash(view.params, self.engage_channel)
        if clash is not None:
            return clash
        missing = self.missing(view.params)
        if missing:
            return f"waiting for the autopilot's parameters {', '.join(missing)}"
        gcs = next(int(view.params[n]) for n in GCS_SYSID_PARAMS if n in view.params)
        if gcs != self.system_id:
            return (f"MAV_GCS_SYSID is {gcs} but the companion speaks as system "
                    f"{self.system_id}, so ArduPilot would ignore its RC override: set "
                    f"SystemID = {gcs} in iMAVLink")
        if view.gcs_silent_s > self.gcs_timeout:
            return (f"no ground station HEARTBEAT for {self.gcs_timeout:g} s (ArduPilot counts "
                    "the companion's RC override as the ground station, so the companion "
                    "watches for the operator itself)")
        if len(view.rc) < self.engage_channel:
            return f"no RC_CHANNELS from the autopilot yet (engage switch RC{self.engage_channel})"
        pwm = view.rc[self.engage_channel - 1]
        if pwm < self.engage_pwm:
            return (f"engage switch RC{self.engage_channel} is low ({pwm} < "
                    f"{self.engage_pwm})")
        return None

    def pwm(self, params: Mapping[str, float], channel: int, fraction: float) -> int:
        """-1..1 to PWM about the channel's trim, as ArduPilot reads its radio."""
        lo = params[f"RC{channel}_MIN"]
        hi = params[f"RC{channel}_MAX"]
        trim = params[f"RC{channel}_TRIM"]
        fraction = max(-1.0, min(1.0, fraction))
        value = trim + fraction * (hi - trim if fraction >= 0 else trim - lo)
        return int(round(max(lo, min(hi, value))))

    def drive(self, mav: mavlink.MAVLink, view: AutopilotView, rudder: float, thrust: float,
              boot_ms: int, elevator: float = 0.0) -> dict[str, float]:
        params = view.params
        channels = self.channels(params)
        assert channels is not None
        steer_ch, throttle_ch = channels
        values = [RC_IGNORE] * 18
        steer = self.pwm(params, steer_ch, rudder / self.max_rudder)
        throttle = self.pwm(params, throttle_ch, thrust / 100.0)
        values[steer_ch - 1] = steer
        values[throttle_ch - 1] = throttle
        self.driven = {steer_ch, throttle_ch}
        mav.rc_channels_override_send(self.target_system, self.target_component, *values)
        return {"AP_CMD_RC_STEER": float(steer), "AP_CMD_RC_THROTTLE": float(throttle)}

    def release(self, mav: mavlink.MAVLink) -> None:
        if not self.driven:
            return
        values = [RC_IGNORE] * 18
        for ch in self.driven:
            values[ch - 1] = RC_RELEASE if ch <= 8 else RC_RELEASE_HIGH
        for _ in range(RELEASE_REPEATS):
            mav.rc_channels_override_send(self.target_system, self.target_component, *values)
        self.driven = set()
