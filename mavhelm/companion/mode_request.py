"""Asking ArduPilot for a flight mode: DO_SET_MODE, confirmed only by the HEARTBEAT.

A COMMAND_ACK ACCEPTED is not proof that the vehicle is in the mode (a later failsafe or the
operator may change it again), and a lost command gets no ACK at all; so the request is sent,
re-sent every ``retry_s`` up to ``tries`` times, and done only when a HEARTBEAT shows the mode.
An ACK that refuses ends it at once (an operator's console: asking again will not help), or,
with ``retry_refused``, is remembered while the tries go on (a hand-back: ArduPilot refuses
a mode while a check fails, and the check may pass a second later). Pure logic, no I/O: the caller
sends ``message()`` when ``step`` says SEND and reports what it hears.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass, field

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

ROVER_MODES: dict[int, str] = dict(mavutil.mode_mapping_rover)
"""Rover's custom_mode number → mode name."""
ROVER_MODE_NUMBERS: dict[str, int] = {name: number for number, name in ROVER_MODES.items()}
SUB_MODES: dict[int, str] = dict(mavutil.mode_mapping_sub)
"""ArduSub's custom_mode number → mode name (GUIDED 4, ALT_HOLD 2, SURFACE 9, MANUAL 19)."""
SUB_MODE_NUMBERS: dict[str, int] = {name: number for number, name in SUB_MODES.items()}

VEHICLE_MODES: dict[int, dict[int, str]] = {mavlink.MAV_TYPE_SUBMARINE: SUB_MODES}
"""HEARTBEAT type → that firmware's mode table; every other type is read as Rover (boats
report MAV_TYPE_SURFACE_BOAT, rovers MAV_TYPE_GROUND_ROVER)."""
ALL_MODE_NAMES: tuple[str, ...] = tuple(dict.fromkeys([*ROVER_MODE_NUMBERS, *SUB_MODE_NUMBERS]))
"""Every mode name a mission may write (OnlineModes), whichever vehicle it runs on."""


def modes_for(mav_type: int | None) -> dict[int, str]:
    """The mode table of the firmware that sent a HEARTBEAT of this type."""
    return VEHICLE_MODES.get(mav_type, ROVER_MODES) if mav_type is not None else ROVER_MODES


def mode_numbers_for(mav_type: int | None) -> dict[str, int]:
    """Mode name → custom_mode number for this HEARTBEAT type."""
    return {name: number for number, name in modes_for(mav_type).items()}


class Step(enum.Enum):
    SEND = "send"
    """Send ``message()`` now (one more try has been counted)."""
    WAIT = "wait"
    """Nothing to do this time."""
    CONFIRMED = "confirmed"
    """A HEARTBEAT has shown the mode."""
    FAILED = "failed"
    """Given up: ``why()`` says why."""


@dataclass
class ModeRequest:
    """One mode asked of the autopilot; ``tries`` DO_SET_MODE commands, ``retry_s`` apart."""

    mode: str
    tries: int = 3
    retry_s: float = 1.0
    sent: int = 0
    next_at: float = -math.inf
    refused: int | None = None
    """The MAV_RESULT of a refusing COMMAND_ACK."""
    confirmed: bool = False
    failed: bool = False
    retry_refused: bool = False
    numbers: dict[str, int] = field(default_factory=lambda: ROVER_MODE_NUMBERS)
    """The vehicle's mode table (``mode_numbers_for`` its HEARTBEAT type); Rover's by default."""
    number: int = field(init=False)

    def __post_init__(self) -> None:
        if self.mode not in self.numbers:
            raise ValueError(f"{self.mode!r} is not a mode of this vehicle (its modes: "
                             f"{', '.join(self.numbers)})")
        if self.tries < 1 or not (math.isfinite(self.retry_s) and self.retry_s > 0):
            raise ValueError("a mode request needs at least one try and a finite retry_s > 0")
        self.number = self.numbers[self.mode]

    def step(self, now: float) -> Step:
        """What to do at ``now``: send (counted as a try), wait, or the outcome."""
        if self.confirmed:
            return Step.CONFIRMED
        if self.failed or (self.refused is not None and not self.retry_refused):
            self.failed = True
            return Step.FAILED
        if now < self.next_at:
            return Step.WAIT
        if self.sent >= self.tries:
            self.failed = True
            return Step.FAILED
        self.sent += 1
        self.next_at = now + self.retry_s
        return Step.SEND

    @property
    def done(self) -> bool:
        """Confirmed or failed: settled, nothing more will be sent."""
        return self.confirmed or self.failed

    def heartbeat(self, mode: str | None) -> bool:
        """The autopilot's HEARTBEAT shows ``mode``; True the first time it is the one asked
        (also after a refusal while still trying: the mode was taken after all)."""
        if self.done or mode != self.mode:
            return False
        self.confirmed = True
        return True

    def acknowledged(self, result: int) -> None:
        """A COMMAND_ACK for DO_SET_MODE; a refusal ends the request."""
        if result != mavlink.MAV_RESULT_ACCEPTED and not self.confirmed:
            self.refused = result

    def why(self) -> str:
        """The reason of a failure, for the operator."""
        if self.refused is not None:
            return f"DO_SET_MODE refused, result {self.refused}"
        return f"no HEARTBEAT in {self.mode} after {self.sent} requests"

    def message(self, target_system: int, target_component: int
                ) -> mavlink.MAVLink_command_long_message:
        """The DO_SET_MODE command to send."""
        return mavlink.MAVLink_command_long_message(
            target_system, target_component, mavlink.MAV_CMD_DO_SET_MODE, 0,
            mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, self.number, 0, 0, 0, 0, 0)
