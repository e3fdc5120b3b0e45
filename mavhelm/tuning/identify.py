"""From a recording of the manoeuvre to the tuned settings and the report a user reads."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from mavhelm.tuning.gains import Course, Gains, Prediction, design
from mavhelm.tuning.model import (
    Series,
    SpeedModel,
    YawModel,
    fit_course_lag,
    fit_speed,
    fit_yaw,
)

TRUSTED_FIT_RMS = 8.0
"""Above this residual (deg/s) the turn-rate model is not trusted to choose gains, and the
defaults are kept. The real SITL motorboat fits within 4–6 deg/s and its tuned gains fly
about as predicted (0.13–0.25 m after a U-turn at 5 m/s against 0.10–0.11); the
motorboat-skid at 5 m/s leaves 11 (the samples placed when the autopilot took them: the
timing is not what is missing): it turns 1.3–1.45 times the rate Rover asks of it (its
dataflash log's STER: 87–97 deg/s where 67 was asked) until the autopilot's rate integrator
pulls it back over about a second, and the integral a survey's U-turn winds up turns it 2–3
deg/s the other way for 2 s after the turn. The fitted model has neither, so it predicted its
tuned gains 0.03–0.10 m after a U-turn where they flew 0.38–0.52 m, worse than the defaults
(0.23–0.45 m); a model with both, fitted from the same recording, still put them first (0.28
m, the defaults 0.99 m: ``benchmarks/bench_tracking.py``)."""

MAX_LATENCY = 1.0
"""A turn rate older than this when a command went out is a stall of the link, not the
loop's latency: it counts as this much."""

CRUISE_FRACTION = 0.8
"""The turn rate is fitted on the samples taken at this fraction of the cruise speed or more
(a boat turns faster when slow: the real SITL motorboat 81 deg/s at 1.3 m/s, 63 at 5)."""


@dataclass
class Recording:
    """What the helm sent and what came back, on the companion's clock (each turn rate
    placed when the autopilot took it, not when it was heard)."""

    turn_command: list[tuple[float, float]] = field(default_factory=list)
    """Turn rate sent to the autopilot, deg/s clockwise."""
    turn_rate: list[tuple[float, float]] = field(default_factory=list)
    """Turn rate reported by the autopilot, deg/s clockwise."""
    thrust_command: list[tuple[float, float]] = field(default_factory=list)
    """Thrust sent, % of full."""
    speed: list[tuple[float, float]] = field(default_factory=list)
    """Speed over the ground from the navigation (NAV_SPEED), m/s."""
    autopilot_speed: list[tuple[float, float]] = field(default_factory=list)
    """The autopilot's own speed estimate, m/s: used when the navigation has no speed."""
    heading: list[tuple[float, float]] = field(default_factory=list)
    """The navigation's heading (NAV_HEADING), degrees."""
    x: list[tuple[float, float]] = field(default_factory=list)
    """The navigation's position east (NAV_X), m."""
    y: list[tuple[float, float]] = field(default_factory=list)
    """The navigation's position north (NAV_Y), m."""
    turn_rate_age: list[tuple[float, float]] = field(default_factory=list)
    """(when heard, how late: INS_AGE) of each turn-rate sample, which ``turn_rate`` places
    that much earlier, when the autopilot took it."""

    def since(self, t0: float) -> Recording:
        """The samples from ``t0`` on (the response before the first command says nothing)."""
        def keep(s: list[tuple[float, float]]) -> list[tuple[float, float]]:
            return [p for p in s if p[0] >= t0]
        return Recording(keep(self.turn_command), keep(self.turn_rate),
                         keep(self.thrust_command), keep(self.speed),
                         keep(self.autopilot_speed), keep(self.heading), keep(self.x),
                         keep(self.y), keep(self.turn_rate_age))

    def latency(self) -> float:
        """How old the newest turn rate heard was, on average over the helm's commands, s:
        what the heading loop waits on besides the vehicle (0 without samples)."""
        commands = Series.of(self.turn_command).t
        heard = Series.of(self.turn_rate_age)
        if not len(heard) or not len(commands):
            return 0.0
        taken = np.maximum.accumulate(heard.t - heard.y)  # the newest taken, heard by then
        newest = np.searchsorted(heard.t, commands, side="right") - 1
        seen = newest >= 0
        ages = commands[seen] - taken[newest[seen]]
        return float(np.mean(np.clip(ages, 0.0, MAX_LATENCY))) if len(ages) else 0.0


@dataclass(frozen=True)
class Tuning:
    yaw: YawModel
    speed: SpeedModel
    gains: Gains
    prediction: Prediction
    cruise_thrust: float
    max_rudder: float
    baseline: Gains | None = None
    """The gains compared with (the product's defaults), None if none were given."""
    baseline_prediction: Prediction | None = None
    course_lag: float = 0.0
    """How far the track over the ground, as the navigation measures it, lags the heading, s."""
    trusted: bool = True
    """Whether the turn-rate model fitted well enough to choose gains (TRUSTED_FIT_RMS)."""

    def lead_for(self, thrust: float | None) -> float:
        """The Lead for a task at this Thrust (the manoeuvre's high thrust without one)."""
        return self.gains.lead(self.speed.speed_at(self.cruise_thrust if thrust is None
                                                   else abs(thrust)))

    def report(self) -> list[str]:
        y, s, g = self.yaw, self.speed, self.gains
        cruise = self.speed.speed_at(self.cruise_thrust)
        accel = ("none" if not math.isfinite(y.accel_limit)
                 else f"{y.accel_limit:.0f} deg/s²")
        lines = [
            f"turn rate: time constant {y.time_constant:.2f} s, delay {y.delay:.2f} s (and "
            f"{y.latency:.2f} s of telemetry age when steered on), "
            f"gain {y.gain:.2f}, limit {y.rate_limit:.1f} deg/s, acceleration limit {accel} "
            f"(fit RMS {y.rms:.2f} deg/s)",
            f"speed: {s.speed_at(100.0):.2f} m/s at full thrust, time constant "
            f"{s.time_constant:.2f} s, delay {s.delay:.2f} s (fit RMS {s.rms:.3f} m/s); the "
            f"track over the ground lags the heading by {self.course_lag:.2f} s",
            f"gains (heading loop {g.loop_gain:.2f} /s):",
            f"  pHelm    YAW_PID_KP = {g.yaw_kp:g}",
            f"  pHelm    YAW_PID_KD = {g.yaw_kd:g}",
            f"  pHelm    LINE_PID_KP = {g.line_kp:g} (the line tasks' loop, asking "
            f"{g.line_kp * g.max_turn_rate / self.max_rudder:.2f} deg/s per deg)",
            f"  pHelm    LINE_PID_KD = {g.line_kd:g}",
            f"  iMAVLink MaxTurnRate = {g.max_turn_rate:g}",
            f"  TrackLine/Survey Lead = {self.lead_for(None):g} "
            f"(LeadTime {g.lead_time:g} s at Thrust {self.cruise_thrust:g}, {cruise:.2f} m/s; "
            f"Lead scales with the task's speed)",
            f"predicted, these gains: {self.prediction.describe(cruise)}",
        ]
        b, bp = self.baseline, self.baseline_prediction
        if not self.trusted and (b is None or bp is None):
            lines.append(f"the turn-rate model leaves {y.rms:.1f} deg/s unexplained (more than "
                         f"{TRUSTED_FIT_RMS:g}): no defaults given to keep, these gains are "
                         f"not trusted")
        if b is not None and bp is not None:
            lines.append(f"predicted, the defaults (YAW_PID_KP {b.yaw_kp:g}, KD {b.yaw_kd:g}, "
                         f"LINE_PID_KP {b.line_kp:g}, KD {b.line_kd:g}, "
                         f"MaxTurnRate {b.max_turn_rate:g}, LeadTime {b.lead_time:g} s): "
                         f"{bp.describe(cruise)}")
            if not self.trusted:
                lines.append(f"the turn-rate model leaves {y.rms:.1f} deg/s unexplained (more "
                             f"than {TRUSTED_FIT_RMS:g}): its predictions are not trusted, "
                             f"the defaults kept")
            elif replace(g, loop_gain=0.0) == replace(b, loop_gain=0.0):
                lines.append("no gains predicted better than the defaults: the defaults kept")
        return lines


def identify(recording: Recording, *, max_rudder: float, app_tick: float,
             cruise_thrust: float, baseline: Gains | None = None,
             turn_lag: float = 0.5) -> Tuning:
    """Fit both models and design the gains, never predicted worse than ``baseline`` (kept
    when the turn-rate fit leaves more than TRUSTED_FIT_RMS unexplained), for lines flown at
    ``cruise_thrust`` by tasks that turn in ``turn_lag`` seconds early; raises ``FitError``
    if the data cannot."""
    starts = [t for t, _ in recording.turn_command + recording.thrust_command]
    data = recording.since(min(starts)) if starts else recording
    speeds = Series.of(data.speed or data.autopilot_speed)
    speed = fit_speed(Series.of(data.thrust_command), speeds)
    rates = Series.of(data.turn_rate)
    cruising = speeds.held(rates.t) >= CRUISE_FRACTION * speed.speed_at(cruise_thrust) \
        if len(speeds) else None
    yaw = replace(fit_yaw(Series.of(data.turn_command), rates, cruising),
                  latency=data.latency())
    cruise = speed.speed_at(cruise_thrust)
    lag = fit_course_lag(Series.of(data.heading), Series.of(data.x), Series.of(data.y),
                         CRUISE_FRACTION * cruise)
    course = Course(cruise, turn_lag, lag)
    trusted = yaw.rms <= TRUSTED_FIT_RMS
    gains, prediction, reference = design(yaw, max_rudder=max_rudder, app_tick=app_tick,
                                          course=course, baseline=baseline, search=trusted)
    return Tuning(yaw, speed, gains, prediction, cruise_thrust, max_rudder,
                  None if reference is None else baseline, reference, lag, trusted)

