"""pNav's extended Kalman filter for a surface vehicle (spec 2.2): pure logic, no I/O, no clock.

State, in this order (indices are the ``I_*`` constants)::

    X, Y          metres, local frame (X east, Y north)
    H             yaw, radians, MOOS convention yaw = −heading (0 = north, counter-clockwise
                  positive); the bow points along (−sin H, cos H)
    Ẋ, Ẏ, Ḣ       earth-frame velocity (m/s) and yaw rate (rad/s)
    [Z, Ż]        height of the vehicle's origin (m, up; −depth at zero tide) and its rate, if
                  ``estimate_z`` (an underwater vehicle, or a depth sensor declared)
    [b]           hidden: heading bias of the orientation sensor (rad), if ``estimate_yaw_bias``
    [ḃ]           hidden: the rate the bias drifts at (rad/s), if ``estimate_yaw_drift`` too
    [κ]           hidden: scale error of the yaw rate the heading integrates, if
                  ``estimate_yaw_scale`` too: the bias grows by κ Ḣ (an odometer's heading)
    [tide]        hidden: height of the sea surface above the Z = 0 plane (m), if
                  ``estimate_tide``; depth = tide − Z (spec 2.3.1)
    [k]           hidden: scale error of the body-velocity speeds, if ``estimate_speed_scale``
    [s]           hidden: range scale error shared by all beacons, if ``estimate_range_scale``
                  and there are beacons
    [o_1 … o_n]   hidden: one range offset per beacon (m), in the order the beacons are given

Model (spec 2.2.3): constant velocity in X, Y, Z and H, uncoupled, driven by white
acceleration whose strength is the spec's ``EKF_*_DYNAMICS`` setting 0–10 (see
:class:`EKFConfig`); the hidden states are random walks (constant plus a slow drift), the
heading bias with its drift rate a constant-velocity pair. A static
vehicle (spec 2.2.2, ``mobile=False``) has its rate states held at zero and its pose a random
walk instead.

Sensor geometry (spec 2.2.1): every observation may carry its sensor's lever arm in body
coordinates, MOOS's: x to starboard, y forward, z up (m). A GPS antenna on the mast, a DVL
at the bow or a transducer below the keel is then explained where it is, which couples heading
into position and rotation into velocity (``ω × r``) as the real geometry does.

Observations (each carries its own time and its sensor's 1-σ noise, as a ``SENSOR_*`` line
declares it):

- :class:`Range` to a beacon at a known position: ``ρ = (1 + s) |p − beacon| + o_beacon``. The
  offset and the scale are learned, so a turn-around delay or a wrong sound speed is estimated,
  not tuned by hand. (Plaza's "+2.8 m offset" turns out to be ranges 6.7 % long: a scale, not
  an offset. With offsets alone the filter scores 1.3 m RMS there, with the scale 0.46 m.)
- :class:`BodyVelocity` (DVL, wheel odometry): forward speed ``u = −Ẋ sin H + Ẏ cos H``,
  starboard speed ``v = Ẋ cos H + Ẏ sin H`` and yaw rate ``Ḣ``; any part may be absent. Wheel
  odometry (distance and yaw change over an interval) is turned into one with :func:`odometry`:
  speed = distance/interval, yaw rate = change/interval, and starboard speed 0 (a wheeled or
  keeled hull does not crab; its noise is the sideslip allowed). Odometry is an *observation*
  here, not a prediction input, because the spec's model is constant velocity and because
  this is what couples heading and position (spec 2.2.3): with a position sensor it makes the
  heading bias observable (spec 2.2.10).
- :class:`Yaw` from an orientation sensor: ``z = H + b`` (b only when estimated).
- :class:`Position` (GPS XY): ``z = (X, Y)`` (plus the rotated lever arm).
- :class:`Depth`: ``z = tide − (Z + lever z)``; :class:`Tide`: ``z = tide`` (a fixed
  observation, spec 2.2.8, pins the Z = 0 plane to the surface).

Data rejection (spec 2.2.6): the observations of one time slice are tested together; each one
first alone (χ² test of its own Mahalanobis distance), then the survivors jointly; when the
joint test fails, the observation whose removal leaves the most consistent set is dropped and
the test retried, so one bad range does not take good ones down with it.

Safety (spec 2.2.11): a rate state beyond ``max_speed`` (EKF_MAX_SPEED) or ``max_yaw_rate``
(π rad/s) is reset to zero with a warning; a position 1-σ beyond ``max_position_sigma`` raises
:class:`NavigationFailure` and takes the filter off-line.

What comes from filterpy: the filter's state lives in a
:class:`filterpy.kalman.ExtendedKalmanFilter` (``self.kf``: ``x, P, F, Q, R, K, y, S`` are
its arrays, with its names and shapes, so filterpy's tools and saver work on it), and the
process noise blocks are those of :func:`filterpy.common.Q_continuous_white_noise` (written
out, see :func:`white_noise_block`; a test pins them equal). What had to be written by hand,
and why:

- ``predict(dt)``: filterpy's ``predict()`` takes no time step; F and Q are rebuilt per ``dt``
  here because observations arrive at irregular times, and propagated here (``F x``,
  ``F P Fᵀ + Q``) without filterpy's copies of the priors.
- The update: the Kalman correction reusing the innovation covariance the gating has
  already computed, in the short form ``P − K S Kᵀ`` symmetrised. filterpy's recomputes S,
  inverts it twice (once for its Mahalanobis distance), applies the Joseph form and copies
  the posteriors: measured on the Plaza replay, it was a third of the navigator's time, and
  the one-hour replay target (< 10 s) needed it gone.
- Speed (a predict+update within 50 µs, 12 states): on matrices this small numpy's cost is
  per call, not per flop — and in the companion's tick, where the other apps run between two
  of pNav's steps, a call costs 5–13 µs, not the 0.3–1 µs of a tight loop (caches gone) — so
  the hot path makes fewer calls with the same arithmetic: rows linearised as floats and
  stacked in one array, the state handled as floats between one read and one write per step
  (F x, x + K y and the yaw wrap are element-wise sums, the same in floats), Q added whole,
  ``np.dot`` for ``@``, LAPACK's gesv called directly for ``np.linalg.solve``/``inv`` (the
  same routine), one Cholesky factorisation deciding the covariance is sound. The matrix
  products stay BLAS's: written as float loops they would round differently (BLAS fuses
  multiply-adds). Results are bit for bit those of the plain numpy expressions (compared on
  the Plaza replay, its fault variants and the simulator's runs).
- χ² gating per observation and jointly, and finding the true outlier by dropping the worst
  and retrying: filterpy only *reports* the Mahalanobis distance after an update has already
  been applied (``mahalanobis``); gating must happen before.
- State augmentation (heading bias, range scale, per-beacon offsets), angle wrapping of H and
  of yaw residuals, rate-state resets, re-initialisation and the navigation-failure limit:
  filterpy has no notion of them.

Use from a navigator, each tick: ``advance(now − lag)``, ``update(observations of that slice)``
(one call per time stamp), then ``forecast(now)`` for the ``EKF_*`` outputs; publish and clear
``warnings``; catch :class:`NavigationFailure`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from typing import Final, NamedTuple

import numpy as np
from scipy.linalg.lapack import dgesv, dpotrf

from mavhelm.nav.chi_square import chi2_logsf, chi2_ppf
from mavhelm.nav.settings import (
    EKF_BEACON_OFFSETS,
    EKF_GATE,
    EKF_MAX_SPEED,
    EKF_MOBILE,
    EKF_RANGE_SCALE,
    EKF_SIGMA_HEADING,
    EKF_SIGMA_XY,
    EKF_SIGMA_Z,
    EKF_TIDE,
    EKF_TIME_SIGMA,
    EKF_XY_DYNAMICS,
    EKF_YAW_BIAS,
    EKF_YAW_DRIFT,
    EKF_YAW_DYNAMICS,
    EKF_Z_DYNAMICS,
    MAX_EKF_POSITION_UNCERTAINTY,
    RADIANS_PER_DEGREE,
    check_config,
    setting,
)

I_X: Final = 0
I_Y: Final = 1
I_H: Final = 2
I_VX: Final = 3
I_VY: Final = 4
I_VH: Final = 5
N_VEHICLE: Final = 6
"""Indices of the vehicle states; Z and Ż (``EKF.i_z``, ``EKF.i_vz``) and the hidden states
follow when the filter has them (see :class:`EKF`)."""

# Full-scale process noise of the constant-velocity model: the spectral density of the white
# acceleration at EKF_*_DYNAMICS = 10, scaled linearly with the setting (as the original
# MOOSNavLib scales its acceleration variance with DYNAMICS/10). At the default 5 a vehicle's
# speed may wander by ~0.7 m/s and its yaw rate by ~0.7 rad/s in one second of silence.
FULL_SCALE_XY_ACCEL: Final = 1.0
"""(m/s²)²/Hz at EKF_XY_DYNAMICS = 10."""
FULL_SCALE_YAW_ACCEL: Final = 1.0
"""(rad/s²)²/Hz at EKF_YAW_DYNAMICS = 10: at the default 5 a yaw rate may change by ~0.7 rad/s
in a second. A boat starts a turn that fast (mavhelm sim: 0 → 0.8 rad/s in 0.3 s); a stiffer
model (0.03) refused every compass and gyro reading through the first turn and never caught
up. Plaza's robot, turning slowly, scores the same with either."""

ALONG_TRACK: Final = 0.05
"""Share of the XY acceleration noise along the bow, for a hull whose velocity follows its
heading (FIXEDSIDESLIP), once it cruises: boats and rovers change speed far more gently than
course (NAV_SPEED on 1 Hz GPS: 0.16 m/s RMS, 0.27 with 0.2). The navigator gives the whole
noise back while the vehicle is still or getting under way (``EKF.along_track``)."""
ACROSS_TRACK: Final = 1.0
"""... and across it (the turn not modelled by the yaw rate)."""

