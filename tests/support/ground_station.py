"""What every test ground station sends: COMMAND_LONGs, arming, mode changes, stream requests.

The real-SITL operator (``ardupilot.RealOperator``, on the wall clock) and the simulator rig's
client (``sitl_rig.Client``, in lockstep) receive differently, so each keeps its own reading;
what they send to the autopilot is this one base, so both speak to it the same way.
"""

from __future__ import annotations

from typing import Any

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink


class GroundStation:
    """Commands to the autopilot at ``target_system``/``target_component`` over ``self.mav``
    (a pymavlink ``MAVLink`` encoder, provided by the subclass)."""

    target_system: int = 1
    target_component: int = 1
    mode_names: dict[int, str] = dict(mavutil.mode_mapping_rover)
    """custom_mode → name of the vehicle spoken to (Rover's unless a rig says otherwise)."""

    @property
    def mav(self) -> Any:
        raise NotImplementedError

    def command(self, command: int, *params: float) -> None:
        """COMMAND_LONG ``command`` with up to seven params (the rest 0)."""
        values = list(params) + [0.0] * (7 - len(params))
        self.mav.command_long_send(self.target_system, self.target_component, command, 0,
                                   *values)

    def arm(self, arm: bool = True) -> None:
        self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0 if arm else 0.0)

    def set_mode(self, name: str) -> None:
        """DO_SET_MODE to the mode ``name`` (GUIDED, HOLD, MANUAL...) of ``mode_names``."""
        numbers = {v: k for k, v in self.mode_names.items()}
        self.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                     float(numbers[name.upper()]))

    def request_streams(self, rate_hz: int) -> None:
        """REQUEST_DATA_STREAM ALL at ``rate_hz`` (hertz of the autopilot's clock)."""
        self.mav.request_data_stream_send(self.target_system, self.target_component,
                                          mavlink.MAV_DATA_STREAM_ALL, rate_hz, 1)

    def request_interval(self, name: str, hz: float) -> None:
        """SET_MESSAGE_INTERVAL for message ``name`` at ``hz``."""
        self.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
                     getattr(mavlink, f"MAVLINK_MSG_ID_{name}"), 1e6 / hz)

    def heartbeat(self) -> None:
        """A ground station's HEARTBEAT (type GCS, no autopilot, active)."""
        self.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                mavlink.MAV_STATE_ACTIVE)
