"""Auxiliary actuators (a winch, a sampler, lights) on the autopilot's free servo outputs.

A task votes on a named actuator (``DESIRED_WINCH``, in percent, -100…100) like on the rudder;
the mission maps the name to a servo output and its PWM range (``Servo = WINCH@9:1100-1900``
in iMAVLink), and the winning vote goes out as MAV_CMD_DO_SET_SERVO: at once when it changes,
and again every ``REFRESH_S`` so a rebooted autopilot or a lost packet is corrected. An output
ArduPilot refuses (it already drives a motor: "Channel N is already in use") is reported once.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.core.mission import Entry
from mavhelm.core.params import Kind

REFRESH_S = 2.0
PWM_LIMITS = (500, 2500)


@dataclass(frozen=True)
class Servo:
    """One named actuator on one servo output."""

    name: str
    channel: int
    pwm_min: int
    pwm_max: int

    def pwm(self, percent: float) -> int:
        """-100 % → pwm_min, 0 → the middle, +100 % → pwm_max."""
        fraction = (max(-100.0, min(100.0, percent)) + 100.0) / 200.0
        return int(round(self.pwm_min + fraction * (self.pwm_max - self.pwm_min)))


class ServoSpec(Kind):
    """``NAME@channel:min-max``: an actuator name, a servo output 1–16, a PWM range."""

    def describe(self) -> str:
        return (f"NAME@output:min-max, output 1-16, PWM in [{PWM_LIMITS[0]}, "
                f"{PWM_LIMITS[1]}], min < max")

    def parse(self, entry: Entry) -> Servo:
        text = entry.value.replace(" ", "")
        name, at, rest = text.partition("@")
        channel_text, colon, span = rest.partition(":")
        low, dash, high = span.partition("-")
        try:
            if not (at and colon and dash and name.isidentifier()):
                raise ValueError
            channel, pwm_min, pwm_max = int(channel_text), int(low), int(high)
        except ValueError:
            raise entry.error(f"{entry.key} expects {self.describe()}, e.g. WINCH@9:1100-1900,"
                              f" got {entry.value.strip()!r}") from None
        if not 1 <= channel <= 16:
            raise entry.error(f"{entry.key} {name}: output must be 1-16, got {channel}")
        if not PWM_LIMITS[0] <= pwm_min < pwm_max <= PWM_LIMITS[1]:
            raise entry.error(f"{entry.key} {name}: PWM range must be min < max within "
                              f"[{PWM_LIMITS[0]}, {PWM_LIMITS[1]}], got {pwm_min}-{pwm_max}")
        return Servo(name.upper(), channel, pwm_min, pwm_max)


@dataclass
class ServoOutputs:
    servos: tuple[Servo, ...]
    target_system: int = 1
    target_component: int = 1
    sent: dict[str, tuple[int, float]] = field(default_factory=dict)
    """name → (PWM, time) of the last DO_SET_SERVO."""
    refused: set[int] = field(default_factory=set)
    _awaiting_ack: deque[int] = field(default_factory=deque)

    def variables(self) -> set[str]:
        return {f"DESIRED_{s.name}" for s in self.servos}

    def update(self, mav: mavlink.MAVLink, desired: dict[str, float],
               now: float) -> list[tuple[Servo, int]]:
        """Send what changed or is due for a refresh; return (servo, PWM) sent."""
        out = []
        for servo in self.servos:
            value = desired.get(f"DESIRED_{servo.name}")
            if value is None or not math.isfinite(value):
                continue
            pwm = servo.pwm(value)
            last = self.sent.get(servo.name)
            if last is not None and last[0] == pwm and now - last[1] < REFRESH_S:
                continue
            mav.command_long_send(self.target_system, self.target_component,
                                  mavlink.MAV_CMD_DO_SET_SERVO, 0, servo.channel, pwm,
                                  0, 0, 0, 0, 0)
            self._awaiting_ack.append(servo.channel)
            while len(self._awaiting_ack) > 32:
                self._awaiting_ack.popleft()
            self.sent[servo.name] = (pwm, now)
            out.append((servo, pwm))
        return out

    def acknowledged(self, result: int) -> str | None:
        """A COMMAND_ACK for DO_SET_SERVO (they come in order); a report the first time an
        output is refused."""
        if not self._awaiting_ack:
            return None
        channel = self._awaiting_ack.popleft()
        if result == mavlink.MAV_RESULT_ACCEPTED or channel in self.refused:
            return None
        self.refused.add(channel)
        names = ", ".join(s.name for s in self.servos if s.channel == channel)
        return (f"servo output {channel} ({names}) refused by the autopilot (result {result}):"
                f" it already drives something (SERVO{channel}_FUNCTION); choose a free output")