# Default 1-σ sensor noise, used when an observation does not say (a SENSOR_* line's "~ noise").
RANGE_SIGMA: Final = 1.0
"""m: a radio or acoustic range after its offset is removed (Plaza: MAD 0.8 m)."""
SPEED_SIGMA: Final = 0.05
"""m/s: forward speed from wheel odometry or a DVL."""
SIDESLIP_SIGMA: Final = 0.1
"""m/s: starboard speed when it is the "does not crab" constraint of odometry."""
YAW_RATE_SIGMA: Final = 0.02
"""rad/s: yaw rate from odometry or a gyro."""
YAW_SIGMA: Final = math.radians(2.0)
"""rad: an orientation sensor (compass, AHRS) apart from its slowly drifting bias."""
POSITION_SIGMA: Final = 3.0
"""m: a GPS fix."""
DEPTH_SIGMA: Final = 0.1
"""m: a pressure depth sensor."""
TIDE_SIGMA: Final = 0.1
"""m: a tide observation (usually a fixed one)."""

Lever = tuple[float, float, float]
"""A sensor's position in body coordinates (m): x starboard, y forward, z up (MOOS's)."""
NO_LEVER: Final[Lever] = (0.0, 0.0, 0.0)


class NavigationFailure(Exception):
    """The filter's uncertainty passed a configured limit (spec 2.2.11): it is off-line now,
    and the navigator must declare a navigation failure (``NAVIGATION_FAILURE``, EndMission)."""


class PositionLost(NavigationFailure):
    """The position 1-σ passed ``max_position_sigma`` (MaxEKFPositionUncertainty): the EKF is
    lost. The navigator decides what follows: a re-boot from the LSQ when one runs, else a
    navigation failure."""


@dataclass(frozen=True)
class Beacon:
    """A range beacon at a surveyed position. ``z`` is its height relative to the vehicle's
    plane (negative below it), so ranges are slant ranges. ``offset`` is the prior of its range
    offset (a known delay, in metres); the filter learns the rest. ``turnaround`` (s) is an
    acoustic transponder's reply delay, taken off its two-way travel times before they
    become ranges."""

    name: str
    x: float
    y: float
    z: float = 0.0
    offset: float = 0.0
    turnaround: float = 0.0


