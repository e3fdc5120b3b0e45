"""From a recording of the manoeuvre to the tuned settings and the report a user reads."""

from __future__ import annotations

from dataclasses import dataclass, field

from mavhelm.tuning.gains import Gains, Prediction, design, predict
from mavhelm.tuning.model import Series, SpeedModel, YawModel, fit_speed, fit_yaw


@dataclass
class Recording:
    """What the helm sent and what came back, on the companion's clock."""

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

    def since(self, t0: float) -> Recording:
        """The samples from ``t0`` on (the response before the first command says nothing)."""
        def keep(s: list[tuple[float, float]]) -> list[tuple[float, float]]:
            return [p for p in s if p[0] >= t0]
        return Recording(keep(self.turn_command), keep(self.turn_rate),
                         keep(self.thrust_command), keep(self.speed),
                         keep(self.autopilot_speed))


@dataclass(frozen=True)
class Tuning:
    yaw: YawModel
    speed: SpeedModel
    gains: Gains
    prediction: Prediction
    cruise_thrust: float
    max_rudder: float

    def lead_for(self, thrust: float | None) -> float:
        """The Lead for a task at this Thrust (the manoeuvre's high thrust without one)."""
        return self.gains.lead(self.speed.speed_at(self.cruise_thrust if thrust is None
                                                   else abs(thrust)))

    def report(self) -> list[str]:
        y, s, g, p = self.yaw, self.speed, self.gains, self.prediction
        cruise = self.speed.speed_at(self.cruise_thrust)
        lines = [
            f"turn rate: time constant {y.time_constant:.2f} s, delay {y.delay:.2f} s, "
            f"gain {y.gain:.2f}, limit {y.rate_limit:.1f} deg/s (fit RMS {y.rms:.2f} deg/s)",
            f"speed: {s.speed_at(100.0):.2f} m/s at full thrust, time constant "
            f"{s.time_constant:.2f} s, delay {s.delay:.2f} s (fit RMS {s.rms:.3f} m/s)",
            "gains:",
            f"  pHelm    YAW_PID_KP = {g.yaw_kp:g}",
            f"  pHelm    YAW_PID_KD = {g.yaw_kd:g}",
            f"  iMAVLink MaxTurnRate = {g.max_turn_rate:g}",
            f"  TrackLine/Survey Lead = {self.lead_for(None):g} "
            f"(at Thrust {self.cruise_thrust:g}, {cruise:.2f} m/s; "
            f"Lead scales with the task's speed)",
            f"predicted: a {30:g} deg heading step settles within 1 deg in "
            f"{p.heading_settle:.1f} s (overshoot {p.heading_overshoot:.1f} deg)",
        ]
        if p.line_settle is not None:
            lines.append(f"predicted: 2 m off a line at {cruise:.2f} m/s settles within "
                         f"0.1 m in {p.line_settle:.1f} s")
        return lines


def identify(recording: Recording, *, max_rudder: float, app_tick: float,
             cruise_thrust: float) -> Tuning:
    """Fit both models and design the gains; raises ``FitError`` if the data cannot."""
    starts = [t for t, _ in recording.turn_command + recording.thrust_command]
    data = recording.since(min(starts)) if starts else recording
    yaw = fit_yaw(Series.of(data.turn_command), Series.of(data.turn_rate))
    speed = fit_speed(Series.of(data.thrust_command),
                      Series.of(data.speed or data.autopilot_speed))
    gains = design(yaw, max_rudder=max_rudder, app_tick=app_tick)
    prediction = predict(gains, yaw, speed.speed_at(cruise_thrust), max_rudder=max_rudder,
                         app_tick=app_tick)
    return Tuning(yaw, speed, gains, prediction, cruise_thrust, max_rudder)

