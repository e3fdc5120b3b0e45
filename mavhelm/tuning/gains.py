"""The gains that suit a fitted vehicle, and how fast they are predicted to settle.

The heading loop (spec 1.4.1) is a PD on the heading error whose rudder becomes a commanded
turn rate (full rudder = ``MaxTurnRate``). With the fitted turn-rate model (lag τ, delay d,
limit r_max):

- ``MaxTurnRate`` = r_max / K: full rudder asks for the fastest turn the vehicle makes, so
  every degree of rudder below that is a turn it can follow;
- ``YAW_PID_KD`` = KP·τ puts the PD's zero on the rate lag, leaving the loop an integrator
  with a delay, Kψ·e^(−sd)/s (Kψ = KP·MaxTurnRate/MAXRUDDER, per second); at most
  ``KD_MAX_RATIO``·KP;
- Kψ for a 60° phase margin, (π/6)/d, with d the fitted delay plus one helm tick (the
  command waits for the next tick, and the fit's delay is only as fine as a tick), and no
  more than ``KPSI_MAX``;
- the TrackLine/Survey ``Lead`` for a cross-track damping ζ = 0.9 at the task's speed
  (``mavhelm.tasks.trackline``: ζ = ½·√(Kψ·Lead/V)), plus the distance run during the
  loop's lag and delay.

The settling times are predicted by simulating these loops on the model (numerically, with
the rudder and turn-rate limits), not read off a formula.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

from mavhelm.tuning.model import YawModel

KPSI_MAX = 2.5
"""Fastest heading loop proposed, 1/s. On the real SITL motorboat a tune that fitted a 0.1 s
delay and proposed 3.5 /s (with KD 0.8 × KP) swung ±3.6 m after turns; 2.1–2.6 /s held
0.04 m RMS."""
PHASE_MARGIN = math.pi / 6.0
"""Phase margin kept in the heading loop: 60°, lightly damped at most."""
ZETA = 0.9
"""Damping of the cross-track loop the Lead is chosen for."""
MIN_LEAD = 1.0
KD_MAX_RATIO = 0.6
"""KD at most this many times KP: the helm's derivative is a 5-tap average of heading
differences, itself two ticks late, so a longer one adds lag rather than cancelling it."""
HEADING_STEP = 30.0
HEADING_TOLERANCE = 1.0
LINE_OFFSET = 2.0
LINE_TOLERANCE = 0.1


@dataclass(frozen=True)
class Gains:
    yaw_kp: float
    yaw_kd: float
    max_turn_rate: float
    loop_gain: float
    """Kψ, 1/s: degrees per second of turn per degree of heading error."""
    delay: float
    """Delay the loop was designed for, s (fitted delay plus one helm tick)."""

    def lead(self, speed: float) -> float:
        """The TrackLine/Survey Lead (m) for a task run at ``speed`` (m/s)."""
        v = max(speed, 0.1)
        return max(MIN_LEAD, round(v * ((2.0 * ZETA) ** 2 / self.loop_gain + self.delay), 1))


def design(yaw: YawModel, *, max_rudder: float, app_tick: float) -> Gains:
    """The heading-loop gains and MaxTurnRate for this vehicle under this helm."""
    max_turn_rate = max(5.0, min(180.0, round(yaw.rate_limit / max(yaw.gain, 1e-3))))
    delay = yaw.delay + 1.0 / app_tick
    kpsi = min(KPSI_MAX, PHASE_MARGIN / max(delay, 1e-3))
    loop_per_rudder = yaw.gain * max_turn_rate / max_rudder
    kp = kpsi / loop_per_rudder
    kd = min(KD_MAX_RATIO * kp, kp * yaw.time_constant)
    return Gains(round(kp, 3), round(kd, 3), float(max_turn_rate), kpsi, delay)


@dataclass(frozen=True)
class Prediction:
    heading_settle: float
    """Seconds for a 30° heading step to stay within 1°."""
    heading_overshoot: float
    """Degrees past the new heading."""
    line_settle: float | None
    """Seconds for a 2 m offset from a line to stay within 0.1 m (None: no speed)."""


def _settle_time(t: list[float], err: list[float], tol: float) -> float:
    for i in range(len(err) - 1, -1, -1):
        if abs(err[i]) > tol:
            return t[min(i + 1, len(t) - 1)]
    return 0.0


@dataclass
class _Loop:
    """The simulated heading loop's state."""

    psi: float = 0.0
    rate: float = 0.0
    command: float = 0.0
    last_err: float = 0.0
    ticks: int = 0
    next_tick: float = 0.0
    queue: list[tuple[float, float]] = field(default_factory=list)
    """Commands in flight: (time they take effect, turn rate)."""


def _heading_loop(gains: Gains, yaw: YawModel, max_rudder: float,
                  app_tick: float) -> Callable[[float, _Loop, float, float], None]:
    """A closure stepping the heading loop: (desired heading, state, t, dt)."""
    per_rudder = gains.max_turn_rate / max_rudder
    period = 1.0 / app_tick

    def step(desired: float, s: _Loop, t: float, dt: float) -> None:
        if t >= s.next_tick:
            err = desired - s.psi
            d_err = (err - s.last_err) / period if s.ticks else 0.0
            s.last_err, s.ticks = err, s.ticks + 1
            rudder = max(-max_rudder, min(max_rudder, gains.yaw_kp * err + gains.yaw_kd * d_err))
            s.queue.append((t + yaw.delay, rudder * per_rudder))
            s.next_tick += period
        while s.queue and s.queue[0][0] <= t:
            s.command = s.queue.pop(0)[1]
        target = max(-yaw.rate_limit, min(yaw.rate_limit, yaw.gain * s.command))
        s.rate += (target - s.rate) * (1.0 - math.exp(-dt / yaw.time_constant))
        s.psi += s.rate * dt

    return step


def predict(gains: Gains, yaw: YawModel, speed: float | None, *, max_rudder: float,
            app_tick: float, horizon: float = 40.0, dt: float = 0.01) -> Prediction:
    """Simulate a heading step and, at ``speed``, the capture of a line from 2 m off it."""
    step = _heading_loop(gains, yaw, max_rudder, app_tick)
    state, ts, errs = _Loop(), [], []
    for i in range(int(horizon / dt)):
        step(HEADING_STEP, state, i * dt, dt)
        ts.append(i * dt)
        errs.append(HEADING_STEP - state.psi)
    heading_settle = _settle_time(ts, errs, HEADING_TOLERANCE)
    overshoot = max(0.0, -min(errs))
    line = None
    if speed is not None and speed > 0.05:
        lead = gains.lead(speed)
        state, ts, xs = _Loop(), [], []
        y = LINE_OFFSET
        for i in range(int(horizon / dt)):
            step(-math.degrees(math.atan(y / lead)), state, i * dt, dt)
            y += speed * math.sin(math.radians(state.psi)) * dt
            ts.append(i * dt)
            xs.append(y)
        line = _settle_time(ts, xs, LINE_TOLERANCE)
    return Prediction(heading_settle, overshoot, line)
