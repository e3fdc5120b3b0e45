"""The scalar PID every steering task uses (spec 1.4.1), and the helm-wide gains that feed it.

The controller is driven by the time stamps of the data it is given, not by a fixed rate:
navigation arrives irregularly, and a controller that assumed a fixed dt would integrate and
differentiate wrongly whenever a message is late or doubled.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass, replace

from mavhelm.core.geodesy import wrap_degrees
from mavhelm.core.params import Number, Param

FIR_TAPS = 5
MIN_DT = 0.01
"""Samples closer than this (s) are one instant to the derivative and the integral. Two
values of one quantity can be stamped microseconds apart (an autopilot clock that moves
between two messages handled in one read): a heading that differs by 0.1° over 10 µs is a
derivative of 10 000 °/s, which the 5-tap FIR held at full rudder for half a second (on the
real SITL motorboat, a 1.5 m swing mid-leg)."""


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

        A sample whose time is not at least ``MIN_DT`` after the previous one (a repeated,
        out-of-order or near-simultaneous stamp) updates the proportional term only: there is
        no dt to integrate or differentiate over.
        """
        if self.angular:
            error = wrap_degrees(error)
        if self._last_time is not None and self._last_error is not None:
            dt = t - self._last_time
            if dt >= MIN_DT:
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


GAIN = Number(0.0, 1000.0)
"""A PID gain or integral limit: finite and not negative (a negative gain steers away)."""
ANGLE_LIMIT = Number(0.0, 90.0, lo_open=True)
"""An actuator or attitude limit in degrees: positive, at most a right angle."""


def _pid_params(prefix: str, attr: str, what: str, defaults: tuple[float, ...]) -> list[Param]:
    kp, kd, ki, limit = defaults
    return [
        Param(f"{prefix}_PID_KP", GAIN, kp, doc=f"{what}: proportional gain",
              attr=f"{attr}_kp"),
        Param(f"{prefix}_PID_KD", GAIN, kd, doc=f"{what}: derivative gain", attr=f"{attr}_kd"),
        Param(f"{prefix}_PID_KI", GAIN, ki, doc=f"{what}: integral gain", attr=f"{attr}_ki"),
        Param(f"{prefix}_PID_INTEGRAL_LIMIT", GAIN, limit,
              doc=f"{what}: bound on the integral term's output", attr=f"{attr}_integral_limit"),
    ]


GAIN_PARAMS: tuple[Param, ...] = (
    *_pid_params("YAW", "yaw", "heading controller (deg of rudder per deg of error)",
                 (0.75, 0.2, 0.0, 2.0)),
    *_pid_params("LINE", "line", "heading controller of the tasks that hold a line: TrackLine, "
                 "Survey, XYPattern, Orbit (deg of rudder per deg of error; a block that sets "
                 "YAW_PID_* and no LINE_PID_* steers its lines on its YAW_PID_*)",
                 (1.0, 0.0, 0.0, 2.0)),
    *_pid_params("Z_TO_PITCH", "z_to_pitch", "depth-to-pitch controller", (0.5, 0.0, 0.0, 0.0)),
    *_pid_params("PITCH", "pitch", "pitch-to-elevator controller", (0.5, 0.0, 0.0, 0.0)),
    Param("MAXRUDDER", ANGLE_LIMIT, 20.0, "deg", "rudder limit; full rudder = MaxTurnRate",
          attr="max_rudder"),
    Param("MAXTHRUST", Number(0.0, 100.0, lo_open=True), 100.0, "%", "thrust limit",
          attr="max_thrust"),
    Param("MAXELEVATOR", ANGLE_LIMIT, 30.0, "deg", "elevator limit", attr="max_elevator"),
    Param("MAXPITCH", ANGLE_LIMIT, 10.0, "deg", "pitch limit of the depth controller",
          attr="max_pitch"),
)
"""The pHelm block's controller settings, shared by every task (one ``HelmGains``)."""


def follows_yaw(given: Iterable[str]) -> bool:
    """Whether a pHelm block that sets these names keeps its lines on YAW_PID: it sets some
    YAW_PID_* and no LINE_PID_*."""
    names = {name.upper() for name in given}
    return any(n.startswith("YAW_PID_") for n in names) and \
        not any(n.startswith("LINE_PID_") for n in names)


def _default(attr: str) -> float:
    """The declared default of one of ``GAIN_PARAMS`` (by attribute), so it is said once."""
    return float(next(p.default for p in GAIN_PARAMS if p.attribute == attr))


