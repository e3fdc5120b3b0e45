"""The vehicle's response, fitted from what the helm sent and what the autopilot reported.

Two first-order-plus-delay models, the simplest that predict what the heading loop and the
line follower need:

- turn rate:  τ·r' = sat(K·u(t − d), ±r_max) − r, with |r'| ≤ a_max   (u: the commanded turn
  rate, deg/s). The acceleration limit is the autopilot's (Rover's ATC_STR_ACC_MAX): on the
  real SITL motorboat the turn rate ramps at about 110 deg/s² from one limit to the other, which
  a lag alone fits with 11 deg/s of residual and a delay too short to design a loop on;
- speed:      τv·v' = Kv·T(t − dv) − v             (T: the commanded thrust, %).

They are fitted by simulating the model over the recorded command and matching the recorded
response (``scipy.optimize.least_squares``), so steps, zig-zags and saturation all count.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

MIN_SAMPLES = 20
"""Fewer samples than this (2 s at 10 Hz) cannot tell a time constant from a delay."""


class FitError(ValueError):
    """The recording cannot identify the model (too short, no excitation, no response)."""


@dataclass(frozen=True)
class Series:
    """A signal sampled at irregular times (seconds, increasing)."""

    t: np.ndarray
    y: np.ndarray

    @classmethod
    def of(cls, samples: Sequence[tuple[float, float]]) -> Series:
        clean = sorted((t, y) for t, y in samples if math.isfinite(t) and math.isfinite(y))
        arr = np.array(clean, dtype=float).reshape(-1, 2)
        return cls(arr[:, 0], arr[:, 1])

    def __len__(self) -> int:
        return len(self.t)

    def held(self, at: np.ndarray) -> np.ndarray:
        """The value in force at each of ``at`` (a command holds until the next one)."""
        idx = np.searchsorted(self.t, at, side="right") - 1
        return np.where(idx >= 0, self.y[np.clip(idx, 0, None)], 0.0)


@dataclass(frozen=True)
class YawModel:
    gain: float
    """K: turn rate delivered per unit of turn rate commanded (1 = as commanded)."""
    time_constant: float
    """τ, seconds."""
    delay: float
    """d, seconds: from the helm's command to the first response in the telemetry."""
    rate_limit: float
    """r_max, deg/s: the fastest the vehicle turned."""
    rms: float
    """RMS of the fit's residual, deg/s."""
    accel_limit: float = math.inf
    """a_max, deg/s²: the fastest the turn rate changes."""
    latency: float = 0.0
    """How old, on average, the newest turn rate (and heading) is when the helm steers on it,
    s: the telemetry's batches and the ticks between them. The fit, on samples placed when
    the autopilot took them, no longer counts it in ``delay``; the heading loop has both."""

    @property
    def loop_delay(self) -> float:
        """From the helm's command to its seeing the response, s."""
        return self.delay + self.latency


@dataclass(frozen=True)
class SpeedModel:
    gain: float
    """Kv, m/s per % thrust (speed at full thrust / 100)."""
    time_constant: float
    delay: float
    rms: float

    def speed_at(self, thrust: float) -> float:
        return self.gain * thrust


def simulate_lag(command: Series, t: np.ndarray, gain: float, tau: float, delay: float,
                 limit: float = math.inf, start: float = 0.0,
                 accel: float = math.inf) -> np.ndarray:
    """The first-order-plus-delay response at times ``t`` to a held ``command``; the
    exact discretisation of each interval (a held input), so uneven sampling is fine, then
    each interval's change bounded by ``accel`` (per second)."""
    u = np.clip(gain * command.held(t - delay), -limit, limit)
    out = np.empty_like(t)
    y = start
    for i in range(len(t)):
        if i:
            dt = t[i] - t[i - 1]
            step = (1.0 - math.exp(-dt / tau)) * (u[i - 1] - y)
            if math.isfinite(accel):
                step = max(-accel * dt, min(accel * dt, step))
            y += step
        out[i] = y
    return out


def _check(command: Series, response: Series, what: str) -> None:
    if len(response) < MIN_SAMPLES or len(command) < 2:
        raise FitError(f"{what}: {len(response)} samples of the response, {len(command)} of "
                       f"the command: too short a recording to fit")
    if float(np.ptp(command.y)) <= 1e-6:
        raise FitError(f"{what}: the command never changed, nothing to identify")


DELAYS = np.arange(0.0, 1.5001, 0.05)
"""The delays tried, s: the residual is flat between command samples, so a delay is searched,
not descended (0.05 s is half a helm tick at 10 Hz)."""


def _best_delay(fit_at):
    """(delay, fit) of the delay whose fit leaves the least residual."""
    fits = [(float(d), fit_at(float(d))) for d in DELAYS]
    return min(fits, key=lambda df: float(df[1].cost))


