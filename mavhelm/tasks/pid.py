"""The scalar PID every steering task uses (spec 1.4.1), and the helm-wide gains that feed it.

The controller is driven by the time stamps of the data it is given, not by a fixed rate:
navigation arrives irregularly, and a controller that assumed a fixed dt would integrate and
differentiate wrongly whenever a message is late or doubled.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from mavhelm.companion.mission import Block
from mavhelm.geo import wrap_degrees

FIR_TAPS = 5


class ScalarPID:
    """PID with an integral limit, an output limit and a 5-tap FIR on the derivative.

    ``angular=True`` wraps the error and its differences to (-180, 180] degrees, so a heading
    error that crosses north does not produce a 360° step and a derivative spike.
    """

    def __init__(
        self,
        kp: float,
        kd: float,
        ki: float,
        integral_limit: float,
        output_limit: float,
        *,
        angular: bool = False,
    ) -> None:
        if integral_limit < 0 or output_limit < 0:
            raise ValueError("PID limits must be non-negative")
        self.kp = kp
        self.kd = kd
        self.ki = ki
        self.integral_limit = integral_limit
        self.output_limit = output_limit
        self.angular = angular
        self.reset()

    def reset(self) -> None:
        """Forget history: called when a task (re)starts so it does not inherit stale state."""
        self._last_error: float | None = None
        self._last_time: float | None = None
        self._diffs: deque[float] = deque(maxlen=FIR_TAPS)
        self._sum = 0.0
        self.error = 0.0
        self.p = 0.0
        self.i = 0.0
        self.d = 0.0
        self.output = 0.0

    def run(self, error: float, t: float) -> float:
        """Feed the error observed at data time ``t``; return the clamped output.

        A sample whose time is not after the previous one (a repeated or out-of-order stamp)
        updates the proportional term only: there is no dt to integrate or differentiate over.
        """
        if self.angular:
            error = wrap_degrees(error)
        if self._last_time is not None and self._last_error is not None:
            dt = t - self._last_time
            if dt > 0:
                diff = error - self._last_error
                if self.angular:
                    diff = wrap_degrees(diff)
                self._diffs.append(diff / dt)
                self._sum += error * dt
                if self.ki != 0.0:
                    bound = self.integral_limit / abs(self.ki)
                    self._sum = max(-bound, min(bound, self._sum))
                self._last_time = t
                self._last_error = error
        else:
            self._last_time = t
            self._last_error = error
        self.error = error
        self.p = self.kp * error
        self.i = self.ki * self._sum
        self.d = self.kd * (sum(self._diffs) / len(self._diffs) if self._diffs else 0.0)
        out = self.p + self.i + self.d
        self.output = max(-self.output_limit, min(self.output_limit, out))
        return self.output

    def describe(self) -> str:
        """One line of the controller's internals, for LOGPID."""
        return (
            f"e={self.error:.3f},p={self.p:.3f},i={self.i:.3f},d={self.d:.3f},out={self.output:.3f}"
        )


_GAIN_KEYS = {
    "yaw_pid_kp": "yaw_kp",
    "yaw_pid_kd": "yaw_kd",
    "yaw_pid_ki": "yaw_ki",
    "yaw_pid_integral_limit": "yaw_integral_limit",
    "z_to_pitch_pid_kp": "z_to_pitch_kp",
    "z_to_pitch_pid_kd": "z_to_pitch_kd",
    "z_to_pitch_pid_ki": "z_to_pitch_ki",
    "z_to_pitch_pid_integral_limit": "z_to_pitch_integral_limit",
    "pitch_pid_kp": "pitch_kp",
    "pitch_pid_kd": "pitch_kd",
    "pitch_pid_ki": "pitch_ki",
    "pitch_pid_integral_limit": "pitch_integral_limit",
    "maxrudder": "max_rudder",
    "maxthrust": "max_thrust",
    "maxelevator": "max_elevator",
    "maxpitch": "max_pitch",
}
_GAIN_PREFIXES = ("yaw_pid_", "z_to_pitch_pid_", "pitch_pid_")


@dataclass
class HelmGains:
    """Controller gains and actuator limits from the pHelm block, shared by every task."""

    yaw_kp: float = 0.5
    yaw_kd: float = 0.2
    yaw_ki: float = 0.0
    yaw_integral_limit: float = 2.0
    z_to_pitch_kp: float = 0.5
    z_to_pitch_kd: float = 0.0
    z_to_pitch_ki: float = 0.0
    z_to_pitch_integral_limit: float = 0.0
    pitch_kp: float = 0.5
    pitch_kd: float = 0.0
    pitch_ki: float = 0.0
    pitch_integral_limit: float = 0.0
    max_rudder: float = 20.0
    max_thrust: float = 100.0
    max_elevator: float = 30.0
    max_pitch: float = 10.0

    @classmethod
    def from_block(cls, block: Block) -> HelmGains:
        """Read the gains; refuse negative values and misspelt gain keys.

        Other keys (AppTick, TaskFile, …) belong to other readers of the block and pass.
        """
        gains = cls()
        for entry in block.entries:
            key = entry.key.lower()
            attr = _GAIN_KEYS.get(key)
            if attr is None:
                if key.startswith(_GAIN_PREFIXES):
                    known = ", ".join(k.upper() for k in _GAIN_KEYS)
                    raise entry.error(f"unknown helm gain {entry.key!r} (known: {known})")
                continue
            value = entry.as_float()
            if value < 0:
                raise entry.error(f"{entry.key} must not be negative, got {entry.value}")
            if attr.startswith("max_") and value == 0:
                raise entry.error(f"{entry.key} must be positive, got {entry.value}")
            setattr(gains, attr, value)
        return gains

    def yaw_pid(self) -> ScalarPID:
        """A fresh heading controller: error in degrees, output rudder in degrees."""
        return ScalarPID(
            self.yaw_kp,
            self.yaw_kd,
            self.yaw_ki,
            self.yaw_integral_limit,
            self.max_rudder,
            angular=True,
        )