@dataclass(frozen=True)
class EKFConfig:
    """The filter's settings. Fields built with ``setting(...)`` are the pNav block's
    ``EKF_*`` keys (:mod:`mavhelm.nav.settings`: their default, range and unit are declared
    there once); the others are the model's constants, not settings.

    - ``xy_dynamics``, ``yaw_dynamics``, ``z_dynamics`` (EKF_XY_DYNAMICS, EKF_YAW_DYNAMICS,
      EKF_Z_DYNAMICS, 0–10): process noise, spectral density = setting/10 ×
      ``FULL_SCALE_*_ACCEL``. 0 = never changes.
    - ``sigma_xy`` (m, EKF_SIGMA_XY), ``sigma_yaw`` (rad, EKF_SIGMA_HEADING in degrees),
      ``sigma_z`` (m, EKF_SIGMA_Z): initial 1-σ of the start; ``sigma_velocity`` (m/s) and
      ``sigma_yaw_rate`` (rad/s) those of the rate states, which start at zero (spec 2.2.4).
    - ``estimate_yaw_bias`` (EKF_YAW_BIAS): add the heading-bias state. Off unless asked for:
      spec 2.2.10 allows it only with a body velocity sensor *and* a position sensor (ranges
      or GPS); without both it is unobservable and only blurs the heading. The navigator adds
      it (:meth:`EKF.with_yaw_bias`) when a doubted heading needs it and the motion makes it
      observable.
      ``sigma_yaw_bias`` is its initial 1-σ (rad), ``yaw_bias_noise`` its random walk
      (rad/√s: 1e-3 lets it follow a gyro-integrated heading drifting ~0.5°/min).
    - ``estimate_yaw_drift`` (EKF_YAW_DRIFT): with the bias state, the rate it drifts at, as
      a second state (the bias and its rate a constant-velocity pair, as position and
      speed): ``sigma_yaw_drift`` its initial 1-σ (rad/s), ``yaw_drift_noise`` the spectral
      density of its changes (rad/s/√s). An odometry-integrated heading's error is the
      integral of a yaw-rate error that changes slowly; a random-walk bias alone holds the
      last bias through a stretch without position data while the heading drifts on. Where
      the heading is the integral of a body velocity's yaw rate (one source gives both),
      that rate reads the drift too (:meth:`_body_velocity_rows`).
      Measured on Plaza1 (RMS m, seeds 1-3), the heading drifting 180° within two minutes
      (``heading_drift`` with a 120 s window): with the rate reading the drift 0.72/1.31/1.42
      at 1e-4, 0.44/0.90/1.43 at 2e-4, 0.40/0.75/1.40 at 3e-4, 0.39/0.72/1.39 at 4e-4,
      0.48/0.87/1.63 at 1e-3; before it 1.89/1.18/1.69 (1e-4). Within one minute, 3e-4:
      0.82/1.41/2.74 (before 15.6/2.04/7.09); within five 0.37/0.46/0.65 (0.41/0.57/0.71);
      the recording without a fault 0.36 → 0.37 m (4e-4 0.37, 1e-3 0.49). Only on a mobile
      vehicle.
    - ``estimate_yaw_scale`` (EKF_YAW_SCALE, set by the navigator only where the orientation
      sensor and a body-velocity sensor are one source): with the bias state, the scale
      error κ of the yaw rate that heading integrates, shared by the two: the sensor's yaw
      rate reads (1 + κ) Ḣ and the bias grows by κ Ḣ dt (a wheel odometer's wheel base, a
      gyro's scale factor). A drift in time does not follow an error made in the turns:
      Plaza1's odometry heading with its yaw rate 5 % (10 %) long, 1.22 (2.51) m RMS
      without, 0.35 (0.35) m with; its other faults and the recording itself unchanged.
      ``sigma_yaw_scale`` its initial 1-σ, ``yaw_scale_noise`` its random walk (1/√s).
      Only on a mobile vehicle.
    - ``estimate_speed_scale`` (EKF_SPEED_SCALE): add one scale factor of the body-velocity
      sensors' forward and starboard speeds (measured = (1 + k) × true), shared by them: a
      wheel odometer's wheel size, a DVL's sound speed. ``sigma_speed_scale`` its initial
      1-σ, ``speed_scale_noise`` its random walk (1/√s). Seen only against position data.
    - ``estimate_range_scale`` (EKF_RANGE_SCALE): add one range scale factor shared by every
      beacon (ranges = (1 + s) × distance + offset): a wrong sound speed for acoustic LBL, a
      clock-rate error for radio ranging. ``sigma_range_scale`` its initial 1-σ,
      ``range_scale_noise`` its random walk (1/√s). Only when there are beacons.
    - ``learn_beacon_offsets`` (EKF_BEACON_OFFSETS): ``sigma_beacon_offset`` (m) is the
      initial 1-σ of the delay every beacon's range shares (a clock or a turn-around common
      to the net), ``sigma_offset_spread`` (m) that of each beacon's own part, around the
      beacon's own prior; the offsets' prior is correlated accordingly (each offset's
      variance is the sum, two offsets' covariance the shared part). ``beacon_offset_noise``
      is each offset's random walk (m/√s). When false the offsets are held at their priors.
      Why a shared part: left each free by metres, a beacon's offset absorbs a bad range
      heard early, or part of a beacon's survey error, and the position drifts with it;
      Plaza1's four UWB offsets, learned, lie within 0.2 m of each other. Why the shared
      delay's σ is 1 m and not the metres a net could have: from a still vehicle, four
      ranges fit a position, a range scale and a free shared delay exactly, so a beacon off
      its survey by 5 m moved the whole fix by 4–5 m, a shared delay of 6 m absorbing the
      rest (Plaza1 with beacon 0 moved 5 m, over twelve directions: worst 1.15 m RMS with
      5 m, 0.83 m with 1 m; clean 0.36 → 0.33 m). A net's real shared delay of several
      metres is still learned once the vehicle moves (every range 6 m long: 0.34 → 0.56 m).
    - ``gate_probability`` (EKF_GATE): χ² acceptance probability of the data rejection
      (0.999: a lone observation is refused beyond 3.3 σ).
    - ``max_speed`` (m/s, EKF_MAX_SPEED), ``max_yaw_rate`` (rad/s): rate states beyond these
      are reset.
    - ``max_position_sigma`` (m, MaxEKFPositionUncertainty): larger 1-σ of the position and
      the filter is lost (:class:`PositionLost`).
    - ``mobile`` (EKF_MOBILE): False for a static vehicle (spec 2.2.2): no rate states, the
      pose a random walk of the dynamics' strength.
    - ``time_sigma`` (s, EKF_TIME_SIGMA): RMS of the data's lateness. Readings are stamped
      when they arrive, a link's latency after they were true: the state the filter holds is
      the vehicle's a little while ago, and the published position covariance
      (:meth:`EKF.position_covariance`) adds that uncertainty along the velocity. It stays out
      of the position: a bias shared by every reading is no noise to average; in a turn a
      heading is widened by it (``Fusion._turning``).
    - ``velocity_follows_heading``: the prediction turns the velocity with the yaw rate
      (a hull that moves along its bow, as ``FIXEDSIDESLIP`` declares): the spec's uncoupled
      model otherwise keeps the old course through a turn, and the sideslip constraint then
      takes the difference out of the speed instead of the course.
    - ``estimate_z``: add Z and Ż (a depth sensor or FIXEDDEPTH is declared);
      ``estimate_tide`` (EKF_TIDE): add the tide (``sigma_tide``, ``tide_noise`` m/√s). Tide
      alone with a depth sensor is not observable: give ranges to beacons at known heights
      or a fixed tide observation too.
    """

    xy_dynamics: float = setting(EKF_XY_DYNAMICS)
    yaw_dynamics: float = setting(EKF_YAW_DYNAMICS)
    sigma_xy: float = setting(EKF_SIGMA_XY)
    sigma_yaw: float = setting(EKF_SIGMA_HEADING, RADIANS_PER_DEGREE)
    sigma_velocity: float = 2.0
    sigma_yaw_rate: float = 0.5
    estimate_yaw_bias: bool = setting(EKF_YAW_BIAS)
    sigma_yaw_bias: float = math.radians(10.0)
    yaw_bias_noise: float = 1e-3
    estimate_yaw_drift: bool = setting(EKF_YAW_DRIFT)
    sigma_yaw_drift: float = math.radians(1.0)
    yaw_drift_noise: float = 3e-4
    estimate_yaw_scale: bool = False
    """EKF_YAW_SCALE where the heading is a body-velocity sensor's (see above)."""
    sigma_yaw_scale: float = 0.05
    yaw_scale_noise: float = 1e-5
    estimate_speed_scale: bool = False
    """Whether the filter holds the speed-scale state: the navigator adds it where
    EKF_SPEED_SCALE says, at the first speed a body-velocity sensor gives
    (:meth:`with_states`)."""
    sigma_speed_scale: float = 0.1
    speed_scale_noise: float = 1e-5
    estimate_range_scale: bool = setting(EKF_RANGE_SCALE)
    sigma_range_scale: float = 0.1
    range_scale_noise: float = 1e-5
    learn_beacon_offsets: bool = setting(EKF_BEACON_OFFSETS)
    sigma_beacon_offset: float = 1.0
    sigma_offset_spread: float = 0.5
    beacon_offset_noise: float = 1e-3
    gate_probability: float = setting(EKF_GATE)
    max_speed: float = setting(EKF_MAX_SPEED)
    max_yaw_rate: float = math.pi
    max_position_sigma: float = setting(MAX_EKF_POSITION_UNCERTAINTY)
    mobile: bool = setting(EKF_MOBILE)
    estimate_z: bool = False
    z_dynamics: float = setting(EKF_Z_DYNAMICS)
    sigma_z: float = setting(EKF_SIGMA_Z)
    estimate_tide: bool = setting(EKF_TIDE)
    sigma_tide: float = 1.0
    tide_noise: float = 1e-3
    velocity_follows_heading: bool = False
    time_sigma: float = setting(EKF_TIME_SIGMA)

    def __post_init__(self) -> None:
        check_config(self)
        for name in ("sigma_velocity", "sigma_yaw_rate", "sigma_yaw_bias", "sigma_yaw_drift",
                     "sigma_yaw_scale", "sigma_speed_scale", "sigma_range_scale",
                     "sigma_beacon_offset", "sigma_offset_spread", "max_yaw_rate",
                     "sigma_tide"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value}")
        for name in ("yaw_bias_noise", "yaw_drift_noise", "yaw_scale_noise", "speed_scale_noise",
                     "range_scale_noise",
                     "beacon_offset_noise", "tide_noise"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be >= 0, got {value}")

    @property
    def offset_sigma(self) -> float:
        """Initial 1-σ of a beacon's offset: held at its prior when not learned."""
        return self.sigma_beacon_offset if self.learn_beacon_offsets else 1e-6

    @property
    def offset_noise(self) -> float:
        """Random walk of a beacon's offset: none when not learned."""
        return self.beacon_offset_noise if self.learn_beacon_offsets else 0.0


# ----------------------------------------------------------------------------- observations


@dataclass(frozen=True)
class Range:
    """A range (m) to ``beacon`` heard at time ``t``."""

    t: float
    beacon: str
    z: float
    sigma: float = RANGE_SIGMA
    lever: Lever = NO_LEVER


@dataclass(frozen=True)
class BodyVelocity:
    """Body-frame velocity at ``t``: ``forward`` and ``starboard`` speed (m/s) and ``yaw_rate``
    (rad/s, counter-clockwise positive like yaw); None for a part the sensor does not give."""

    t: float
    forward: float | None = None
    starboard: float | None = None
    yaw_rate: float | None = None
    sigma_forward: float = SPEED_SIGMA
    sigma_starboard: float = SIDESLIP_SIGMA
    sigma_yaw_rate: float = YAW_RATE_SIGMA
    lever: Lever = NO_LEVER
    integrated: bool = False
    """Whether the orientation sensor's heading is this yaw rate integrated (the same
    instrument: wheel odometry, a gyro): its scale error (``estimate_yaw_scale``) is then
    shared by the two."""


@dataclass(frozen=True)
class Yaw:
    """Yaw (rad, yaw = −heading) from an orientation sensor at ``t``; read ``age`` s before
    ``t`` (a telemetry link's batch), so it is the heading then: ψ − age·ψ̇, whose rate row
    lets the filter weigh the turn's share rather than move the reading by its own guess."""

    t: float
    z: float
    sigma: float = YAW_SIGMA
    age: float = 0.0


@dataclass(frozen=True)
class Position:
    """An XY fix (m, local frame) at ``t``, e.g. GPS."""

    t: float
    x: float
    y: float
    sigma: float = POSITION_SIGMA
    lever: Lever = NO_LEVER


@dataclass(frozen=True)
class Depth:
    """Depth of the sensor below the surface (m, positive down) at ``t``."""

    t: float
    z: float
    sigma: float = DEPTH_SIGMA
    lever: Lever = NO_LEVER


@dataclass(frozen=True)
class Tide:
    """Height of the surface above the Z = 0 plane (m) at ``t``."""

    t: float
    z: float
    sigma: float = TIDE_SIGMA


Observation = Range | BodyVelocity | Yaw | Position | Depth | Tide


def odometry(t: float, interval: float, distance: float, dyaw: float, *,
             sigma_forward: float = SPEED_SIGMA, sigma_starboard: float = SIDESLIP_SIGMA,
             sigma_yaw_rate: float = YAW_RATE_SIGMA) -> BodyVelocity:
    """Odometry increments over ``interval`` seconds ending at ``t`` (distance travelled, yaw
    change) as the mean body velocity of the interval, with the no-crabbing constraint."""
    if not interval > 0:
        raise ValueError(f"odometry interval must be > 0 s, got {interval}")
    return BodyVelocity(t, distance / interval, 0.0, dyaw / interval,
                        sigma_forward, sigma_starboard, sigma_yaw_rate)


def white_noise_block(dt: float) -> tuple[float, float, float, float]:
    """The (position, rate) block of continuous white-noise acceleration of unit spectral
    density over ``dt``, flattened: filterpy's ``Q_continuous_white_noise(2, dt, 1)``, written
    out because it is needed every prediction and filterpy assembles it with scipy's
    ``block_diag``, which costs more than the rest of the prediction."""
    return (dt**3 / 3.0, dt**2 / 2.0, dt**2 / 2.0, dt)


def wrap_angle(a: float) -> float:
    """An angle in [−π, π)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


# ----------------------------------------------------------------------------- the filter


@dataclass(frozen=True)
class Estimate:
    """What the filter believes at ``t``: the NAV_* family's sources (EKF_X, EKF_YAW, …)."""

    t: float
    x: float
    y: float
    yaw: float
    x_vel: float
    y_vel: float
    yaw_vel: float
    sigma_x: float
    sigma_y: float
    sigma_yaw: float
    yaw_bias: float
    yaw_drift: float
    range_scale: float
    offsets: dict[str, float]
    speed_scale: float = 0.0
    yaw_scale: float = 0.0
    z: float = 0.0
    z_vel: float = 0.0
    tide: float = 0.0
    sigma_z: float = 0.0

    @property
    def depth(self) -> float:
        return self.tide - self.z

    @property
    def speed(self) -> float:
        return math.hypot(self.x_vel, self.y_vel)

    @property
    def heading(self) -> float:
        """Compass heading, degrees clockwise from north, in [0, 360)."""
        return (-math.degrees(self.yaw)) % 360.0


class Verdict(NamedTuple):
    """The fate of one observation in an update: its squared Mahalanobis distance against the
    prior, its degrees of freedom, whether it was used, and its (first row's) innovation,
    measured less predicted (a named tuple: immutable, and a frozen dataclass cost as much to
    build as a third of a Kalman update)."""

    obs: Observation
    d2: float
    dof: int
    accepted: bool
    innovation: float = 0.0


@dataclass
class UpdateResult:
    """What ``update`` did with each observation it was given, in order."""

    verdicts: list[Verdict] = field(default_factory=list)

    @property
    def accepted(self) -> list[Observation]:
        return [v.obs for v in self.verdicts if v.accepted]

    @property
    def rejected(self) -> list[Observation]:
        return [v.obs for v in self.verdicts if not v.accepted]


@dataclass
class _Rows:
    """One observation linearised: measurement, prediction, Jacobian, noise, angle rows."""

    z: np.ndarray
    hx: np.ndarray
    H: np.ndarray
    r: np.ndarray
    angular: np.ndarray


_Row = tuple[float, float, list[tuple[int, float]], float, bool]
"""One row of an observation: measured, predicted, Jacobian as (state index, derivative)
pairs, variance, whether it is an angle (its residual wraps)."""


class _Slice(NamedTuple):
    """The observations of one time slice stacked: residuals, Jacobian, noise, and where each
    observation's rows start (``first[k]:first[k + 1]``)."""

    y: np.ndarray
    H: np.ndarray
    r: np.ndarray
    first: list[int]
    residuals: list[float]
    """``y`` as floats."""
    x: list[float]
    """The state the rows were linearised at, as floats."""


class EKF:
    """The pNav EKF. Build it with a start pose, then per tick: ``advance(t)`` (or
    ``predict(dt)``), ``update(observations)``, read ``estimate()``.

    ``x`` and ``P`` are filterpy's column-vector state and covariance; ``F`` and ``Q`` the last
    prediction's matrices. Beacons are fixed at construction; their offsets are states
    ``offset_index(name)``. Warnings (rate resets) accumulate in ``warnings`` for the owner to
    publish and clear.
    """

    @staticmethod
    def prepare() -> type:
        """filterpy's ``ExtendedKalmanFilter``, imported on first use: filterpy.kalman brings
        scipy.stats, a second of start-up for every command that never builds a filter (the
        simulator, the consoles, ``--help``). A navigator calls this when its mission is
        loaded, so the tick that boots the first filter does not pay for the import."""
        from filterpy.kalman import ExtendedKalmanFilter

        return ExtendedKalmanFilter

    def __init__(self, t: float, x: float, y: float, yaw: float = 0.0, *,
                 beacons: Iterable[Beacon] = (), config: EKFConfig | None = None,
                 sigma_xy: float | None = None, sigma_yaw: float | None = None) -> None:
        self.config = cfg = config or EKFConfig()
        self.beacons: dict[str, Beacon] = {}
        for beacon in beacons:
            if beacon.name in self.beacons:
                raise ValueError(f"beacon {beacon.name} is declared twice")
            self.beacons[beacon.name] = beacon
        n = N_VEHICLE
        self.i_z: int | None = None
        self.i_vz: int | None = None
        if cfg.estimate_z:
            self.i_z, self.i_vz = n, n + 1
            n += 2
        self.i_bias: int | None = n if cfg.estimate_yaw_bias else None
        n += 1 if cfg.estimate_yaw_bias else 0
        drifts = cfg.estimate_yaw_bias and cfg.estimate_yaw_drift and cfg.mobile
        self.i_drift: int | None = n if drifts else None
        n += 1 if drifts else 0
        scales = cfg.estimate_yaw_bias and cfg.estimate_yaw_scale and cfg.mobile
        self.i_yaw_scale: int | None = n if scales else None
        n += 1 if scales else 0
        self.i_tide: int | None = n if cfg.estimate_tide else None
        n += 1 if cfg.estimate_tide else 0
        self.i_speed: int | None = n if cfg.estimate_speed_scale else None
        n += 1 if cfg.estimate_speed_scale else 0
        self.i_scale: int | None = n if cfg.estimate_range_scale and self.beacons else None
        first_offset = n + (1 if self.i_scale is not None else 0)
        self._offset_index = {name: first_offset + k for k, name in enumerate(self.beacons)}
        self.dim = first_offset + len(self.beacons)
        self.kf = EKF.prepare()(dim_x=self.dim, dim_z=1)
        self.t = float(t)
        self.warnings: list[str] = []
        self.failure: NavigationFailure | None = None
        self.rate_resets = 0
        self._gates: dict[int, float] = {}
        self._last_r = np.zeros(0)
        self._last_dt = 0.0
        self.kf.F = np.eye(self.dim)
        self.kf.Q = np.zeros((self.dim, self.dim))
        self._wander: tuple[float, float] | None = None
        """(extra bias variance rate, until when) after a heading doubt."""
        self.follows_heading = self.config.velocity_follows_heading
        """Whether the prediction turns the velocity with the yaw rate (and ``along_track``
        applies): the config's ``velocity_follows_heading``, or its owner's decision at run
        time."""
        self._turning_velocity = False
        """Whether ``F`` holds the velocity's turn from the last prediction."""
        self.along_track = ALONG_TRACK
        """The share of the XY acceleration noise along the bow (``velocity_follows_heading``):
        ``ALONG_TRACK`` while the vehicle cruises; its owner sets 1 while it starts or stops,
        when the speed does change fast."""
        self.hold_speed_scale = False
        """Keep the speed scale where it is (a Schmidt "consider" state: its uncertainty
        still counts, the updates leave it alone): its owner holds it while the heading is
        in question, when the track's errors would be taken as the speeds' scale."""
        self.hold_drift = False
        """The same for the heading bias's drift rate, which a heading being turned by
        tens of degrees would take for drift."""
        self._eye = np.eye(self.dim)
        self._pairs, self._walks = self._noise_layout()
        self._coupling, self._noise_templates = self._templates()
        self._F = np.eye(self.dim)
        """The prediction's transition matrix, rewritten in place: only the dt entries change."""
        self._q_cells, self._q_blocks = self._noise_cells()
        self._q_dt, self._q_dense = 0.0, np.zeros((self.dim, self.dim))
        self._q_block = white_noise_block(0.0)
        """The last step's Q as a full matrix and its white-noise coefficients: a steady tick
        has the same step, so the same Q."""
        self._f_dt: float | None = None
        """The step ``_F``'s rate cells hold."""
        self._rate_of = list(zip(self._pairs[0].tolist(), self._pairs[1].tolist(), strict=True))
        """(position, rate) index pairs of the constant-velocity model."""
        self._initialise(x, y, yaw, sigma_xy, sigma_yaw)
        self._good = (float(x), float(y), float(yaw))
        """The last position known finite, where a numerical recovery restarts."""
        self.recoveries = 0

    def _templates(self) -> tuple[np.ndarray, tuple[np.ndarray, ...]]:
        """F = I + dt·C and Q = dt³/3·Q₃ + dt²/2·Q₂ + dt·Q₁ + dt·Q_walk: the constant
        matrices, built once, so a prediction is a few matrix products."""
        n = self.dim
        pos, vel, q = self._pairs
        walk, walk_q = self._walks
        coupling = np.zeros((n, n))
        q_pp, q_pv, q_vv, q_walk = (np.zeros((n, n)) for _ in range(4))
        if self.config.mobile:
            coupling[pos, vel] = 1.0
            q_pp[pos, pos] = q
            q_pv[pos, vel] = q_pv[vel, pos] = q
            q_vv[vel, vel] = q
        else:
            q_walk[pos, pos] = q  # a static vehicle's pose: a random walk
        q_walk[walk, walk] = walk_q
        return coupling, (q_pp, q_pv, q_vv, q_walk)

    def _noise_cells(self) -> tuple[np.ndarray, np.ndarray]:
        """Q's nonzero cells (flat indices into P) and their template values, one row per
        coefficient (dt³/3, dt²/2, dt, dt: :func:`white_noise_block`'s and the walks'): Q's
        cells are then ``coefficients @ blocks``, so the prediction adds Q where it is nonzero
        in one product and one indexed add. Each cell has one nonzero template, so the sums are
        exact: the same Q bit for bit as the four scaled templates added."""
        templates = self._noise_templates
        cells = np.flatnonzero(sum(np.abs(t) for t in templates))
        return cells, np.array([t.reshape(-1)[cells] for t in templates])

    def _noise_layout(self) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray],
                                     tuple[np.ndarray, np.ndarray]]:
        """Where the process noise goes: (position, rate, spectral density) of each
        constant-velocity pair, and (index, variance rate) of each random-walk state."""
        cfg = self.config
        q_xy = cfg.xy_dynamics / 10.0 * FULL_SCALE_XY_ACCEL
        q_yaw = cfg.yaw_dynamics / 10.0 * FULL_SCALE_YAW_ACCEL
        q_z = cfg.z_dynamics / 10.0 * FULL_SCALE_XY_ACCEL
        pairs = [(I_X, I_VX, q_xy), (I_Y, I_VY, q_xy), (I_H, I_VH, q_yaw)]
        if self.i_z is not None and self.i_vz is not None:
            pairs.append((self.i_z, self.i_vz, q_z))
        if self.i_bias is not None and self.i_drift is not None:
            pairs.append((self.i_bias, self.i_drift, cfg.yaw_drift_noise**2))
        walks = [(i, noise**2) for i, noise in (
            (self.i_bias, cfg.yaw_bias_noise), (self.i_yaw_scale, cfg.yaw_scale_noise),
            (self.i_tide, cfg.tide_noise),
            (self.i_speed, cfg.speed_scale_noise), (self.i_scale, cfg.range_scale_noise))
            if i is not None]
        walks += [(i, cfg.offset_noise**2) for i in self._offset_index.values()]
        pos, vel, q = (np.array(col) for col in zip(*pairs, strict=True))
        walk = np.array([i for i, _ in walks], dtype=int)
        walk_q = np.array([v for _, v in walks], dtype=float)
        return (pos, vel, q), (walk, walk_q)

    def _initialise(self, x: float, y: float, yaw: float, sigma_xy: float | None,
                    sigma_yaw: float | None) -> None:
        """Every state to its prior (spec 2.2.4): the pose given, rates zero, hidden states at
        the beacons' priors, all uncorrelated."""
        cfg = self.config
        sxy = cfg.sigma_xy if sigma_xy is None else sigma_xy
        syaw = cfg.sigma_yaw if sigma_yaw is None else sigma_yaw
        state = np.zeros(self.dim)
        state[[I_X, I_Y, I_H]] = x, y, wrap_angle(yaw)
        var = np.zeros(self.dim)
        var[[I_X, I_Y]] = sxy**2
        var[I_H] = syaw**2
        var[[I_VX, I_VY]] = cfg.sigma_velocity**2
        var[I_VH] = cfg.sigma_yaw_rate**2
        if self.i_z is not None and self.i_vz is not None:
            var[self.i_z] = cfg.sigma_z**2
            var[self.i_vz] = cfg.sigma_velocity**2
        if self.i_bias is not None:
            var[self.i_bias] = cfg.sigma_yaw_bias**2
        if self.i_drift is not None:
            var[self.i_drift] = cfg.sigma_yaw_drift**2
        if self.i_yaw_scale is not None:
            var[self.i_yaw_scale] = cfg.sigma_yaw_scale**2
        if self.i_tide is not None:
            var[self.i_tide] = cfg.sigma_tide**2
        if self.i_speed is not None:
            var[self.i_speed] = cfg.sigma_speed_scale**2
        if self.i_scale is not None:
            var[self.i_scale] = cfg.sigma_range_scale**2
        for name, i in self._offset_index.items():
            state[i] = self.beacons[name].offset
        if not cfg.mobile:
            var[list(self._rate_indices())] = 0.0
        self.kf.x = state.reshape(-1, 1)
        P = np.diag(var)
        self._offset_prior(P, list(self._offset_index.values()))
        self.kf.P = P

    def _offset_prior(self, P: np.ndarray, index: list[int]) -> None:  # noqa: N803
        """The prior covariance of the offsets at ``index`` written into ``P``: the shared
        delay's variance everywhere in their block, each one's own part on the diagonal (or
        held at the prior when offsets are not learned)."""
        cfg = self.config
        if cfg.learn_beacon_offsets:
            P[np.ix_(index, index)] = cfg.sigma_beacon_offset**2
            P[index, index] += cfg.sigma_offset_spread**2
        else:
            P[index, index] = cfg.offset_sigma**2

    def _rate_indices(self) -> tuple[int, ...]:
        return (I_VX, I_VY, I_VH) + ((self.i_vz,) if self.i_vz is not None else ())

    # textbook names, backed by filterpy's arrays
    @property
    def x(self) -> np.ndarray:
        return self.kf.x

    @property
    def P(self) -> np.ndarray:  # noqa: N802 - textbook name
        return self.kf.P

    @property
    def F(self) -> np.ndarray:  # noqa: N802
        """The last prediction's transition matrix."""
        return self._eye + self._last_dt * self._coupling

    @property
    def Q(self) -> np.ndarray:  # noqa: N802
        """The last prediction's process noise."""
        dt = self._last_dt
        if dt <= 0:
            return np.zeros((self.dim, self.dim))
        pp, pv, _, vv = white_noise_block(dt)
        q_pp, q_pv, q_vv, q_walk = self._noise_templates
        return pp * q_pp + pv * q_pv + vv * q_vv + dt * q_walk

    @property
    def R(self) -> np.ndarray:  # noqa: N802
        """The noise of the last update's accepted rows."""
        return np.diag(self._last_r)

    @property
    def mahalanobis(self) -> float:
        """Mahalanobis distance of the last applied update's innovation (as filterpy's)."""
        y, S_inv = self.kf.y, self.kf.SI
        return math.sqrt(max(float(y @ S_inv @ y), 0.0))

    @property
    def online(self) -> bool:
        return self.failure is None

    def offset_index(self, beacon: str) -> int:
        return self._offset_index[beacon]

    # ------------------------------------------------------------------ prediction

    def advance(self, t: float) -> None:
        """Predict to time ``t`` (no-op if ``t`` is not later than the filter's time)."""
        if t > self.t:
            self.predict(t - self.t)

    def predict(self, dt: float) -> None:
        """Constant-velocity prediction over ``dt`` seconds."""
        if self.failure is not None:
            raise self.failure
        if not (math.isfinite(dt) and dt >= 0):
            raise ValueError(f"predict needs dt >= 0 s, got {dt}")
        self._last_dt = dt
        kf = self.kf
        F = self._F
        mobile = self.config.mobile
        follows = mobile and self.follows_heading
        if self._turning_velocity and not follows:
            F[I_VX, I_VX], F[I_VX, I_VY], F[I_VY, I_VX], F[I_VY, I_VY] = 1.0, 0.0, 0.0, 1.0
            F[I_VX, I_VH] = F[I_VY, I_VH] = 0.0
        self._turning_velocity = follows
        if mobile and dt != self._f_dt:
            self._f_dt = dt
            for i, j in self._rate_of:
                F[i, j] = dt
        i_bias, i_scale = self.i_bias, self.i_yaw_scale
        # the bias, when an integrated heading's grows by its scale error times the turn:
        # b ← b + dt κ ω, linearised for P
        turned: int | None = None
        if i_scale is not None and i_bias is not None:
            turned, k, w = i_bias, kf.x.item(i_scale), kf.x.item(I_VH)
            F[i_bias, i_scale] = dt * w
            F[i_bias, I_VH] = dt * k
        if follows:
            # the velocity turns with the hull: v ← R(Ḣ dt) v, linearised for P
            _, _, _, vx, vy, w, *_ = state = _column(kf.x)
            s, c = math.sin(w * dt), math.cos(w * dt)
            F[I_VX, I_VX], F[I_VX, I_VY], F[I_VY, I_VX], F[I_VY, I_VY] = c, -s, s, c
            F[I_VX, I_VH] = dt * (-vx * s - vy * c)
            F[I_VY, I_VH] = dt * (vx * c - vy * s)
            state = _column(F @ kf.x)
            state[I_VX], state[I_VY] = vx * c - vy * s, vx * s + vy * c
            if turned is not None:
                state[turned] -= dt * k * w  # F x counted the product twice
        else:
            # F x in floats: each position plus dt times its rate (F's other rows are the
            # identity's), the sum BLAS makes of the same products and exact zeros
            state = _column(kf.x)
            if mobile:
                for i, j in self._rate_of:
                    state[i] += dt * state[j]
            if turned is not None:
                state[turned] += dt * k * w
        kf.P = np.dot(np.dot(F, kf.P), F.T)  # F P Fᵀ: np.dot is ``@`` at half the call cost
        if dt > 0:
            if dt != self._q_dt:  # the same step as last time (a steady tick): the same Q
                self._q_dt = dt
                self._q_block = white_noise_block(dt)
                pp, pv, _, vv = self._q_block
                # Q's cells are the same at every step: rewritten in place, its zeros kept
                self._q_dense.reshape(-1)[self._q_cells] = np.dot((pp, pv, vv, dt),
                                                                   self._q_blocks)
            # Q added whole: its zero cells leave P's as they are (x + 0 = x), one call
            # instead of an indexed read-add-write
            kf.P += self._q_dense
            if follows:
                pp, pv, _, vv = self._q_block
                self._along_track_noise(kf.P, state[I_H], pp, pv, vv)
            if self._wander is not None and self.i_bias is not None:
                extra, until = self._wander
                kf.P[self.i_bias, self.i_bias] += extra * dt
                if self.t + dt >= until:
                    self._wander = None
        self.t += dt
        self._tidy(state, updated=False)

    def _along_track_noise(self, P: np.ndarray, h: float, pp: float, pv: float,
                           vv: float) -> None:
        """A hull that moves along its bow changes its speed slowly and its course by
        turning, which the prediction already models: its acceleration noise is
        ``ALONG_TRACK`` of the dynamics' along the bow and ``ACROSS_TRACK`` across it, in
        place of the same in every direction (``along_track``, set by the owner, along the
        bow). ``h``: the predicted yaw."""
        q = self.config.xy_dynamics / 10.0 * FULL_SCALE_XY_ACCEL
        a = (-math.sin(h), math.cos(h))
        c = (math.cos(h), math.sin(h))
        along, across = self.along_track - 1.0, ACROSS_TRACK - 1.0
        # q ((along) a aᵀ + (across) c cᵀ), cell by cell in floats: the same operations as
        # numpy's outer products and sums, without a dozen small arrays
        delta = np.array([[q * (along * (a[i] * a[j]) + across * (c[i] * c[j]))
                           for j in (0, 1)] for i in (0, 1)])
        # X, Y and Ẋ, Ẏ are two runs of adjacent states: the four blocks are slices
        P[I_X:I_Y + 1, I_X:I_Y + 1] += pp * delta
        P[I_VX:I_VY + 1, I_VX:I_VY + 1] += vv * delta
        P[I_X:I_Y + 1, I_VX:I_VY + 1] += pv * delta
        P[I_VX:I_VY + 1, I_X:I_Y + 1] += pv * delta

    # ------------------------------------------------------------------ update

    def update(self, z: Observation | Sequence[Observation]) -> UpdateResult:
        """Gate and apply one observation or the observations of one time slice (taken to be
        at the filter's time: ``advance`` to them first). Returns each one's verdict."""
        if self.failure is not None:
            raise self.failure
        if isinstance(z, (list, tuple)) or isinstance(z, Sequence):  # the ABC's check is slow
            observations = list(z)
        else:
            observations = [z]
        if not observations:
            return UpdateResult()
        rows = self._linearise_all(observations)
        first, y, residuals = rows.first, rows.y, rows.residuals
        dot = np.dot  # the same BLAS product as ``@``, at half its call cost on 12×12
        PHt = dot(self.kf.P, rows.H.T)
        S = dot(rows.H, PHt)
        S.reshape(-1)[::len(y) + 1] += rows.r  # + R, on the diagonal
        d2 = [_block_d2(S, y, residuals, first[k], first[k + 1])
              for k in range(len(observations))]
        gates = self._gates
        alive = [k for k, (d, dof) in enumerate(d2)
                 if d <= (gates[dof] if dof in gates else self._gate(dof))]
        S_inv = None
        if len(alive) > 1:
            alive, S_inv = self._joint_test(alive, first, y, S, residuals)
        if alive:
            idx = None if len(alive) == len(observations) else _rows_of(alive, first)
            if idx is not None:
                S_inv = None
            elif S_inv is None and len(y) == 1:
                S_inv = np.array([[1.0 / S.item(0, 0)]])  # what inv() gives for 1×1, bit for bit
            self._apply(rows.x, rows.r, idx, y, S, PHt, S_inv)
        return UpdateResult([Verdict(obs, d2[k][0], d2[k][1], k in alive, residuals[first[k]])
                             for k, obs in enumerate(observations)])

    def _joint_test(self, alive: list[int], first: list[int], y: np.ndarray, S: np.ndarray,
                    residuals: list[float]) -> tuple[list[int], np.ndarray | None]:
        """The χ² test of the observations ``alive`` together (each passed alone): while they
        fail it, drop the one whose absence leaves the most consistent set (the largest χ²
        tail probability, in logs, which do not saturate as the CDF does). Returns those kept
        and, when they are the whole slice, S⁻¹ (the update reuses it)."""
        everything = len(first) - 1
        full_inverse: np.ndarray | None = None

        def d2_of(which: list[int]) -> tuple[float, int]:
            nonlocal full_inverse
            if len(which) == 1:
                return _block_d2(S, y, residuals, first[which[0]], first[which[0] + 1])
            if len(which) == everything:
                full_inverse = _inv(S)
                return float(np.dot(np.dot(y, full_inverse), y)), len(y)
            idx = _rows_of(which, first)
            yi = y[idx]
            return float(np.dot(yi, _solve(S[idx][:, idx], yi))), len(idx)

        alive = list(alive)
        while len(alive) > 1:
            joint, dof = d2_of(alive)
            if joint <= self._gate(dof):
                break

            def leave_out(k: int, keep: list[int] = alive) -> float:
                return chi2_logsf(*d2_of([j for j in keep if j != k]))

            alive.remove(max(alive, key=leave_out))
        return alive, full_inverse if len(alive) == everything else None

    def _gate(self, dof: int) -> float:
        gate = self._gates.get(dof)
        if gate is None:
            gate = self._gates[dof] = float(chi2_ppf(self.config.gate_probability, dof))
        return gate

    def _apply(self, x: list[float], r: np.ndarray, idx: np.ndarray | None, y: np.ndarray,
               S: np.ndarray, PHt: np.ndarray, S_inv: np.ndarray | None = None) -> None:  # noqa: N803
        """The Kalman correction with the accepted rows ``idx`` (None: all), reusing the
        innovation covariance the gating computed; ``x``: the prior state as floats."""
        if idx is None:
            Ss, PHts, yi = S, PHt, y
        else:
            Ss, PHts, yi, r = S[idx][:, idx], PHt[:, idx], y[idx], r[idx]
        if S_inv is None:
            S_inv = _inv(Ss)
        K = np.dot(PHts, S_inv)
        kf = self.kf
        rows = [i for i, hold in ((self.i_speed, self.hold_speed_scale),
                                  (self.i_drift, self.hold_drift)) if hold and i is not None]
        held = bool(rows)
        if held:
            K[rows, :] = 0.0
        state = [a + b for a, b in zip(x, np.dot(K, yi).tolist(), strict=True)]  # x + K y
        if held:  # a gain not the optimal one: P − K (P Hᵀ)ᵀ − (P Hᵀ) Kᵀ + K S Kᵀ
            KPHt = np.dot(K, PHts.T)
            kf.P = kf.P - KPHt - KPHt.T + np.dot(np.dot(K, Ss), K.T)
        else:
            # P − K S Kᵀ (= P − K (P Hᵀ)ᵀ), symmetrised by _tidy: one product instead of the
            # Joseph form's four, which on this filter's well-conditioned updates gives the
            # same P to 1e-12 (pinned by a test) at a third of the cost
            kf.P = kf.P - np.dot(K, PHts.T)
        kf.K, kf.y, kf.S, kf.SI = K, yi, Ss, S_inv
        self._last_r = r
        self._tidy(state)

    def _linearise_all(self, observations: list[Observation]) -> _Slice:
        """The observations of one slice linearised and stacked: Python floats per row into
        one list (H row by row, then the residuals, then the variances), made one array and
        viewed as the three (a few small arrays per observation cost more than the maths)."""
        x = _column(self.kf.x)
        n = self.dim
        rows: list[_Row] = []
        first = [0]
        for obs in observations:
            rows += self._rows(obs, x)
            first.append(len(rows))
        m = len(rows)
        at_y = m * n
        at_r = at_y + m
        flat = [0.0] * (at_r + m)
        for k, (z, hx, jacobian, variance, angular) in enumerate(rows):
            residual = z - hx
            if angular:
                residual = (residual + math.pi) % (2.0 * math.pi) - math.pi
            flat[at_y + k] = residual
            flat[at_r + k] = variance
            base = k * n
            for col, value in jacobian:
                flat[base + col] = value
        stacked = np.array(flat)
        return _Slice(stacked[at_y:at_r], stacked[:at_y].reshape(m, n), stacked[at_r:], first,
                      flat[at_y:at_r], x)

    def _linearise(self, obs: Observation) -> _Rows:
        """One observation linearised at the current state: measurement, prediction, Jacobian,
        noise and angle rows as arrays."""
        x = self.kf.x[:, 0].tolist()
        rows = self._rows(obs, x)
        H = np.zeros((len(rows), self.dim))
        for k, (_z, _hx, jacobian, _r, _a) in enumerate(rows):
            for col, value in jacobian:
                H[k, col] = value
        z, hx, _j, r, angular = zip(*rows, strict=True)
        return _Rows(np.array(z), np.array(hx), H, np.array(r), np.array(angular))

    def _rows(self, obs: Observation, x: list[float]) -> list[_Row]:
        """The rows of one observation at state ``x``: (measured, predicted, Jacobian as
        (state index, derivative) pairs, variance, is an angle)."""
        if isinstance(obs, Range):
            if obs.beacon not in self.beacons:
                raise KeyError(f"range to unknown beacon {obs.beacon!r}")
            b = self.beacons[obs.beacon]
            i = self._offset_index[obs.beacon]
            (px, py, pz), (dpx, dpy) = self._sensor_position(x, obs.lever)
            dx, dy, dz = px - b.x, py - b.y, pz - b.z
            d = max(math.sqrt(dx * dx + dy * dy + dz * dz), 1e-6)
            k = 1.0
            jacobian: list[tuple[int, float]] = []
            if self.i_scale is not None:
                k += x[self.i_scale]
                jacobian.append((self.i_scale, d))
            jacobian += [(I_X, k * dx / d), (I_Y, k * dy / d), (i, 1.0),
                         (I_H, k * (dx * dpx + dy * dpy) / d)]
            if self.i_z is not None:
                jacobian.append((self.i_z, k * dz / d))
            return [(obs.z, k * d + x[i], jacobian, obs.sigma**2, False)]
        if isinstance(obs, BodyVelocity):
            return self._body_velocity_rows(obs, x, self.i_speed,
                                            self.i_yaw_scale if obs.integrated else None,
                                            self.i_drift if obs.integrated else None)
        if isinstance(obs, Yaw):
            jacobian = [(I_H, 1.0)]
            predicted = x[I_H]
            if obs.age:
                jacobian.append((I_VH, -obs.age))
                predicted -= obs.age * x[I_VH]
            if self.i_bias is not None:
                jacobian.append((self.i_bias, 1.0))
                predicted += x[self.i_bias]
            return [(obs.z, predicted, jacobian, obs.sigma**2, True)]
        if isinstance(obs, Position):
            (px, py, _pz), (dpx, dpy) = self._sensor_position(x, obs.lever)
            variance = obs.sigma**2
            return [(obs.x, px, [(I_X, 1.0), (I_H, dpx)], variance, False),
                    (obs.y, py, [(I_Y, 1.0), (I_H, dpy)], variance, False)]
        if isinstance(obs, Depth):
            if self.i_z is None:
                raise ValueError("a depth observation needs the Z state (estimate_z)")
            jacobian = [(self.i_z, -1.0)]
            predicted = -x[self.i_z] - obs.lever[2]
            if self.i_tide is not None:
                jacobian.append((self.i_tide, 1.0))
                predicted += x[self.i_tide]
            return [(obs.z, predicted, jacobian, obs.sigma**2, False)]
        if isinstance(obs, Tide):
            if self.i_tide is None:
                raise ValueError("a tide observation needs the tide state (estimate_tide)")
            return [(obs.z, x[self.i_tide], [(self.i_tide, 1.0)], obs.sigma**2, False)]
        raise TypeError(f"not an observation: {obs!r}")

    @staticmethod
    def _body_velocity_rows(obs: BodyVelocity, x: list[float], i_speed: int | None = None,
                            i_yaw_scale: int | None = None, i_drift: int | None = None
                            ) -> list[_Row]:
        """Forward speed, starboard speed and yaw rate, those the sensor gives (ω × r at the
        sensor's lever arm); the speeds times (1 + the speed scale) when it is a state
        (``i_speed``), the yaw rate times (1 + the yaw scale) when the heading is its
        integral (``i_yaw_scale``), plus the rate the bias drifts at (``i_drift``): the
        heading's error is the integral of its rate's, so the rate reads the drift too.
        Without it a stretch without position data let the heading follow the rate as read,
        drift and all, while the bias held (Plaza1, the heading drifting 1.5°/s through its
        100 s without ranges: the bias fell 40° behind, 14 m off)."""
        s, c = math.sin(x[I_H]), math.cos(x[I_H])
        vx, vy = x[I_VX], x[I_VY]
        u = -vx * s + vy * c
        v = vx * c + vy * s
        lx, ly, _lz = obs.lever
        w = x[I_VH]
        g = 1.0 + x[i_speed] if i_speed is not None else 1.0
        forward, starboard = u + w * lx, v - w * ly
        parts: list[tuple[float | None, float, tuple[float, ...], float, float]] = [
            (obs.forward, g * forward, (-g * s, g * c, -g * v, g * lx), obs.sigma_forward,
             forward),
            (obs.starboard, g * starboard, (g * c, g * s, g * u, -g * ly),
             obs.sigma_starboard, starboard),
            (obs.yaw_rate, w, (0.0, 0.0, 0.0, 1.0), obs.sigma_yaw_rate, 0.0)]
        rows: list[_Row] = []
        if (i_yaw_scale is not None or i_drift is not None) and obs.yaw_rate is not None:
            # the integrated heading's own yaw rate reads (1 + κ) ω + ḃ: its row in place of ω's
            k = x[i_yaw_scale] if i_yaw_scale is not None else 0.0
            jacobian = [(I_VH, 1.0 + k)]
            predicted = (1.0 + k) * w
            if i_yaw_scale is not None:
                jacobian.append((i_yaw_scale, w))
            if i_drift is not None:
                jacobian.append((i_drift, 1.0))
                predicted += x[i_drift]
            rows.append((obs.yaw_rate, predicted, jacobian, obs.sigma_yaw_rate**2, False))
            del parts[-1]
        for measured, predicted, (d_vx, d_vy, d_h, d_vh), sigma, d_g in parts:
            if measured is None:
                continue
            jacobian = [(I_VX, d_vx), (I_VY, d_vy), (I_H, d_h), (I_VH, d_vh)]
            if i_speed is not None and d_g:
                jacobian.append((i_speed, d_g))
            rows.append((measured, predicted, jacobian, sigma**2, False))
        if not rows:
            raise ValueError("a BodyVelocity observation with no part")
        return rows

    def _sensor_position(self, x: list[float], lever: Lever
                         ) -> tuple[tuple[float, float, float], tuple[float, float]]:
        """Where a sensor at ``lever`` (body x starboard, y forward, z up) is in the local
        frame, and the derivative of its X, Y with respect to yaw."""
        lx, ly, lz = lever
        z = (x[self.i_z] if self.i_z is not None else 0.0) + lz
        if lx == 0.0 and ly == 0.0:
            return (x[I_X], x[I_Y], z), (0.0, 0.0)
        s, c = math.sin(x[I_H]), math.cos(x[I_H])
        px = x[I_X] + lx * c - ly * s
        py = x[I_Y] + lx * s + ly * c
        return (px, py, z), (-lx * s - ly * c, lx * c - ly * s)

    # ------------------------------------------------------------------ housekeeping

    def reinitialise(self, x: float, y: float, sigma_xy: float, yaw: float | None = None,
                     sigma_yaw: float | None = None) -> None:
        """Start again from a fix, e.g. the LSQ's after a divergence (spec 2.2.9): every state
        back to its prior, hidden ones included, since a diverged filter will have pushed its
        misfit into them too (offsets, scale and heading bias that "explain" a wrong position).
        Yaw defaults to the current estimate, with the configured start uncertainty."""
        if yaw is None:
            yaw = float(self.kf.x[I_H, 0] + (self.kf.x[self.i_bias, 0]
                                             if self.i_bias is not None else 0.0))
        self._initialise(x, y, yaw, sigma_xy, sigma_yaw)
        self.warnings.append(f"EKF re-initialised to ({x:.1f}, {y:.1f}) at t={self.t:.2f}")

    def reopen_offsets(self, beacons: Iterable[str], position_sigma: float = 0.0,
                       scale: bool = False) -> None:
        """What the ranges taught the filter, forgotten: the range offsets of ``beacons`` back
        to their priors, value and covariance (uncorrelated with the rest of the state), and
        the position's variance widened by ``position_sigma`` (m) squared, so that the next
        ranges set them again; with ``scale`` the range scale too (every beacon's ranges
        doubted: the scale they share learned what the offsets did). Inflating the
        offsets' variance alone leaves what a bad range taught them in the state. The block
        is the prior's, its rows otherwise cleared, and a diagonal grows: P stays positive
        definite."""
        names = list(beacons)
        index = [self._offset_index[name] for name in names]
        x, P = self.kf.x, self.kf.P
        for name, i in zip(names, index, strict=True):
            x[i, 0] = self.beacons[name].offset
        P[index, :] = 0.0
        P[:, index] = 0.0
        self._offset_prior(P, index)
        if scale and self.i_scale is not None:
            self._reset_states((self.i_scale,), (0.0,), self.config.sigma_range_scale**2)
        self.widen_position(position_sigma)

    def widen_position(self, sigma: float) -> None:
        """The position's variance widened by ``sigma`` (m) squared on each axis: the next
        fixes or ranges set it again. Only a diagonal grows: P stays positive definite."""
        P = self.kf.P
        P[I_X, I_X] += sigma**2
        P[I_Y, I_Y] += sigma**2

    def doubt_heading(self, sigma: float, wander: float = 0.0, until: float = 0.0) -> None:
        """Raise the heading's 1-σ to at least ``sigma`` (rad): the bias state's when it is
        estimated (the orientation sensor is what is doubted), else the yaw's. The position
        and body-velocity data then decide the heading, where the motion makes it observable
        (spec 2.2.10). With ``wander`` (rad/√s) the bias random walk is that strong until
        time ``until``: a bias found wandering once is let wander. Only a diagonal grows, so
        P stays positive definite."""
        i = self.i_bias if self.i_bias is not None else I_H
        if self.kf.P[i, i] < sigma * sigma:
            self.kf.P[i, i] = sigma * sigma
        if self.i_bias is not None and wander > self.config.yaw_bias_noise:
            self._wander = (wander**2 - self.config.yaw_bias_noise**2, until)

    def forget_turn(self, yaw: float | None) -> None:
        """What a yaw rate of the wrong sign taught, forgotten (:mod:`mavhelm.nav.rate_sense`;
        also when it is found agreeing again, as what the negated one taught is as wrong):
        the yaw rate back to zero and the yaw rate's scale to none, at their priors; with
        ``yaw`` (rad: the heading sensor's latest reading less its bias) the heading taken
        from it at the start's 1-σ. Each uncorrelated with the rest: P stays positive
        definite."""
        cfg = self.config
        self._reset_states((I_VH,), (0.0,), cfg.sigma_yaw_rate**2)
        if self.i_yaw_scale is not None:
            self._reset_states((self.i_yaw_scale,), (0.0,), cfg.sigma_yaw_scale**2)
        if yaw is not None and math.isfinite(yaw):
            self._reset_states((I_H,), (wrap_angle(yaw),), cfg.sigma_yaw**2)

    def reset_yaw_bias(self, bias: float, sigma_yaw: float) -> None:
        """The heading bias set to ``bias`` (the sensor's offset from the heading, rad) at
        1-σ ``sigma_yaw``, its drift rate to zero at its prior; both uncorrelated with the
        rest, the heading itself kept (:mod:`mavhelm.nav.alignment`: a heading held from the
        motion while the bias went stale)."""
        if self.i_bias is None:
            raise ValueError("reset_yaw_bias needs the heading-bias state")
        self._reset_states((self.i_bias,), (wrap_angle(bias),), sigma_yaw**2)
        if self.i_drift is not None:
            self._reset_states((self.i_drift,), (0.0,), self.config.sigma_yaw_drift**2)

    def shift_yaw_bias(self, step: float) -> None:
        """The heading bias moved by ``step`` (rad), its uncertainty kept: the sensor's own
        reading stepped (:mod:`mavhelm.nav.heading_kick`), the heading did not."""
        if self.i_bias is None:
            raise ValueError("shift_yaw_bias needs the heading-bias state")
        self.kf.x[self.i_bias, 0] = wrap_angle(self.kf.x.item(self.i_bias) + step)

    def realign_heading(self, bias: float, sigma_yaw: float, velocity: tuple[float, float],
                        sigma_velocity: float) -> float:
        """The heading taken from the motion (:mod:`mavhelm.nav.alignment`), the filter's
        heading wrong with its bias: the bias reset to ``bias`` (the sensor's offset from the
        course made good), the heading turned by as much (heading + bias still reads what
        the sensor reads), the velocity set to the course and speed made good; the heading
        and velocity uncorrelated with the rest, at 1-σ ``sigma_yaw`` and
        ``sigma_velocity``. Position, beacon offsets and the other learned states are kept.
        Returns the turn given to the heading (rad)."""
        if self.i_bias is None:
            raise ValueError("realign_heading needs the heading-bias state")
        turn = wrap_angle(self.kf.x.item(self.i_bias) - bias)
        self.reset_yaw_bias(bias, sigma_yaw)
        self.turn_heading(turn, sigma_yaw, velocity, sigma_velocity)
        return turn

    def turn_heading(self, turn: float, sigma_yaw: float, velocity: tuple[float, float],
                     sigma_velocity: float) -> None:
        """The heading turned by ``turn`` (rad) and the velocity set to ``velocity``, both
        uncorrelated with the rest at 1-σ ``sigma_yaw`` and ``sigma_velocity``: the heading
        the motion found, where no sensor reads it (no bias to set)."""
        self._reset_states((I_H,), (wrap_angle(self.kf.x.item(I_H) + turn),), sigma_yaw**2)
        self._reset_states((I_VX, I_VY), velocity, sigma_velocity**2)

    def with_yaw_bias(self) -> EKF:
        """This filter with a heading-bias state added (at zero, its prior 1-σ, uncorrelated),
        every other state and its covariance carried over: for an orientation sensor found
        wandering on a mission that did not declare ``EKF_YAW_BIAS``. A bias that keeps
        wandering only a state can take out; down-weighting the readings leaves them a share
        of the heading in proportion to the bias. Itself if it has one already.

        The bias comes with its drift rate when ``EKF_YAW_DRIFT`` says so (the default): a
        mission that declared no bias said nothing of its heading either, and an integrated
        one drifts at a rate a random walk trails (Plaza1, the heading drifting 180° within
        five minutes, no bias declared: 10.09 m RMS with the walk alone, 0.91 m with the
        rate, 0.42 m once its wander after being added was cut to five minutes). On a
        compass the rate learns the readings' lag in turns as drift, which costs little (a
        20 s GPS gap across a corner, simulated: 3.7 m worst error without it, 3.8 m with
        it)."""
        return self.with_states(estimate_yaw_bias=True)

    def with_states(self, **added: bool) -> EKF:
        """This filter with the hidden states that ``added`` switches on (``EKFConfig``
        fields, e.g. ``estimate_speed_scale=True``): each new one at zero with its prior 1-σ,
        uncorrelated; every other state and its covariance carried over. Itself if it holds
        them already."""
        config = replace(self.config, **added)
        if config == self.config:
            return self
        twin = EKF(self.t, 0.0, 0.0, beacons=self.beacons.values(), config=config)
        where = {name: i for i, name in enumerate(twin.state_names())}
        kept = [where[name] for name in self.state_names()]
        twin.kf.x[kept, 0] = self.kf.x[:, 0]
        twin.kf.P[np.ix_(kept, kept)] = self.kf.P
        twin.warnings, twin.rate_resets, twin.recoveries = (self.warnings, self.rate_resets,
                                                             self.recoveries)
        twin._good, twin._wander, twin.along_track = self._good, self._wander, self.along_track
        twin.follows_heading = self.follows_heading or config.velocity_follows_heading
        twin.hold_speed_scale = self.hold_speed_scale
        twin.hold_drift = self.hold_drift
        return twin

    def state_names(self) -> list[str]:
        """The state vector's entries by name, in order (the .xlog's columns)."""
        names = {I_X: "X", I_Y: "Y", I_H: "H", I_VX: "X_VEL", I_VY: "Y_VEL", I_VH: "H_VEL"}
        for i, name in ((self.i_z, "Z"), (self.i_vz, "Z_VEL"), (self.i_bias, "YAW_BIAS"),
                        (self.i_drift, "YAW_DRIFT"), (self.i_yaw_scale, "YAW_SCALE"),
                        (self.i_tide, "TIDE"),
                        (self.i_speed, "SPEED_SCALE"), (self.i_scale, "RANGE_SCALE")):
            if i is not None:
                names[i] = name
        for beacon, i in self._offset_index.items():
            names[i] = f"OFFSET_{beacon}"
        return [names[i] for i in range(self.dim)]

    def _reset_states(self, idx: tuple[int, ...], values: tuple[float, ...],
                      variance: float) -> None:
        x, P = self.kf.x, self.kf.P
        for i, value in zip(idx, values, strict=True):
            x[i, 0] = value
            P[i, :] = 0.0
            P[:, i] = 0.0
            P[i, i] = variance

    def _tidy(self, state: list[float], updated: bool = True) -> None:
        """Store the new ``state`` (floats) with yaw wrapped, keep P symmetric, recover from a
        broken covariance, reset silly rates, check the uncertainty limit.

        After a prediction (``updated`` False) only the state is checked: F P Fᵀ + Q of the
        finite, positive definite P the last update left is symmetric, positive definite and
        finite (it cannot overflow: the position-σ limit below takes the filter off-line
        long before), so the checks of P wait for the update, where rounding can break it
        (two numpy calls a tick less)."""
        kf, cfg = self.kf, self.config
        if updated:
            P = kf.P + kf.P.T
            P *= 0.5  # 0.5 (P + Pᵀ), one temporary fewer
            kf.P = P
            sound = self._healthy(state)
        else:
            sound = math.isfinite(sum(state)) or self._healthy(state)
        if sound:
            self._good = (state[I_X], state[I_Y], state[I_H])
        else:
            kf.x[:, 0] = state
            self._recover()
            state = _column(kf.x)
        yaw, vx, vy, yaw_rate = state[I_H], state[I_VX], state[I_VY], state[I_VH]
        state[I_H] = wrap_angle(yaw)
        if self.i_bias is not None:
            state[self.i_bias] = wrap_angle(state[self.i_bias])
        kf.x[:, 0] = state  # in place: one write of the whole state
        if not cfg.mobile:
            self._reset_states(self._rate_indices(), (0.0,) * len(self._rate_indices()), 0.0)
            vx = vy = yaw_rate = 0.0
        speed = math.hypot(vx, vy)
        if not speed <= cfg.max_speed:
            self._reset_states((I_VX, I_VY), (0.0, 0.0), cfg.sigma_velocity**2)
            self.rate_resets += 1
            self.warnings.append(f"EKF speed {speed:.1f} m/s exceeds {cfg.max_speed:g} m/s: "
                                 "velocity states reset to zero")
        if not abs(yaw_rate) <= cfg.max_yaw_rate:
            self._reset_states((I_VH,), (0.0,), cfg.sigma_yaw_rate**2)
            self.rate_resets += 1
            self.warnings.append(f"EKF yaw rate {yaw_rate:.2f} rad/s exceeds "
                                 f"{cfg.max_yaw_rate:.2f} rad/s: yaw rate state reset to zero")
        sigma = self.position_sigma()
        if not sigma <= cfg.max_position_sigma:
            self.failure = PositionLost(
                f"EKF position 1-sigma {sigma:.1f} m exceeds the limit "
                f"{cfg.max_position_sigma:g} m (MaxEKFPositionUncertainty) at t={self.t:.2f}")
            raise self.failure

    def _healthy(self, state: list[float] | None = None) -> bool:
        """A finite state and a covariance with no negative variance and no correlation
        beyond ±1: rounding in ``P − K S Kᵀ`` after an observation far more precise than the
        prior can break both, and the filter would then divide by or take roots of them.

        The common case is decided by one Cholesky factorisation: it succeeds only on a
        positive definite P, whose variances are positive and correlations inside ±1 (to
        rounding, far inside the 1e-6 allowed below). Only a P it refuses (a static
        vehicle's zero rate variances, or a broken one) is checked entry by entry. ``state``:
        x as floats, when the caller has them."""
        P = self.kf.P
        if state is None:
            state = _column(self.kf.x)
        total = np.add.reduce(P, None) + sum(state)  # not finite if any entry is not
        if math.isfinite(total) and dpotrf(P)[1] == 0:
            return True
        if not (all(math.isfinite(v) for v in state) and np.isfinite(P).all()):
            return False
        var = P.diagonal()
        if (var < 0.0).any():
            return False
        bound = np.sqrt(np.outer(var, var)) * (1.0 + 1e-6) + 1e-300
        return bool((np.abs(P) <= bound).all())

    def _recover(self) -> None:
        """Start again from the last sound position (the state's own if still finite) with the
        configured start uncertainty, and say so: a numerical failure is the filter's, not the
        vehicle's, so it is a warning and a re-initialisation, never an exception."""
        x = self.kf.x[:, 0]
        if np.isfinite(x[[I_X, I_Y, I_H]]).all():
            self._good = (float(x[I_X]), float(x[I_Y]), float(x[I_H]))
        px, py, yaw = self._good
        self._initialise(px, py, yaw, None, None)
        self.recoveries += 1
        self.warnings.append(f"EKF covariance lost its positive definiteness at "
                             f"t={self.t:.2f}: re-initialised to ({px:.1f}, {py:.1f})")

    def position_sigma(self) -> float:
        """The larger 1-σ of the position (square root of P's top eigenvalue for X, Y)."""
        P = self.kf.P
        pxx, pxy, pyy = P.item(0, 0), P.item(0, 1), P.item(1, 1)
        half_sum, half_diff = (pxx + pyy) / 2, (pxx - pyy) / 2
        return math.sqrt(max(half_sum + math.hypot(half_diff, pxy), 0.0))

    def position_covariance(self) -> np.ndarray:
        """The published 2×2 position covariance: P's, plus the data's lateness
        (``time_sigma``) times the velocity, along the track."""
        return np.array(self.position_covariance_floats())

    def position_covariance_floats(self) -> tuple[tuple[float, float], tuple[float, float]]:
        """:meth:`position_covariance` as floats (the same operations, cell by cell)."""
        P = self.kf.P
        vx, vy = (self.kf.x.item(I_VX), self.kf.x.item(I_VY)) if self.config.mobile \
            else (0.0, 0.0)
        late = self.config.time_sigma**2
        return ((P.item(0, 0) + late * (vx * vx), P.item(0, 1) + late * (vx * vy)),
                (P.item(1, 0) + late * (vy * vx), P.item(1, 1) + late * (vy * vy)))

    def estimate(self) -> Estimate:
        return self._estimate(self.t, _column(self.kf.x))

    def forecast(self, t: float) -> Estimate:
        """The estimate predicted forward to ``t`` without changing the filter (the spec's
        ``EKF_LAG``: the filter runs behind time, control needs now)."""
        x = _column(self.kf.x)
        dt = max(t - self.t, 0.0)
        x[I_X] += dt * x[I_VX]
        x[I_Y] += dt * x[I_VY]
        x[I_H] = wrap_angle(x[I_H] + dt * x[I_VH])
        if self.i_z is not None and self.i_vz is not None:
            x[self.i_z] += dt * x[self.i_vz]
        return self._estimate(t, x)

    def _estimate(self, t: float, x: list[float]) -> Estimate:
        var = self.kf.P.diagonal().tolist()
        late = self.config.time_sigma**2 if self.config.mobile else 0.0
        return Estimate(
            t=t, x=x[I_X], y=x[I_Y], yaw=x[I_H], x_vel=x[I_VX], y_vel=x[I_VY], yaw_vel=x[I_VH],
            sigma_x=_root(var[I_X] + late * x[I_VX] ** 2),
            sigma_y=_root(var[I_Y] + late * x[I_VY] ** 2), sigma_yaw=_root(var[I_H]),
            yaw_bias=x[self.i_bias] if self.i_bias is not None else 0.0,
            yaw_drift=x[self.i_drift] if self.i_drift is not None else 0.0,
            range_scale=x[self.i_scale] if self.i_scale is not None else 0.0,
            speed_scale=x[self.i_speed] if self.i_speed is not None else 0.0,
            yaw_scale=x[self.i_yaw_scale] if self.i_yaw_scale is not None else 0.0,
            offsets={name: x[i] for name, i in self._offset_index.items()},
            z=x[self.i_z] if self.i_z is not None else 0.0,
            z_vel=x[self.i_vz] if self.i_vz is not None else 0.0,
            tide=x[self.i_tide] if self.i_tide is not None else 0.0,
            sigma_z=_root(var[self.i_z]) if self.i_z is not None else 0.0,
        )