ACCEL_GUESS = 200.0
"""The scale of a turn-rate acceleration limit, deg/s²."""
ACCEL_MAX = 5000.0
"""A fitted acceleration limit this high is none (the lag alone sets the response)."""
GAIN_RANGE = (0.5, 1.2)
"""The turn-rate gain K the fit may find: an autopilot's rate controller (with its integral)
delivers about the rate it is asked for, and a manoeuvre whose commands mostly saturate the
vehicle barely shows K, so an unbounded fit wandered (K 1.5–2.3 on the real SITL, and the loop
designed on it flew at half its intended gain, swinging 1–2 m after every turn)."""
YAW_STARTS = ((0.1, 100.0), (0.5, 0.5 * ACCEL_MAX))
"""Where the turn-rate fit starts (τ s, a_max deg/s²): a slewing and a lagging vehicle (the
clipped residual has a local minimum between them)."""


def fit_yaw(command: Series, response: Series, counted: np.ndarray | None = None) -> YawModel:
    """Fit τ, d, K, r_max and a_max to the turn rate (deg/s, clockwise) commanded and observed.
    ``counted`` (a mask over the response's samples) keeps the fit to those samples: a boat
    turns faster slowly than at its cruise speed, and the loop is designed for the cruise."""
    _check(command, response, "turn rate")
    t, r = response.t, response.y
    mask = np.ones(len(r), dtype=bool) if counted is None or int(np.sum(counted)) < MIN_SAMPLES \
        else np.asarray(counted, dtype=bool)
    peak = float(np.max(np.abs(r[mask])))
    if peak < 1.0:
        raise FitError(f"turn rate: the vehicle never turned faster than {peak:.2f} deg/s")

    def fit_at(delay: float):
        def residual(p: np.ndarray) -> np.ndarray:
            return (simulate_lag(command, t, p[0], p[1], delay, p[2], start=r[0],
                                 accel=p[3]) - r)[mask]
        fits = [least_squares(residual, np.array([1.0, tau, peak * 1.05, accel]),
                              bounds=([GAIN_RANGE[0], 0.02, 0.5, 5.0],
                                      [GAIN_RANGE[1], 20.0, 720.0, ACCEL_MAX]),
                              x_scale=[1.0, 1.0, peak, ACCEL_GUESS])
                for tau, accel in YAW_STARTS]
        return min(fits, key=lambda f: float(f.cost))

    delay, fit = _best_delay(fit_at)
    gain, tau, limit, accel = (float(v) for v in fit.x)
    limit = min(limit, peak * 1.05)  # never claim a rate the vehicle was not seen to reach
    rms = float(np.sqrt(np.mean(fit.fun ** 2)))
    return YawModel(gain, tau, delay, limit, rms,
                    math.inf if accel >= 0.99 * ACCEL_MAX else accel)


def fit_speed(command: Series, response: Series) -> SpeedModel:
    """Fit τv, dv and Kv to the thrust (%) commanded and the speed (m/s) observed."""
    _check(command, response, "speed")
    t, v = response.t, response.y
    if float(np.max(v)) < 0.1:
        raise FitError("speed: the vehicle never made way")

    top = float(np.max(np.abs(command.y))) or 1.0
    guess = np.array([float(np.max(v)) / top, 2.0])

    def fit_at(delay: float):
        def residual(p: np.ndarray) -> np.ndarray:
            return simulate_lag(command, t, p[0], p[1], delay, start=v[0]) - v
        return least_squares(residual, guess, bounds=([1e-4, 0.05], [1.0, 60.0]),
                             x_scale=[guess[0], 1.0])

    delay, fit = _best_delay(fit_at)
    gain, tau = (float(x) for x in fit.x)
    return SpeedModel(gain, tau, delay, float(np.sqrt(np.mean(fit.fun ** 2))))


COURSE_LAGS = np.arange(0.0, 1.0001, 0.05)
"""The lags of the track behind the heading tried, s."""


def fit_course_lag(heading: Series, x: Series, y: Series, min_speed: float) -> float:
    """How long (s) the direction of the track over the ground, from the navigation's
    positions, lags its heading, fitted on the samples at ``min_speed`` or more: the boat's
    sideslip in a turn and the position fix's latency, which the line follower sees and the
    turn-rate model does not (about 0.3 s on the real SITL motorboat at 5 m/s). 0 when the
    recording cannot tell."""
    if min(len(heading), len(x), len(y)) < MIN_SAMPLES:
        return 0.0
    t = x.t
    north = np.interp(t, y.t, y.y)
    keep = np.concatenate([[True], np.diff(t) > 1e-6])
    t, east, north = t[keep], x.y[keep], north[keep]
    if len(t) < MIN_SAMPLES:
        return 0.0
    ve, vn = np.gradient(east, t), np.gradient(north, t)
    moving = np.hypot(ve, vn) >= max(min_speed, 0.1)
    if int(np.sum(moving)) < MIN_SAMPLES:
        return 0.0
    psi = np.unwrap(np.radians(heading.y))
    course = np.arctan2(ve, vn)

    def misfit(lag: float) -> float:
        err = np.angle(np.exp(1j * (course - np.interp(t - lag, heading.t, psi))))
        return float(np.mean(err[moving] ** 2))

    return float(min(COURSE_LAGS, key=misfit))