@dataclass
class HelmGains:
    """Controller gains and actuator limits from the pHelm block, shared by every task."""

    yaw_kp: float = _default("yaw_kp")
    yaw_kd: float = _default("yaw_kd")
    yaw_ki: float = _default("yaw_ki")
    yaw_integral_limit: float = _default("yaw_integral_limit")
    line_kp: float = _default("line_kp")
    line_kd: float = _default("line_kd")
    line_ki: float = _default("line_ki")
    line_integral_limit: float = _default("line_integral_limit")
    z_to_pitch_kp: float = _default("z_to_pitch_kp")
    z_to_pitch_kd: float = _default("z_to_pitch_kd")
    z_to_pitch_ki: float = _default("z_to_pitch_ki")
    z_to_pitch_integral_limit: float = _default("z_to_pitch_integral_limit")
    pitch_kp: float = _default("pitch_kp")
    pitch_kd: float = _default("pitch_kd")
    pitch_ki: float = _default("pitch_ki")
    pitch_integral_limit: float = _default("pitch_integral_limit")
    max_rudder: float = _default("max_rudder")
    max_thrust: float = _default("max_thrust")
    max_elevator: float = _default("max_elevator")
    max_pitch: float = _default("max_pitch")

    @classmethod
    def from_values(cls, values: dict[str, object], given: Iterable[str] = ()) -> HelmGains:
        """From a pHelm block read by a schema holding ``GAIN_PARAMS`` (other keys ignored).
        ``given``: the names the block itself sets. A block that sets YAW_PID_* and no
        LINE_PID_* (a MOOS mission, whose pHelm has the one heading loop) keeps its lines on
        its YAW_PID: gains tuned on a vehicle are not swapped for defaults measured on another
        (``lines_follow_yaw``)."""
        gains = cls(**{p.attribute: float(values[p.attribute])  # type: ignore[arg-type]
                       for p in GAIN_PARAMS})
        return gains.lines_follow_yaw() if follows_yaw(given) else gains

    def lines_follow_yaw(self) -> HelmGains:
        """These gains with the line loop the heading loop (``LINE_PID_*`` = ``YAW_PID_*``)."""
        return replace(self, line_kp=self.yaw_kp, line_kd=self.yaw_kd, line_ki=self.yaw_ki,
                       line_integral_limit=self.yaw_integral_limit)

    def yaw_pid(self) -> ScalarPID:
        """A fresh heading controller: error in degrees, output rudder in degrees."""
        return ScalarPID(self.yaw_kp, self.yaw_kd, self.yaw_ki, self.yaw_integral_limit,
                         self.max_rudder, angular=True)

    def line_pid(self) -> ScalarPID:
        """A fresh heading controller for a task that holds a line (``LINE_PID_*``).

        A line's own loop (cross-track error to desired heading, ``trackline``) sits outside
        this one and wants it stiff and without the derivative: on the real SITL, KP 1.0 and
        KD 0 (Kψ 4.5 /s at the defaults' MaxTurnRate 90, MAXRUDDER 20) held every model's
        lines best at 5 m/s, where the heading tasks' KP 0.75, KD 0.2 swung the skid boat
        0.8–0.9 m on a leg in the stock wind; for a 30° heading step the same gains overshoot
        13–23° (``benchmarks/bench_heading_step.py``), so heading tasks keep ``YAW_PID_*``."""
        return ScalarPID(self.line_kp, self.line_kd, self.line_ki, self.line_integral_limit,
                         self.max_rudder, angular=True)

    def depth_pid(self, *, reversing: bool = False) -> DepthByPitch:
        """A fresh depth controller (spec 1.4.2): depth error in metres, elevator in degrees."""
        return DepthByPitch(
            ScalarPID(self.z_to_pitch_kp, self.z_to_pitch_kd, self.z_to_pitch_ki,
                      self.z_to_pitch_integral_limit, self.max_pitch),
            ScalarPID(self.pitch_kp, self.pitch_kd, self.pitch_ki,
                      self.pitch_integral_limit, self.max_elevator),
            reversing=reversing,
        )


class DepthByPitch:
    """Depth through pitch (spec 1.4.2, Figure 3): an outer PID turns the error in Z into a
    desired pitch (limited by MAXPITCH), an inner PID turns the pitch error into elevator
    (limited by MAXELEVATOR).

    Signs as the original's CPitchZPID: Z is up, so a depth error (desired − current, positive
    when too shallow) is a negative Z error; positive pitch is nose up; positive elevator dives
    (it pitches the nose down). ``reversing`` (a reverse dive, driven astern) flips both the
    Z error and the elevator, since the control surfaces act the other way round.
    """

    def __init__(self, z_pid: ScalarPID, pitch_pid: ScalarPID, *, reversing: bool = False
                 ) -> None:
        self.z_pid = z_pid
        self.pitch_pid = pitch_pid
        self.reversing = reversing
        self.desired_pitch = 0.0
        """Degrees, nose up: the outer loop's output (what the original posts DESIRED_PITCH)."""

    def reset(self) -> None:
        self.z_pid.reset()
        self.pitch_pid.reset()
        self.desired_pitch = 0.0

    def run(self, depth_error: float, depth_time: float, pitch: float, pitch_time: float
            ) -> float:
        """Elevator (degrees, positive dives) for ``depth_error`` (m, desired − current depth)
        seen at ``depth_time`` and the vehicle's ``pitch`` (degrees, nose up) at
        ``pitch_time``."""
        z_error = -depth_error
        if self.reversing:
            z_error = -z_error
        self.desired_pitch = self.z_pid.run(z_error, depth_time)
        out = self.pitch_pid.run(self.desired_pitch - pitch, pitch_time)
        return out if self.reversing else -out

    def describe(self) -> str:
        """Both loops' internals, for LOGPID."""
        return f"z:{self.z_pid.describe()};pitch:{self.pitch_pid.describe()}"