def _rows_of(which: list[int], first: list[int]) -> np.ndarray:
    """The stacked rows of the observations ``which`` (``first``: where each one's start)."""
    return np.concatenate([np.arange(first[k], first[k + 1]) for k in which])


def _column(a: np.ndarray) -> list[float]:
    """A column vector's entries as floats (the state is n × 1)."""
    return a.ravel().tolist()


def _root(variance: float) -> float:
    """A 1-σ from a variance that rounding may have taken a hair below zero."""
    return math.sqrt(max(variance, 0.0))


def _block_d2(S: np.ndarray, y: np.ndarray, residuals: list[float], a: int, b: int  # noqa: N803
              ) -> tuple[float, int]:
    """yᵀ S⁻¹ y of one observation's rows ``a:b`` (its χ², and its degrees of freedom).

    An observation has one to three rows; for so few, Cholesky in floats costs a fraction of
    a LAPACK solve's call and wrapping (the gate of every observation, every slice). The same
    value to rounding; a block that is not positive definite goes to LAPACK, which decides."""
    n = b - a
    if n == 1:
        return residuals[a] * residuals[a] / S.item(a, a), 1
    if n <= 3:
        low: list[list[float]] = []
        z: list[float] = []
        total = 0.0
        for i in range(n):
            row: list[float] = []
            for j in range(i + 1):
                s = S.item(a + i, a + j)
                other = row if i == j else low[j]
                for k in range(j):
                    s -= row[k] * other[k]
                if i == j:
                    if not s > 0.0:
                        break
                    row.append(math.sqrt(s))
                else:
                    row.append(s / low[j][j])
            else:
                zi = residuals[a + i]
                for k in range(i):
                    zi -= row[k] * z[k]
                zi /= row[i]
                z.append(zi)
                total += zi * zi
                low.append(row)
                continue
            break
        else:
            return total, n
    ya = y[a:b]
    return float(np.dot(ya, _solve(S[a:b, a:b], ya))), n


def _solve(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.linalg.solve`` for the filter's small systems: the same LAPACK routine (gesv), the
    same result bit for bit, without numpy's wrapping, which costs more than the solve."""
    _lu, _piv, solution, info = dgesv(a, b)
    if info != 0:
        raise np.linalg.LinAlgError("Singular matrix")
    return solution


def _read_only(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


_EYES = [_read_only(np.eye(n)) for n in range(8)]
"""Identities of the sizes a slice's innovation has (gesv copies its right-hand side)."""


def _inv(a: np.ndarray) -> np.ndarray:
    """``np.linalg.inv`` the same way: gesv against the identity."""
    n = len(a)
    return _solve(a, _EYES[n] if n < len(_EYES) else np.eye(n))
