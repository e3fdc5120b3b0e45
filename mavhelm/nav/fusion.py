"""The navigation filters run together (spec 2.2): time queue, lag, LSQ boot and watch, failure.

:class:`Fusion` is what pNav does with observations each tick, as a pure object of
(state, readings, time) — the navigator app and an offline replay drive the same code:

- **Time queue and lag** (spec 2.2.7): readings wait in a queue that sorts itself on time
  stamp; each tick the filter takes those up to ``now − lag``, in time order, one time slice
  (equal stamps) per update, then forecasts its estimate to ``now``. A reading older than what
  the filter has already processed arrives too late for it and is logged ``late``; set
  ``EKF_LAG`` to the age of the oldest data worth using (LBL replies: the listen window).
- **Fixed observations** (spec 2.2.8) are added once per tick at the filter's time.
- **LSQ** (spec 2.2.9): ranges also feed the least-squares filter. Its fixes boot the EKF when
  no start was given (a repeatable stream, :mod:`mavhelm.nav.boot_stream`), re-initialise it after a
  sustained disagreement, and prove observability: no fix for ``lsq_timeout`` seconds is a
  navigation failure. With no beacons, the first XY fix boots the EKF instead.
- **Channel rejection** (spec 2.2.6, ``LSQ_REJECTION``): a ranging sensor's channels are
  tested against their own recent consensus before either filter sees them.
- **Navigation failure** (spec 2.2.11): the EKF's uncertainty limit or the LSQ time-out takes
  every filter off-line for good; ``failure`` says why. The owner publishes it.

Logs (spec 2.2.5): ``olog`` collects one line per reading with its fate (accepted, rejected
with its χ² distance, late, outlier, waiting for the filter to boot), ``xlog`` one line per
tick with the state and the 1-σ of each state; the owner writes them out and clears them.
"""

from __future__ import annotations

import dataclasses
import heapq
import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from mavhelm.nav.alignment import MAX_SPREAD, MotionAlignment, Sense
from mavhelm.nav.beacon_watch import BeaconWatch
from mavhelm.nav.boot_stream import BootStream
from mavhelm.nav.chi_square import chi2_ppf
from mavhelm.nav.ekf import (
    ALONG_TRACK,
    EKF,
    I_H,
    I_VH,
    I_VX,
    I_VY,
    I_X,
    I_Y,
    Beacon,
    BodyVelocity,
    Depth,
    EKFConfig,
    Estimate,
    NavigationFailure,
    Observation,
    Position,
    PositionLost,
    Range,
    Tide,
    Yaw,
)
from mavhelm.nav.filter_safety import (
    BOOTED,
    FAILED,
    HEADING,
    LOST,
    REINITIALISED,
    RESTARTED,
    Decision,
    FilterSafety,
)
from mavhelm.nav.fix_watch import FixWatch
from mavhelm.nav.heading_kick import KICK_MIN, HeadingKick
from mavhelm.nav.heading_watch import (
    ADDED_WANDER_TIME,
    BIAS_WANDER_TIME,
    DOUBT_SIGMA,
    HEADING_DOUBT_SCALE,
    HEADING_MAX_SCALE,
    WANDER_NOISE,
    WANDER_TIME,
    HeadingWatch,
)
from mavhelm.nav.lsq import LSQ, Fix
from mavhelm.nav.noise_match import NoiseMatch
from mavhelm.nav.range_alignment import MIN_BEACONS as RANGE_MIN_BEACONS
from mavhelm.nav.range_alignment import MIN_TURN as RANGE_MIN_TURN
from mavhelm.nav.range_alignment import SENSE_EITHER, RangeAlignment, RangeHeading
from mavhelm.nav.range_alignment import WINDOW as RANGE_WINDOW
from mavhelm.nav.rate_sense import RateSense
from mavhelm.nav.sensor_channel import LSQ_REJECTION, RejectionRule, SensorChannel
from mavhelm.nav.sensors import (
    BEACON,
    FIXEDDEPTH,
    FIXEDHEADING,
    FIXEDSIDESLIP,
    FIXEDTIDE,
    FixedValue,
    Reading,
    fixed_observations,
)
from mavhelm.nav.settings import (
    EKF_LAG,
    EKF_SPEED_SCALE,
    LSQ_OFFSET,
    LSQ_TIMEOUT,
    LSQ_WINDOW,
    MAX_LSQ_EKF_DEVIATION,
    MAX_MEDIAN_LSQ_SHIFT,
    check_config,
    setting,
)
from mavhelm.nav.settings import LSQ as LSQ_SETTING
from mavhelm.nav.stuck_heading import StuckHeading
from mavhelm.nav.survey_check import Fit, SurveyCheck

BOOT_SIGMA = 5.0
"""m: the least 1-σ given to an LSQ fix that boots or resets the EKF. A fix's formal σ only
counts the ranges' noise; their unknown offsets and scale (the EKF's hidden states, not yet
learned at boot) move it by metres (Plaza: 4.5 m, from ranges 7 % long)."""
ANCHOR_AGE = 5.0
"""s: how old the LSQ's last fix may be to re-centre a filter the ranges found off
(:meth:`Fusion._forget`): a beacon cycle or two (Plaza: a fix every ~4 s)."""
UNDER_WAY_TIME = 20.0
"""s: how long after it starts moving a vehicle counts as cruising, its speed changing only
gently (the EKF's ``ALONG_TRACK``); while still and until then its speed may change as fast
as its course. Measured on a recorded simulator patrol on radio ranges without GPS (RMS /
max m): 2.76 / 18.0 with the gentle noise from the start (the filter trailed the
accelerating boat by up to 18 m in its first 40 s), 0.56 / 3.7 with 10 s, 0.55 / 3.5 with
20, 0.54 / 3.7 with 40; the same with GPS 0.35 / 2.5 → 0.29 / 0.8. NAV_SPEED on 1 Hz GPS and
a compass, 0.156 m/s RMS, stays so up to 20 s (40: 0.169)."""
FUTURE_TOLERANCE = 1.0
"""s: a reading stamped further ahead of the navigator's clock than this is refused."""
ALIGN_JUMP = math.radians(20.0)
"""rad: the least offset between the motion's and the filter's bias that is realigned (and
only beyond three times their combined 1-σ); a nearer one the bias state learns from the
data itself."""
ALIGN_RESET = math.radians(60.0)
"""rad: a heading this far out has misled every hidden state it touched (beacon offsets,
range scale, the beacons' and channels' verdicts): they start again from their priors at
the last fix, as a re-initialisation does."""
FIT_FAR = 3.0
"""A heading turned onto the ranges' but not so far that the filter restarts: where the
track fitted to the ranges puts the vehicle this many combined 1-σ from the filter, the
filter is told it (the position the wrong heading dead-reckoned is as wrong)."""
ALIGN_SIGMA = math.radians(10.0)
"""rad: the least 1-σ of a heading taken from the motion."""
ALIGN_SIGMA_VELOCITY = 0.5
"""m/s: the 1-σ of the velocity set from the last run made good."""
RANGE_CHECK_EVERY = 1.0
"""s between two asks of the heading from the ranges while a doubt lasts (``RANGE_WINDOW``
after it)."""
SENSE_TIME = 300.0
"""s after a yaw rate is found turning against a heading during which the motion is asked
which of the two turns the wrong way (:meth:`Fusion._test_sense`), and the filter takes
neither; untold by then, the rate is taken negated and the heading as it reads."""
SENSE_CHECK_EVERY = 2.0
"""s between two such asks (each fits the track both ways round, sixteen fits)."""


@dataclass
class NisTally:
    """One sensor's innovations: the χ² distances of its accepted readings and their degrees
    of freedom summed (``total / dof`` near 1: its noise told right), its readings, those
    rejected, and how many accepted ones fell below and above the two-sided 95 % χ² band of
    their degrees of freedom (95 % of them inside when the noise and the filter's
    uncertainty are both told right; below: both too cautious)."""

    total: float = 0.0
    dof: int = 0
    n: int = 0
    rejected: int = 0
    below: int = 0
    above: int = 0

    @property
    def inside(self) -> int:
        return self.n - self.rejected - self.below - self.above

    def add(self, d2: float, dof: int, accepted: bool) -> None:
        self.n += 1
        if not accepted:
            self.rejected += 1
            return
        self.total += d2
        self.dof += dof
        band = _NIS_BANDS.get(dof)
        if band is None:
            band = _NIS_BANDS[dof] = (chi2_ppf(0.025, dof), chi2_ppf(0.975, dof))
        if d2 < band[0]:
            self.below += 1
        elif d2 > band[1]:
            self.above += 1


_NIS_BANDS: dict[int, tuple[float, float]] = {}


@dataclass(frozen=True)
class Start:
    """A start pose known roughly (spec 2.2.4): position (m) and yaw (rad) with their 1-σ."""

    x: float
    y: float
    yaw: float = 0.0
    sigma_xy: float = 5.0
    sigma_yaw: float | None = None
    z: float = 0.0


@dataclass(frozen=True)
class FusionConfig:
    """The pNav block's filter settings: each ``setting(...)`` field is declared once, by the
    ``Param`` it names (default, range, unit); ``ekf`` and ``start`` are built from theirs."""

    ekf: EKFConfig = field(default_factory=EKFConfig)
    beacons: tuple[Beacon, ...] = setting(BEACON)
    lag: float = setting(EKF_LAG)
    start: Start | None = None
    lsq: bool = setting(LSQ_SETTING)
    lsq_window: float = setting(LSQ_WINDOW)
    lsq_timeout: float | None = setting(LSQ_TIMEOUT)
    lsq_offset: bool = setting(LSQ_OFFSET)
    divergence_distance: float = setting(MAX_LSQ_EKF_DEVIATION)
    max_median_shift: float = setting(MAX_MEDIAN_LSQ_SHIFT)
    fixed_depth: FixedValue | None = setting(FIXEDDEPTH)
    fixed_heading: FixedValue | None = setting(FIXEDHEADING)
    fixed_tide: FixedValue | None = setting(FIXEDTIDE)
    fixed_sideslip: FixedValue | None = setting(FIXEDSIDESLIP)
    rejection: tuple[RejectionRule, ...] = setting(LSQ_REJECTION)
    speed_scale: bool = setting(EKF_SPEED_SCALE)
    """Add the body-velocity speed-scale state at the first speed a body-velocity sensor
    gives (:meth:`Fusion._add_speed_scale`); the navigator says so only where a position
    sensor makes the scale observable."""
    follow_unless_speed: bool = False
    """A heading is sensed and body-velocity sensors are declared, but no ``FIXEDSIDESLIP``:
    until one of them gives a speed (a gyro gives only the yaw rate), the velocity follows
    the heading once under way, as for a mission without them (:mod:`mavhelm.nav.navigator`,
    ``_velocity_follows_heading``)."""
    heading_sensed: bool = True
    """An orientation sensor (or ``FIXEDHEADING``) gives the heading. Without one (wheel
    odometry and ranges, say) the heading is the yaw rate's integral from a start nobody
    knows, and the ranges' window (:mod:`mavhelm.nav.range_alignment`) fits the track the
    filter's own heading dead-reckons: the turn it finds is the filter's to make
    (:meth:`Fusion._align_from_ranges`)."""

    def __post_init__(self) -> None:
        check_config(self)


def describe(obs: Observation) -> str:
    """An observation's values for the .olog, compactly."""
    if isinstance(obs, Range):
        return f"beacon={obs.beacon} range={obs.z:.3f}"
    if isinstance(obs, Position):
        return f"x={obs.x:.3f} y={obs.y:.3f}"
    if isinstance(obs, Yaw):
        return f"yaw={obs.z:.4f}"
    if isinstance(obs, BodyVelocity):
        parts = [f"{k}={v:.3f}" for k, v in (("u", obs.forward), ("v", obs.starboard),
                                             ("w", obs.yaw_rate)) if v is not None]
        return " ".join(parts)
    if isinstance(obs, Depth):
        return f"depth={obs.z:.3f}"
    if isinstance(obs, Tide):
        return f"tide={obs.z:.3f}"
    return repr(obs)


class Fusion:
    """EKF and LSQ fed from one time queue. ``add(reading, now)`` as data arrive; once a tick
    ``step(now)``, which returns the EKF's estimate forecast to ``now`` (None until booted or
    after a failure). New LSQ fixes are in ``new_fixes`` after a step."""

    def __init__(self, config: FusionConfig) -> None:
        self.config = config
        EKF.prepare()
        beacons = list(config.beacons)
        self.lsq: LSQ | None = (LSQ(beacons, window=config.lsq_window,
                                    estimate_offset=config.lsq_offset)
                                if beacons and config.lsq else None)
        if self.lsq is not None and config.fixed_tide is not None:
            self.lsq.tide = config.fixed_tide.value
            self.lsq.tide_sigma = config.fixed_tide.sigma
        self.safety = FilterSafety(config.divergence_distance, config.lsq_timeout,
                                   config.max_median_shift)
        self.ekf: EKF | None = None
        self.horizon: float | None = None
        self.slices = 0
        """Time slices taken so far (each a prediction and an update): readings stamped apart
        within one tick make several, the filter's main cost."""
        self.failure: str | None = None
        self.new_fixes: list[Fix] = []
        self.decisions: list[Decision] = []
        """Everything the navigator decided (spec 2.2.9), in order; ``new_decisions`` this
        step's."""
        self.new_decisions: list[Decision] = []
        self.ekf_config = config.ekf
        """The filter's settings, those of every boot: ``config.ekf``, with a heading-bias state
        once one was added (:meth:`_add_yaw_bias`)."""
        self.heading_watch = HeadingWatch(config.ekf.estimate_yaw_bias)
        self.rate_sense = RateSense()
        """The body velocity sensors' yaw rates voted against the headings' turns: a rate of
        the wrong sense is negated (:mod:`mavhelm.nav.rate_sense`)."""
        self.stuck_heading = StuckHeading()
        """Heading sensors whose value stands while the vehicle turns, refused until it moves
        (:mod:`mavhelm.nav.stuck_heading`)."""
        self.heading_kick = HeadingKick()
        """Heading sensors that jump (:mod:`mavhelm.nav.heading_kick`)."""
        self.kick_offset = 0.0
        """rad: the heading sensor's jumps still standing (the bias has them; the ranges'
        window is given the readings without them)."""
        self.reversed_headings: set[str] = set()
        """Heading sensors the motion found read the wrong way round, where a rate turned
        against them (:meth:`_test_sense`): their readings are taken negated."""
        self._sense_test: tuple[float, float, str, str] | None = None
        """While a rate turns against a heading: (until when and when next the motion is
        asked which of the two is wrong, the rate, the heading sensor)."""
        self._speed_heard = False
        """Whether a body-velocity sensor has given a speed (not only a yaw rate)."""
        self._sense_open_at = -math.inf
        """When a sense test was last open: the ranges are not asked for the heading within
        a window of it (the track then turned with a rate in question)."""
        self._sense_said: bool | None = None
        """The motion's last answer to it, which the next must confirm."""
        self._heading_coupled = config.fixed_sideslip is not None
        """Whether the heading moves the position (a sideslip constraint, a body velocity with
        a speed): then the motion can tell a heading bias from a heading."""
        self.noise = NoiseMatch()
        self.survey_check = SurveyCheck({b.name: b for b in config.beacons})
        self._anchored = False
        """Whether a position fix (GPS, an XY reading) has been accepted: it anchors the
        beacons' offsets, so they can take the blame for a beacon off its survey even where
        the track cannot tell which one (:mod:`mavhelm.nav.beacon_watch`)."""
        self.beacon_watch = self._new_beacon_watch()
        self.alignment = MotionAlignment()
        """The orientation sensor's offset from the course made good, for a heading far out
        (:meth:`_align`)."""
        self.fix_watch = FixWatch()
        """Each position sensor's refused fixes, for a filter gone astray (:meth:`_watch_fix`)."""
        self._last_fix: tuple[float, float, float] | None = None
        """(x, y, 1-σ) of the latest position fix, where a realignment far out restarts."""
        self._lsq_fix: Fix | None = None
        """The LSQ's latest fix: where a filter the ranges found off is re-centred."""
        self.range_alignment = RangeAlignment({b.name: b for b in config.beacons})
        """The heading sensor's offset told by the ranges, asked only while in doubt
        (:meth:`_align_from_ranges`)."""
        self._range_doubt = (-math.inf, -math.inf)
        """(until when the ranges are asked for the heading, when next)."""
        self._range_heading: RangeHeading | None = None
        """The ranges' last answer, which the next must confirm."""
        self._mirrored_said: bool | None = None
        """The ranges' last answer to whether the headings (a sensor's, else the yaw rate's
        integral) turn the wrong way round (:meth:`_mirror_from_ranges`)."""
        self._questioned = (-math.inf, 0.0)
        """(when last asked, s under way since the ranges were first asked) for
        :meth:`_heading_in_question`."""
        self._heading_scale = (1.0, 0.0)
        """(σ scale of the heading readings, until when): a doubted heading without a bias
        state to absorb its error is down-weighted."""
        self.nis: dict[str, NisTally] = {}
        """Per sensor, its innovations' tally."""
        self._olog: list[str | OlogEntry] = []
        self._xlog: list[str | XlogEntry] = []
        """The .olog and .xlog lines since they were last taken: in a tick only what they
        need is kept, formatted once taken, in the loop's idle time (:meth:`take_olog`)."""
        self.warnings: list[str] = []
        self.counts = {"accepted": 0, "rejected": 0, "late": 0, "future": 0, "outlier": 0,
                       "stuck": 0, "waiting": 0, "offline": 0}
        self.reinitialisations = 0
        self.fixes = 0
        self.boot_fix: Fix | None = None
        self._queue: list[tuple[float, int, Reading]] = []
        self._seq = itertools.count()
        self._stream = BootStream()
        self._last_yaw: float | None = None
        self._heading_sensor: str | None = None
        """The sensor of the latest heading reading (``_last_yaw``)."""
        self._rules = {r.sensor: r for r in config.rejection}
        self._channels: dict[tuple[str, str], SensorChannel] = {}
        self._xlog_header = False
        self._lost = False
        self.logging = True
        """Build the .olog/.xlog lines; an owner with nowhere to write them turns it off."""

    @property
    def online(self) -> bool:
        return self.failure is None

    # ------------------------------------------------------------------ input

    def add(self, reading: Reading, now: float) -> None:
        t = reading.obs.t
        if self.failure is not None:
            self._log(reading, "offline")
        elif t > now + FUTURE_TOLERANCE:
            self._log(reading, "future")
        elif self.horizon is not None and t < self.horizon:
            self._log(reading, "late", f"{self.horizon - t:.2f}s")
        else:
            heapq.heappush(self._queue, (t, next(self._seq), reading))

    # ------------------------------------------------------------------ the tick

    def step(self, now: float) -> Estimate | None:
        self.new_fixes = []
        self.new_decisions = []
        if self.failure is not None:
            return None
        horizon = now - self.config.lag
        if self.horizon is not None and horizon < self.horizon:
            horizon = self.horizon
        self.safety.start(horizon)
        try:
            if self.ekf is None and self.config.start is not None and not self._lost:
                self._boot_at_start(horizon)
            sliced = self._drain(horizon)
            self.horizon = horizon
            self._tick_fixed(horizon, sliced)
            self._check_lsq(horizon)
        except PositionLost as exc:
            if self.lsq is None:
                self._fail(str(exc))
                return None
            self._lose(str(exc), horizon)
        except NavigationFailure as exc:
            self._fail(str(exc))
            return None
        except (np.linalg.LinAlgError, ValueError, ArithmeticError) as exc:
            self._restart(exc)
        if self.ekf is None:
            return None
        if self.logging:
            self._xlog_row()
        self.warnings.extend(self.ekf.warnings)
        self.ekf.warnings.clear()
        return self._forecast(now)

    def _drain(self, horizon: float) -> bool:
        """Every queued slice up to ``horizon``, in time order; whether there was one."""
        sliced = False
        while self._queue and self._queue[0][0] <= horizon:
            t = self._queue[0][0]
            batch = []
            while self._queue and self._queue[0][0] == t:
                batch.append(heapq.heappop(self._queue)[2])
            self._slice(t, batch)
            self.slices += 1
            sliced = True
        return sliced

    def _tick_fixed(self, horizon: float, sliced: bool) -> None:
        """A tick with data leaves the filter at its newest slice, and the forecast takes it
        on to now; a tick without (or with fixed observations to apply) predicts to the
        horizon, so a filter starved of data still grows uncertain, and fails, in time."""
        if self.ekf is None:
            return
        cfg = self.config
        fixed = fixed_observations(horizon, cfg.fixed_depth, cfg.fixed_heading, cfg.fixed_tide,
                                   cfg.fixed_sideslip)
        if not fixed and sliced:
            return
        self.ekf.advance(horizon)
        if not fixed:
            return
        for v in self.ekf.update(fixed).verdicts:
            if not v.accepted:
                self._olog.append(f"{horizon:.3f} fixed {type(v.obs).__name__} "
                                 f"{describe(v.obs)} rejected {v.d2:.2f}")

    def _restart(self, exc: Exception) -> None:
        """A numerical failure inside the filter (a singular innovation, a non-finite value):
        drop the EKF, which boots again from the start, the LSQ or the next fix, and say so;
        nothing escapes the tick."""
        if self.ekf is not None:
            self.warnings.extend(self.ekf.warnings)
        t = self.ekf.t if self.ekf is not None else (self.horizon or 0.0)
        self.ekf = None
        self._stream.clear()
        self.reinitialisations += 1
        self._decide(Decision(t, RESTARTED, f"EKF numerical failure ({type(exc).__name__}: "
                              f"{exc}): the filter starts again"))

    def _lose(self, why: str, t: float) -> None:
        """The EKF is lost (MaxEKFPositionUncertainty): off-line until the LSQ's next
        repeatable fixes boot it again (the original navigator's reset)."""
        if self.ekf is not None:
            self.warnings.extend(self.ekf.warnings)
        self.ekf = None
        self._lost = True
        self._stream.clear()
        self.reinitialisations += 1
        self.alignment.clear()
        self._decide(Decision(t, LOST, f"{why}: EKF off-line until the LSQ boots it again"))

    def _decide(self, decision: Decision) -> None:
        """Record a decision where the operator and the logs see it."""
        self.decisions.append(decision)
        self.new_decisions.append(decision)
        self.warnings.append(str(decision))
        line = f"# {decision.t:.3f} decision {decision}"
        self._olog.append(line)
        if self._xlog_header:
            self._xlog.append(line)

    def _forecast(self, now: float) -> Estimate:
        """The lagged estimate brought forward to ``now`` (spec 2.2.7), the filter itself left
        as it is. Across a lag of seconds a constant-velocity guess misses every turn begun
        since (a boat at 3 m/s turning at a corner: 5–7 m in 3.5 s, measured), while the
        readings of those seconds are already waiting in the queue: the heading and body
        velocity among them are dead-reckoned forward, the rest wait for the filter."""
        ekf = self.ekf
        assert ekf is not None
        newer = sorted(item for item in self._queue if item[0] <= now)
        if not newer:
            return ekf.forecast(now)
        e = ekf.estimate()
        t, x, y, yaw = e.t, e.x, e.y, e.yaw
        vx, vy, w = e.x_vel, e.y_vel, e.yaw_vel
        body: tuple[float, float] | None = None
        reversed_ = self.rate_sense.reversed
        _, _, unsure_rate, unsure_heading = self._sense_test or (0.0, 0.0, None, None)
        for ti, _, reading in newer:
            dt = ti - t
            if dt > 0:
                x, y, yaw, t = x + vx * dt, y + vy * dt, yaw + w * dt, ti
            obs = reading.obs
            if isinstance(obs, Yaw) and reading.sensor.name != unsure_heading:
                z = -obs.z if reading.sensor.name in self.reversed_headings else obs.z
                yaw = z - (e.yaw_bias + e.yaw_drift * (ti - e.t))  # the bias as it drifted
            elif isinstance(obs, BodyVelocity):
                if obs.yaw_rate is not None and _rate_label(reading) != unsure_rate:
                    w = -obs.yaw_rate if _rate_label(reading) in reversed_ else obs.yaw_rate
                    if obs.integrated:  # as the filter reads it: (1 + κ) ω + ḃ
                        w = (w - e.yaw_drift) / (1.0 + e.yaw_scale)
                if obs.forward is not None:
                    body = (obs.forward, obs.starboard or 0.0)
            else:
                continue
            if body is not None:
                s, c = math.sin(yaw), math.cos(yaw)
                vx, vy = -body[0] * s + body[1] * c, body[0] * c + body[1] * s
        dt = now - t
        x, y, yaw = x + vx * dt, y + vy * dt, yaw + w * dt
        return dataclasses.replace(e, t=now, x=x, y=y, yaw=math.remainder(yaw, 2 * math.pi),
                                   x_vel=vx, y_vel=vy, yaw_vel=w,
                                   z=e.z + e.z_vel * max(now - e.t, 0.0))

    def _slice(self, t: float, batch: list[Reading]) -> None:
        kept = [r for r in batch if self._channel_agrees(r)]
        if self.reversed_headings:
            kept = [dataclasses.replace(r, obs=dataclasses.replace(r.obs, z=-r.obs.z))
                    if isinstance(r.obs, Yaw) and r.sensor.name in self.reversed_headings
                    else r for r in kept]
        if self.ekf is not None:
            kept = self._not_stuck(t, kept, self.ekf.x.item(I_VH))
        for r in kept:
            if isinstance(r.obs, Yaw):
                self._last_yaw, self._heading_sensor = r.obs.z, r.sensor.name
        kept = self._sensed(t, kept)
        if self.ekf is not None:
            self._kicked(t, kept)
        fixes = self._feed_lsq(kept)
        self._feed_alignment(kept, fixes)
        if self.ekf is not None:
            cruising = self.heading_watch.under_way_for(t) >= UNDER_WAY_TIME
            # no heading to take the speed along while it is open which way the sensor reads
            self.ekf.along_track = ALONG_TRACK if cruising and self._sense_test is None else 1.0
            if self.config.follow_unless_speed:
                self._speed_heard = self._speed_heard or any(
                    isinstance(r.obs, BodyVelocity) and r.obs.forward is not None for r in kept)
                self.ekf.follows_heading = cruising and not self._speed_heard
            # nor is the speeds' scale learned from a track the heading may have turned
            # (the bias's drift neither) while the ranges are still asked for the heading
            in_question = self._heading_in_question(t)
            self.ekf.hold_speed_scale = self._sense_test is not None or in_question
            self.ekf.hold_drift = in_question
            self.ekf.advance(t)
            x = self.ekf.x
            self.survey_check.move(t, x.item(I_X), x.item(I_Y), x.item(I_VX), x.item(I_VY))
        for fix in fixes:
            self._watch(fix)
        if self.ekf is None:
            self._try_boot(t, kept, fixes)
            if self.ekf is None:
                for r in kept:
                    self._log(r, "waiting")
                return
        if self._sense_test is not None:
            self._sense_open_at = t
            kept = self._undecided(kept)
        if kept:
            self._update(t, kept)
        self._align(t)
        self._align_from_ranges(t)
        self._test_sense(t)

    def _not_stuck(self, t: float, kept: list[Reading], yaw_rate: float) -> list[Reading]:
        """The slice without the headings of a sensor found stuck
        (:mod:`mavhelm.nav.stuck_heading`)."""
        out = []
        for r in kept:
            if isinstance(r.obs, Yaw):
                use, decision = self.stuck_heading.reading(t, r.sensor.name, r.obs.z, yaw_rate)
                if decision is not None:
                    self._decide(decision)
                if not use:
                    self._log(r, "stuck")
                    continue
            out.append(r)
        return out

    def _sensed(self, t: float, kept: list[Reading]) -> list[Reading]:
        """The slice's yaw rates and headings voted (:mod:`mavhelm.nav.rate_sense`); the
        readings with each reversed rate negated."""
        sense = self.rate_sense
        for r in kept:
            obs = r.obs
            if isinstance(obs, BodyVelocity) and obs.yaw_rate is not None:
                sense.rate(_rate_label(r), obs.t, obs.yaw_rate)
            elif isinstance(obs, Yaw):
                for finding in sense.heading(f"sensor {r.sensor.name} ({r.sensor.source})", obs.t,
                                             obs.z):
                    told = self.config.beacons or self._last_fix is not None
                    self.range_alignment.restore_refused()
                    self._sense_test = ((t + SENSE_TIME, t, finding.sensor, r.sensor.name)
                                        if finding.reversed and told else None)
                    self._sense_said = None
                    what = "" if not finding.reversed else (
                        "; neither is taken until the motion tells which" if told
                        else "; the rate is taken negated (no ranges or fixes to tell which)")
                    self._decide(Decision(t, HEADING, str(finding) + what))
                    ekf = self.ekf
                    if ekf is not None:  # what the rate taught, read either way, forgotten
                        bias = ekf.x.item(ekf.i_bias) if ekf.i_bias is not None else 0.0
                        ekf.forget_turn(obs.z - bias)
        if not sense.reversed:
            return kept
        return [dataclasses.replace(r, obs=dataclasses.replace(r.obs, yaw_rate=-r.obs.yaw_rate))
                if isinstance(r.obs, BodyVelocity) and r.obs.yaw_rate is not None
                and _rate_label(r) in sense.reversed else r for r in kept]

    def _undecided(self, kept: list[Reading]) -> list[Reading]:
        """While it is open which of a yaw rate and a heading turns the wrong way, the
        filter takes neither: the motion holds the heading meanwhile."""
        assert self._sense_test is not None
        _, _, rate, heading = self._sense_test
        out = []
        for r in kept:
            if isinstance(r.obs, Yaw) and r.sensor.name == heading:
                continue
            if isinstance(r.obs, BodyVelocity) and r.obs.yaw_rate is not None \
                    and _rate_label(r) == rate:
                if r.obs.forward is None and r.obs.starboard is None:
                    continue
                r = dataclasses.replace(r, obs=dataclasses.replace(r.obs, yaw_rate=None))
            out.append(r)
        return out

    def _feed_alignment(self, kept: list[Reading], fixes: list[Fix]) -> None:
        """Headings, astern runs, then the slice's fixes (the LSQ's, else an XY sensor's)."""
        alignment, ekf = self.alignment, self.ekf
        bias = float(ekf.x[ekf.i_bias, 0]) if ekf is not None and ekf.i_bias is not None else 0.0
        held = ekf.x.item(I_H) if ekf is not None else None
        # without beacons the ranges are never asked (``_align_from_ranges``): not fed
        ranges = self.range_alignment if self.range_alignment.beacons else None
        stand_in = held if ranges is not None and not self.config.heading_sensed else None
        for r in kept:
            obs = r.obs
            if isinstance(obs, Yaw):
                alignment.add_heading(obs.t, obs.z, bias, held)
                if ranges is not None:
                    ranges.add_heading(obs.t, obs.z - self.kick_offset)
            elif isinstance(obs, BodyVelocity) and obs.forward is not None:
                alignment.add_body_velocity(obs.t, obs.forward, obs.starboard)
                if ranges is not None:
                    if stand_in is not None:  # no sensor: the heading the filter holds
                        ranges.add_heading(obs.t, stand_in)
                    ranges.add_body_velocity(obs.t, obs.forward, obs.starboard)
            elif isinstance(obs, Range) and ranges is not None:
                # before the boot too: a filter booted under way asks for the heading at once
                z = ekf.x.item(ekf.i_z) if ekf is not None and ekf.i_z is not None else 0.0
                height = z + obs.lever[2]
                weighed = self._weighted(obs, r.sensor.name)  # its σ as the filter weighs it
                sigma = weighed.sigma if isinstance(weighed, Range) else obs.sigma
                ranges.add_range(obs.t, obs.beacon, obs.z, sigma, height)
        if self.lsq is not None:
            for fix in fixes:
                alignment.add_fix(fix.t, fix.x, fix.y)
                self._last_fix = (fix.x, fix.y, max(fix.sigma, fix.rms, BOOT_SIGMA))
                self._lsq_fix = fix
            return
        for r in kept:
            if isinstance(r.obs, Position):
                alignment.add_fix(r.obs.t, r.obs.x, r.obs.y)
                self._last_fix = (r.obs.x, r.obs.y, max(2.0 * r.obs.sigma, 1.0))

    def _align(self, t: float) -> None:
        """A heading far out, taken from the motion (:mod:`mavhelm.nav.alignment`), where the
        heading moves the position. When the runs made good put the filter's own heading
        more than ``ALIGN_JUMP`` (and three times the combined 1-σ) off the course, the
        heading is turned onto it and the bias set to the sensor's offset from the course;
        beyond ``ALIGN_RESET`` the hidden states start again at the last fix. When the
        heading held (from the motion, the sensor refused as contradicting it) but the bias
        went stale beyond the same bound, the bias alone is set, to the sensor's offset from
        the heading held: the courses of fixes metres apart are only good to tens of
        degrees (Plaza1, a compass both wandering and kicked: its bias about 150° stale
        after 450 s refused, the heading right to 5°, turned by the bias's change as if it had
        followed the sensor, 100 m off and re-initialised). Nearer, the bias state learns
        the offset itself."""
        ekf = self.ekf
        if ekf is None or not self._heading_coupled:
            return
        found = self.alignment.estimate()
        if found is None:
            return
        i = ekf.i_bias
        bias, var = (float(ekf.x[i, 0]), float(ekf.P[i, i])) if i is not None else (0.0, 0.0)
        var_heading = float(ekf.P[I_H, I_H])
        heading_wrong = found.told and abs(found.heading_error) >= max(
            ALIGN_JUMP, 3.0 * math.sqrt(var_heading + found.spread**2))
        if heading_wrong:
            offset = math.remainder(bias + found.correction, 2 * math.pi)
        elif (abs(found.heading_error) < ALIGN_JUMP and found.stale_spread <= MAX_SPREAD
              and abs(found.stale) >= max(ALIGN_JUMP,
                                          3.0 * math.sqrt(var + found.stale_spread**2))):
            offset = math.remainder(bias + found.stale, 2 * math.pi)
        else:
            return
        if ekf.i_bias is None:
            ekf = self._add_yaw_bias(t)
        if heading_wrong and abs(found.heading_error) > ALIGN_RESET and self._last_fix is not None:
            x, y, sigma = self._last_fix
            ekf.reinitialise(x, y, sigma)
            ekf.warnings.pop()  # the decision below says it
            self.noise = NoiseMatch()
            self.beacon_watch = self._new_beacon_watch()
            self.survey_check.clear()
        if heading_wrong:
            turn = ekf.realign_heading(offset, max(found.spread, ALIGN_SIGMA),
                                       found.velocity, ALIGN_SIGMA_VELOCITY)
            what = (f"heading taken from the motion: the orientation sensor reads "
                    f"{math.degrees(offset):+.0f}° off the course made good over {found.runs} "
                    f"runs (spread {math.degrees(found.spread):.0f}°); heading turned by "
                    f"{math.degrees(turn):+.0f}°")
        else:
            ekf.reset_yaw_bias(offset, max(found.stale_spread, ALIGN_SIGMA))
            what = (f"heading bias taken from the motion: the orientation sensor reads "
                    f"{math.degrees(offset):+.0f}° off the heading the filter held, which "
                    f"the course made good over {found.runs} runs confirms (to "
                    f"{math.degrees(found.heading_error):+.0f}°); the heading kept")
        ekf.doubt_heading(DOUBT_SIGMA, WANDER_NOISE, t + BIAS_WANDER_TIME)
        self.alignment.clear()
        self._decide(Decision(t, HEADING, what))

    def _heading_in_question(self, t: float) -> bool:
        """Whether the heading is in question: the ranges are asked for it (a doubt, or a
        boot whose heading is the sensor's) and could answer (``RANGE_MIN_BEACONS``), for
        at most ``RANGE_WINDOW`` s under way, the time the ranges need to tell it. While
        it is, the hidden states a wrong heading would teach (the speed scale, the bias's
        drift) are held: a heading 90° out when the vehicle first moved taught Plaza1's
        filter a speed scale of +0.42 and a drift of −1.6°/s within ten seconds, while the
        bias itself was learned, and it ran 1.5-3 m off for four minutes after (1.02 m
        RMS; 0.45 m held)."""
        until = self._range_doubt[0]
        last, moving = self._questioned
        if t > until or len(self.config.beacons) < RANGE_MIN_BEACONS:
            self._questioned = (t, 0.0)
            return False
        if self.heading_watch.under_way_for(t) > 0.0:
            moving += max(t - last, 0.0)
        self._questioned = (t, moving)
        return moving <= RANGE_WINDOW

    def _doubt_from_ranges(self, t: float, until: float | None = None) -> None:
        """A reason to doubt the heading: the ranges are asked for it until they confirm
        the filter or correct it, for ``RANGE_WINDOW`` s at most unless ``until`` says."""
        was, next_at = self._range_doubt
        self._range_doubt = (max(was, t + RANGE_WINDOW if until is None else until),
                             next_at if t <= was else t)

    def _align_from_ranges(self, t: float) -> None:
        """While in doubt, a heading far out taken from the ranges
        (:mod:`mavhelm.nav.range_alignment`): the heading turned onto the one they fit, and
        beyond ``ALIGN_RESET`` the filter started again where they put the vehicle."""
        until, next_at = self._range_doubt
        ekf = self.ekf
        if (ekf is None or t > until or t < next_at or not self._heading_coupled
                or not self.config.beacons or t - self._sense_open_at < RANGE_WINDOW):
            return
        self._range_doubt = (until, t + RANGE_CHECK_EVERY)
        near = self._last_fix[:2] if self._last_fix is not None else (ekf.x.item(I_X),
                                                                      ekf.x.item(I_Y))
        if self._mirror_from_ranges(t, near):
            return
        found = self.range_alignment.estimate(near)
        if found is not None and self.kick_offset:  # the sensor as it reads, its jump with it
            found = dataclasses.replace(
                found, bias=math.remainder(found.bias + self.kick_offset, 2 * math.pi))
        last, self._range_heading = self._range_heading, found
        if (found is None or last is None or found.t - last.t > 2 * RANGE_CHECK_EVERY
                or abs(math.remainder(found.bias - last.bias, 2 * math.pi)) > MAX_SPREAD):
            return  # two answers in a row must agree: a stuck sensor's track bends them
        bias = ekf.x.item(ekf.i_bias) if ekf.i_bias is not None else 0.0  # none unsensed
        if abs(math.remainder(found.bias - bias, 2 * math.pi)) < RANGE_MIN_TURN:
            self._range_doubt, self._range_heading = (-math.inf, -math.inf), None
            return  # the filter holds the heading the ranges say: the doubt is over
        self._heading_from_ranges(t, found, bias,
                                  abs(math.remainder(found.bias - bias, 2 * math.pi))
                                  > ALIGN_RESET)

    def _mirror_from_ranges(self, t: float, near: tuple[float, float]) -> bool:
        """Where no heading turns against a yaw rate, a rate of the wrong sense goes unseen:
        without a heading sensor, or where the heading sensor is the rate's own integral
        read the wrong way round with it (an odometer or an AHRS giving its clockwise
        heading and rate where pNav's are anticlockwise). The track the headings
        dead-reckon then bends the wrong way through every turn: where it fits the ranges
        only mirrored (:meth:`RangeAlignment.sense`), twice in a row, the heading sensor
        and every rate heard are taken the other way round from now on, the window and the
        filter's heading mirrored with them and what they taught forgotten; the ranges'
        next answers turn the heading (with a sensor, at once: it reads anywhere now).
        Whether it did. (Plaza1, its odometry's heading and rate both negated: 8-14 m RMS,
        the filter re-initialised and turned by the ranges over and over.)"""
        said, self._mirrored_said = self._mirrored_said, self.range_alignment.sense(near)
        if not (said and self._mirrored_said):
            return False
        self._mirrored_said = None
        ekf = self.ekf
        assert ekf is not None
        sense = self.rate_sense
        sense.mirror()
        rates = ", ".join(sense.heard) or "none"
        self.range_alignment.mirror()
        self.alignment.clear()
        self._range_heading = None
        sensor = self._heading_sensor
        if not self.config.heading_sensed or sensor is None:
            ekf.forget_turn(-ekf.x.item(I_H))
            self._doubt_from_ranges(t)
            self._decide(Decision(t, HEADING, (
                "with no heading sensor, the track the yaw rate turns fits the ranges only "
                "mirrored: the rate " + rates + " is of the wrong sense, taken negated from "
                "now on (check its sign: pNav's yaw rate is anticlockwise-positive, a NED "
                "gyro's clockwise)" if sense.reversed else
                "with no heading sensor, the track the yaw rate turns fits the ranges as it "
                "reads after all: the rate taken as it reads again")))
            return True
        self.reversed_headings.symmetric_difference_update({sensor})
        self.heading_kick = HeadingKick()  # its readings negated from now: no step
        self.kick_offset = -self.kick_offset  # as the window's headings, mirrored
        if self._last_yaw is not None:
            self._last_yaw = -self._last_yaw
        self._retake_heading()
        self._decide(Decision(t, HEADING, (
            f"the track the heading of sensor {sensor} dead-reckons fits the ranges only "
            f"mirrored, and the yaw rate ({rates}) turns with it: both are of the wrong "
            f"sense, taken negated from now on (check their convention: S_YAW and the yaw "
            f"rate anticlockwise, S_HEADING clockwise from north)"
            if sensor in self.reversed_headings else
            f"the track the heading of sensor {sensor} dead-reckons fits the ranges only "
            f"as it reads after all: it and the yaw rate ({rates}) taken as they read")))
        self._heading_after_sense(t, near, None, restart=True)
        return True

    def _heading_from_ranges(self, t: float, found: RangeHeading, bias: float,
                             restarted: bool) -> None:
        """The heading turned onto the one the ranges fit (``found``; ``bias`` the filter's
        until now), and where ``restarted`` the filter started again where they put the
        vehicle."""
        ekf = self.ekf
        assert ekf is not None
        sensed = self.config.heading_sensed
        if ekf.i_bias is None and sensed:
            ekf = self._add_yaw_bias(t)
        held = ekf.x.item(I_H)
        sigma = max(found.sigma, 1.0)
        moved = False
        if restarted:  # as _align: so far out, every hidden state was misled too
            ekf.reinitialise(found.x, found.y, sigma, yaw=self._last_yaw if sensed else held)
            ekf.warnings.pop()  # the decision below says it
            self.noise = NoiseMatch()
            self.beacon_watch = self._new_beacon_watch()
            self.survey_check.clear()
        else:
            off = math.hypot(found.x - ekf.x.item(I_X), found.y - ekf.x.item(I_Y))
            if off > FIT_FAR * math.hypot(sigma, ekf.position_sigma()):
                ekf.widen_position(off)
                moved = ekf.update(Position(t, found.x, found.y, sigma)).verdicts[0].accepted
        if sensed:
            ekf.realign_heading(found.bias, ALIGN_SIGMA, found.velocity, ALIGN_SIGMA_VELOCITY)
        else:  # the filter's own heading was off by the turn found
            ekf.turn_heading(math.remainder(held - found.bias - ekf.x.item(I_H), 2 * math.pi),
                             ALIGN_SIGMA, found.velocity, ALIGN_SIGMA_VELOCITY)
        turn = math.remainder(ekf.x.item(I_H) - held, 2 * math.pi)
        ekf.doubt_heading(DOUBT_SIGMA, WANDER_NOISE, t + BIAS_WANDER_TIME)
        self.alignment.clear()
        self.range_alignment.clear()
        self._range_doubt, self._range_heading = (t + RANGE_WINDOW, t), None  # confirm it
        reads = ("the orientation sensor reads" if sensed
                 else "with no heading sensor, the heading the filter held was")
        self._decide(Decision(t, HEADING, (
            f"heading taken from the ranges: {reads} "
            f"{math.degrees(found.bias):+.0f}° off the heading the last "
            f"{RANGE_WINDOW:.0f} s of ranges fit (χ² per dof {found.chi2:.1f}, "
            f"{found.chi2_other:.1f} with any other turn)"
            + (f", the filter's bias {math.degrees(bias):+.0f}°" if sensed else "")
            + f"; heading turned by {math.degrees(turn):+.0f}°"
            + (f", the filter restarted at ({found.x:.1f}, {found.y:.1f}) ± {sigma:.1f} m"
               if restarted else "")
            + (f", its position moved to ({found.x:.1f}, {found.y:.1f}) ± {sigma:.1f} m"
               if moved else ""))))

    def _test_sense(self, t: float) -> None:
        """While a yaw rate turns against a heading, which of the two is wrong: the track
        dead-reckoned from the headings fits the ranges either as they read or negated
        (:meth:`RangeAlignment.sense`), or, without ranges to tell, the headings keep one
        offset from the courses made good between fixes either way round
        (:meth:`MotionAlignment.sense`); twice in a row. Negated: the heading sensor's sense
        is the wrong way round (a clockwise heading given as pNav's anticlockwise yaw), not
        the rate's. Its readings are taken negated from now on, the rate as it reads, what
        the two taught the filter forgotten, and the heading (and, from the ranges, the
        position) taken from the motion."""
        test, ekf = self._sense_test, self.ekf
        if test is None or ekf is None:
            return
        until, next_at, rate, heading = test
        if t > until:
            self._sense_test, self._sense_said = None, None
            self._retake_heading()
            self._decide(Decision(t, HEADING, (
                f"the motion did not tell in {SENSE_TIME:.0f} s which of the heading of "
                f"sensor {heading} and the yaw rate {rate} turns the wrong way: the rate "
                f"is taken negated, the heading as it reads")))
            return
        if t < next_at:
            return
        self._sense_test = (until, t + SENSE_CHECK_EVERY, rate, heading)
        near = self._last_fix[:2] if self._last_fix is not None else (ekf.x.item(I_X),
                                                                      ekf.x.item(I_Y))
        by_ranges = (self.range_alignment.sense(near, SENSE_EITHER) if self.config.beacons
                     else None)
        by_courses = self.alignment.sense() if by_ranges is None else None
        answer = by_ranges if by_ranges is not None else (
            by_courses.reversed if by_courses is not None else None)
        said, self._sense_said = self._sense_said, answer
        if answer is None or answer != said:
            return
        self._sense_test, self._sense_said = None, None
        told, turn = (("the track the ranges fit", "turns") if by_ranges is not None
                      else ("the courses made good between fixes", "turn"))
        if answer:
            self.reversed_headings.add(heading)
            self.rate_sense.forgive(rate)
            self.range_alignment.mirror()
            self.alignment.clear()
            self.heading_kick = HeadingKick()  # its readings negated from now: no step
            self.kick_offset = -self.kick_offset  # as the window's headings, mirrored
            if self._last_yaw is not None:
                self._last_yaw = -self._last_yaw
            self._retake_heading()
            self._decide(Decision(t, HEADING, (
                f"the heading of sensor {heading} turns against {told}, the yaw rate {rate} "
                f"with it: the heading is the one of the wrong sense, taken negated from now "
                f"on, the rate as it reads (check the heading's convention: S_YAW "
                f"anticlockwise from east, S_HEADING clockwise from north)")))
        else:
            self._retake_heading()
            self._decide(Decision(t, HEADING, (
                f"{told} {turn} with the heading of sensor {heading}: the yaw rate {rate} "
                f"is the one of the wrong sense, taken negated")))
        self._heading_after_sense(t, near, by_courses, restart=answer)

    def _retake_heading(self) -> None:
        """The heading taken again from the sensor's last reading (less the bias), what the
        rate taught forgotten: the filter took neither while the sense was open."""
        ekf = self.ekf
        assert ekf is not None
        bias = ekf.x.item(ekf.i_bias) if ekf.i_bias is not None else 0.0
        ekf.forget_turn(self._last_yaw - bias if self._last_yaw is not None else None)

    def _heading_after_sense(self, t: float, near: tuple[float, float],
                             by_courses: Sense | None, restart: bool) -> None:
        """The heading taken from what told the sense, where the filter's is far from it:
        while undecided it took neither the heading nor the rate, and a heading newly read
        the other way round is anywhere."""
        ekf = self.ekf
        assert ekf is not None
        bias = ekf.x.item(ekf.i_bias) if ekf.i_bias is not None else 0.0
        if by_courses is None:
            found = self.range_alignment.estimate(near)
            if found is not None:
                far = abs(math.remainder(found.bias - bias, 2 * math.pi))
                if restart or far >= RANGE_MIN_TURN:
                    self._heading_from_ranges(t, found, bias, restart or far > ALIGN_RESET)
                    return
        elif restart or abs(math.remainder(by_courses.bias - bias, 2 * math.pi)) >= ALIGN_JUMP:
            if ekf.i_bias is None:
                ekf = self._add_yaw_bias(t)
            turn = ekf.realign_heading(by_courses.bias, max(by_courses.spread, ALIGN_SIGMA),
                                       by_courses.velocity, ALIGN_SIGMA_VELOCITY)
            ekf.doubt_heading(DOUBT_SIGMA, WANDER_NOISE, t + BIAS_WANDER_TIME)
            self._decide(Decision(t, HEADING, (
                f"heading taken from the motion: the orientation sensor reads "
                f"{math.degrees(by_courses.bias):+.0f}° off the courses made good over "
                f"{by_courses.runs} runs (spread {math.degrees(by_courses.spread):.0f}°); "
                f"heading turned by {math.degrees(turn):+.0f}°")))
            return
        if restart:
            ekf.doubt_heading(DOUBT_SIGMA, WANDER_NOISE, t + BIAS_WANDER_TIME)
            self._doubt_from_ranges(t)

    def _new_beacon_watch(self) -> BeaconWatch:
        """A beacon watch whose offsets take the blame where the track cannot, or where a
        position fix anchors them."""
        return BeaconWatch(blame_by_offsets=self.survey_check.blind or self._anchored)

    def _feed_lsq(self, kept: list[Reading]) -> list[Fix]:
        """The slice's pose-proportional readings into the LSQ; the fixes it makes. A beacon
        held off its survey (:mod:`mavhelm.nav.beacon_watch`) is left out while the others
        can still make a fix: the LSQ watches the EKF (spec 2.2.9), and one fed a beacon 20 m
        off disagreed with it by 23 m for six fixes and re-initialised it there (Plaza1,
        beacon 0 20 m off, long after the track had singled it out: 41.8 m at most)."""
        fixes: list[Fix] = []
        if self.lsq is None:
            return fixes
        off = self.beacon_watch.weights
        if len(self.lsq.beacons) - len(off) < self.lsq.min_beacons:
            off = {}
        for r in kept:
            if isinstance(r.obs, Yaw | Depth | Position):
                self.lsq.add_pose(r.obs)
            elif isinstance(r.obs, Range) and r.obs.beacon not in off:
                fix = self.lsq.add(r.obs)
                if fix is not None:
                    fixes.append(fix)
        self.new_fixes.extend(fixes)
        self.fixes += len(fixes)
        return fixes

    def _update(self, t: float, kept: list[Reading]) -> None:
        """The EKF's update on a slice, each reading's fate logged and watched."""
        ekf = self.ekf
        assert ekf is not None
        if self.config.speed_scale and ekf.i_speed is None \
                and any(_has_speed(r.obs) for r in kept):
            ekf = self._add_speed_scale(t)
        prior = (ekf.x.item(I_X), ekf.x.item(I_Y), math.hypot(ekf.x.item(I_VX),
                                                                ekf.x.item(I_VY)))
        speed = prior[2]
        result = ekf.update([self._weighted(self._brought_forward(r), r.sensor.name)
                             for r in kept])
        self._note_coupling(kept)
        for r, verdict in zip(kept, result.verdicts, strict=True):
            self._log(r, "accepted" if verdict.accepted else "rejected", d2=verdict.d2)
            used = verdict.obs
            if isinstance(used, Range) and ekf.config.learn_beacon_offsets:
                lockout = self.beacon_watch.refused(t, used.beacon, verdict.accepted,
                                                    verdict.innovation, used.sigma, used.z)
                adrift = None
                # while the LSQ disagrees its re-initialisation (spec 2.2.9) comes first,
                # unless it is open which way the heading turns: the filter takes no heading
                # then, and ran 25 m off while the count of fixes the re-initialisation waits
                # for came (Plaza1 from 800 s, booted under way, 2.17 m RMS)
                if lockout is None and not verdict.accepted:
                    if not self.safety.disagreeing or self._sense_test is not None:
                        lockout = adrift = self.beacon_watch.adrift(t, speed)
                    elif self.beacon_watch.adrift_beacons(t, speed):
                        # awaited, the ranges still asked for the heading: with half
                        # Plaza1's ranges the six fixes took 40 s, the filter ran 97 m off
                        self._doubt_from_ranges(t)
                if lockout is not None:
                    self._forget(ekf, abs(verdict.innovation), adrift=adrift is not None)
                    self._decide(lockout)
                    self._doubt_from_ranges(t)
                if adrift is not None and self.heading_watch.course_defined(t):
                    ekf = self._doubt_heading(t)
            if isinstance(used, Position):
                ekf = self._watch_fix(t, r.sensor.name, used, verdict.accepted, prior)
            if isinstance(r.obs, Range) and verdict.accepted:
                height = (ekf.x.item(ekf.i_z) if ekf.i_z is not None else 0.0) + r.obs.lever[2]
                self.survey_check.hear(r.obs.t, r.obs.beacon, r.obs.z, r.obs.sigma, height)
            if isinstance(r.obs, Position) and verdict.accepted and not self._anchored:
                self._anchored = self.beacon_watch.blame_by_offsets = True
            self._score(r.sensor.name, verdict.d2, verdict.dof, verdict.accepted)
            nis = verdict.d2 / max(verdict.dof, 1)
            self._check_heading(t, r, verdict.accepted, nis)
            if isinstance(r.obs, Range | Position) and verdict.accepted:
                self.noise.observe(_channel(r.obs, r.sensor.name), nis,
                                   may_shrink=isinstance(r.obs, Range))
        ekf = self.ekf  # a doubt may have given it a bias state
        assert ekf is not None
        decision = self.heading_watch.motion(t, math.hypot(ekf.x.item(I_VX), ekf.x.item(I_VY)))
        if decision is not None and self.config.heading_sensed:  # else no bias to observe
            self._decide(decision)
        if (ekf.i_bias is None and self._heading_coupled and not self.heading_watch.rejecting
                and self.heading_watch.course_defined(t) and self.config.heading_sensed):
            ekf = self._add_yaw_bias(t)
            ekf.doubt_heading(DOUBT_SIGMA, WANDER_NOISE, t + ADDED_WANDER_TIME)
        if any(isinstance(r.obs, Range) for r in kept):
            singled_out = self.survey_check.review(t)
            misfit = self.survey_check.misfit_warning(t)
            if misfit is not None:
                self.warnings.append(misfit)
            for decision in self.beacon_watch.review(t, ekf, singled_out):
                self._decide(decision)
            for name in self.beacon_watch.newly_off:
                self._forget(ekf, self.beacon_watch.weights[name], but=name,
                             fit=self.survey_check.fits.get(name) if name == singled_out else None)

    def _kicked(self, t: float, kept: list[Reading]) -> None:
        """The slice's headings checked for a jump of their sensor
        (:mod:`mavhelm.nav.heading_kick`): where the one heading sensor jumped faster than the
        vehicle turns, the bias state (added if the filter has none and the motion can tell
        it) steps with it, and the ranges' window is given its readings less the steps still
        standing (``kick_offset``), the track they fit unbent. With two heading sensors the
        bias is shared, and the other holds the heading: the gate refuses the jumped one."""
        kick = self.heading_kick
        for r in kept:
            if not isinstance(r.obs, Yaw) or not self._heading_coupled or kick.sensors > 1:
                continue
            ekf = self.ekf
            assert ekf is not None
            step = kick.step(r.sensor.name, r.obs.t, r.obs.z, r.obs.sigma, ekf.x.item(I_VH),
                             math.sqrt(ekf.P.item(I_VH, I_VH)))
            if step is None:
                continue
            if ekf.i_bias is None:
                ekf = self._add_yaw_bias(t)
            ekf.shift_yaw_bias(step)
            standing = math.remainder(self.kick_offset + step, 2.0 * math.pi)
            self.kick_offset = standing if abs(standing) >= KICK_MIN else 0.0
            self._decide(Decision(t, HEADING, (
                f"heading sensor {r.sensor.name} jumped {math.degrees(step):+.0f}° between "
                f"two readings, faster than the vehicle turns: taken as its bias stepping, "
                f"the heading kept")))

    def _watch_fix(self, t: float, sensor: str, fix: Position, accepted: bool,
                   prior: tuple[float, float, float]) -> EKF:
        """A position fix's verdict to the fix watch (:mod:`mavhelm.nav.fix_watch`); when it
        finds the filter off (``prior``: its x, y and speed before the update), the position
        is widened by the fix's distance and the heading doubted, unless the LSQ's
        disagreement (spec 2.2.9) is about to re-initialise it anyway."""
        ekf = self.ekf
        assert ekf is not None
        x, y, speed = prior
        off = math.hypot(fix.x - x, fix.y - y)
        decision = self.fix_watch.heard(t, sensor, fix.x, fix.y, fix.sigma, accepted, speed,
                                        off)
        if decision is None or self.safety.disagreeing:
            return ekf
        ekf.widen_position(off)
        self.alignment.filter_off(t)
        self._decide(decision)
        return self._doubt_heading(t)

    def _forget(self, ekf: EKF, error: float, but: str | None = None,
                fit: Fit | None = None, adrift: bool = False) -> None:
        """What the ranges taught the filter, doubted (:mod:`mavhelm.nav.beacon_watch`): a
        beacon off its survey, or a bad range accepted at the boot, that locked out good
        ones. Every beacon's offset but ``but``'s is re-opened to its prior and the
        position widened by ``error`` (m), so that the ranges still trusted set them again.
        A ``fit`` of the track without ``but`` (:mod:`mavhelm.nav.survey_check`) says where
        the other beacons put the vehicle: the position is widened by its distance from
        there, then told it. Where the ranges of several beacons say the filter is
        ``adrift``, the LSQ's last fix says where they put the vehicle (:meth:`_lsq_anchor`);
        one beacon's ranges refused (most likely that beacon off its survey) leave it: its
        ranges are in that fix. Where no beacon is blamed (``but`` None: ranges refused in a
        row, either way) the range scale every beacon shares is forgotten too: a bad range
        taken at the boot teaches it as much as the offsets (Plaza1, 15 % of the ranges 5-50
        m out, seed 3: one 12 m short, taken 2.7 s in at the still start, set the scale to
        −9 %; the offsets re-opened alone, the ranges put the vehicle back 11 m off, 2.29 m
        RMS, NEES 7.5; with the scale, 1 m off at once, 1.56 m, NEES 2.6; Plaza1's one
        beacon 5 m off, seed 2, 0.65 → 0.73 m, its other draws and beacons unchanged). The
        survey check's blame keeps the scale."""
        anchor = (Position(fit.t, fit.x, fit.y, fit.sigma) if fit is not None
                  else self._lsq_anchor(ekf) if adrift else None)
        if anchor is not None:
            error = max(error, math.hypot(anchor.x - ekf.x.item(I_X),
                                          anchor.y - ekf.x.item(I_Y)))
        ekf.reopen_offsets([name for name in ekf.beacons if name != but], error,
                           scale=but is None)
        if anchor is not None:
            ekf.update(anchor)

    def _lsq_anchor(self, ekf: EKF) -> Position | None:
        """Where the LSQ's last fix, at most ``ANCHOR_AGE`` s old, puts the vehicle, with the
        σ a boot from it gets, widened by the filter's speed over its age: every beacon's
        ranges solved together, outliers dropped, against the filter's sequential updates,
        which from a wide prior take the first ranges in a straight line (Plaza1, a range
        16 m short at the boot: the filter widened 10 m off settled 28 m off, its range
        scale −0.26, until the LSQ's disagreement re-initialised it 25 s later)."""
        fix = self._lsq_fix
        if fix is None or not 0.0 <= ekf.t - fix.t <= ANCHOR_AGE:
            return None
        speed = math.hypot(ekf.x.item(I_VX), ekf.x.item(I_VY))
        sigma = math.hypot(max(fix.sigma, fix.rms, BOOT_SIGMA), speed * (ekf.t - fix.t))
        return Position(ekf.t, fix.x, fix.y, sigma)

    def _note_coupling(self, kept: list[Reading]) -> None:
        """A body velocity with a speed ties the heading to the motion for good."""
        if not self._heading_coupled:
            self._heading_coupled = any(_has_speed(r.obs) for r in kept)

    def _brought_forward(self, r: Reading) -> Observation:
        """An XY fix already ``r.age`` old when stamped (an autopilot's 5 Hz GPS_RAW_INT is
        not in step with its 5 Hz fixes: 0-0.2 s, the same all run long, on the real SITL)
        moved on along the filter's velocity to where the vehicle was at the stamp, its σ
        widened by the velocity's own over that time. Left as stamped, the estimate trails
        the vehicle by the age times the speed, a bias no σ told (NEES 2.4-2.6). A heading
        ``r.age`` old is given its age instead: the filter predicts it as the heading then
        (:class:`~mavhelm.nav.ekf.Yaw`)."""
        obs, ekf = r.obs, self.ekf
        if not r.age or ekf is None or not ekf.config.mobile:
            return obs
        x, P = ekf.x, ekf.P
        if isinstance(obs, Yaw):  # heard late in a turn (INS_AGE): the heading that long ago
            return dataclasses.replace(obs, age=r.age)
        if not isinstance(obs, Position):
            return obs
        var_v = (float(P[I_VX, I_VX]) + float(P[I_VY, I_VY])) / 2.0
        return dataclasses.replace(obs, x=obs.x + float(x[I_VX, 0]) * r.age,
                                   y=obs.y + float(x[I_VY, 0]) * r.age,
                                   sigma=math.sqrt(obs.sigma**2 + var_v * r.age**2))

    def _turning(self, obs: Yaw) -> Yaw:
        """A heading's σ widened by the data's lateness (``time_sigma``) times the turn rate:
        stamped late in a turn it is off by that much, and trusted as declared it turns the
        body velocity off the track (the real SITL's GPS outage: cross-track NEES 2.6-3.1 in
        turns of 5-20 deg/s, 1.1-1.3 on the straights)."""
        ekf = self.ekf
        if ekf is None or not ekf.config.mobile or not ekf.config.time_sigma:
            return obs
        late = ekf.config.time_sigma * float(ekf.x[I_VH, 0])
        return dataclasses.replace(obs, sigma=math.hypot(obs.sigma, late)) if late else obs

    def _weighted(self, obs: Observation, sensor: str) -> Observation:
        """A range or fix with its channel's σ scaled (:mod:`mavhelm.nav.noise_match`), a
        range to a beacon off its survey down-weighted (:mod:`mavhelm.nav.beacon_watch`); a
        heading with the lateness of a turn and the doubt's scale, while it lasts."""
        if isinstance(obs, Yaw):
            obs = self._turning(obs)
            scale, until = self._heading_scale
            if scale == 1.0 or obs.t > until:
                self._heading_scale = (1.0, 0.0)
                return obs
            return dataclasses.replace(obs, sigma=obs.sigma * scale)
        if not isinstance(obs, Range | Position):
            return obs
        sigma = obs.sigma * self.noise.scale(_channel(obs, sensor))
        if isinstance(obs, Range) and self.beacon_watch.weights:
            sigma = self.beacon_watch.sigma(obs.beacon, sigma)
        return obs if sigma == obs.sigma else dataclasses.replace(obs, sigma=sigma)

    def _check_heading(self, t: float, r: Reading, accepted: bool, nis: float) -> None:
        """The heading watch on one reading's fate (see :mod:`mavhelm.nav.heading_watch`)."""
        watch, ekf = self.heading_watch, self.ekf
        assert ekf is not None
        if isinstance(r.obs, Yaw):
            self.heading_kick.taken(r.sensor.name, r.obs.t, r.obs.z, accepted)
            decision = watch.heading(t, r.sensor.name, accepted)
            if decision is not None:
                self._decide(decision)
            if not accepted and self.range_alignment.beacons and self._sense_test is None:
                bias = ekf.x.item(ekf.i_bias) if ekf.i_bias is not None else 0.0
                self.range_alignment.refused_heading(r.obs.t, ekf.x.item(I_H) + bias
                                                     - self.kick_offset)
            return
        if not isinstance(r.obs, Range | Position) or not accepted:
            return  # an outlier is the gate's business: a wrong heading shows first
        decision = watch.position(t, nis)
        if decision is not None:
            self._decide(decision)
        if watch.doubted_at == t:
            self._doubt_heading(t)

    def _doubt_heading(self, t: float) -> EKF:
        """The heading (its bias, when estimated or once added) doubted: the position data
        decide it where the motion makes it observable."""
        ekf = self.ekf
        assert ekf is not None
        if ekf.i_bias is None and self._heading_coupled and self.config.heading_sensed:
            ekf = self._add_yaw_bias(t)  # without a heading sensor nothing reads a bias
        ekf.doubt_heading(DOUBT_SIGMA, WANDER_NOISE, t + BIAS_WANDER_TIME)
        self._doubt_from_ranges(t)
        if ekf.i_bias is None:
            # nothing tells a bias from a heading: the heading itself is down-weighted
            scale = min(self._heading_scale[0] * HEADING_DOUBT_SCALE, HEADING_MAX_SCALE)
            self._heading_scale = (scale, t + WANDER_TIME)
        return ekf

    def _add_yaw_bias(self, t: float) -> EKF:
        """A heading-bias state for a filter that has none, once the motion makes one
        observable (the heading moves the position and the vehicle has been under way for
        ``STILL_TIME``), or on a doubt: the state is added (and kept by every later boot), so
        the position data take a wandering bias out of the heading instead of sharing it. A
        mission that declared no bias state said nothing of its sensor's bias: it starts with
        the doubt's prior and may wander for ``ADDED_WANDER_TIME`` while the motion pins it
        (``BIAS_WANDER_TIME`` when a doubt added it; added only once doubted, a compass
        sitting 4° off for a minute went unseen and cost 0.6-1 m). Its drift rate comes with
        it, as ``EKF_YAW_DRIFT`` says (:meth:`EKF.with_yaw_bias`)."""
        self._decide(Decision(t, HEADING, "the orientation sensor's heading bias is estimated "
                              "from now on (as EKF_YAW_BIAS = true): the motion can tell it "
                              "from the heading"))  # in the .xlog still under its old header
        self.heading_watch.estimates_bias = True
        self._heading_scale = (1.0, 0.0)
        return self._with_states(estimate_yaw_bias=True)

    def _add_speed_scale(self, t: float) -> EKF:
        """The body-velocity speeds' scale error as a state, from the first speed a sensor
        gives, where position data observe it (``EKF_SPEED_SCALE``): a wheel odometer is
        seldom within a few per cent of its wheel size (Plaza1's odometer made 10 % long or
        short: 1.9 m RMS without the state, 0.36 m with it), a DVL's sound speed off by as
        much as the water differs from what it was told. Kept by every later boot."""
        return self._with_states(estimate_speed_scale=True)

    def _with_states(self, **added: bool) -> EKF:
        """The filter grown by the hidden states ``added`` switches on (:meth:`EKF.with_states`),
        kept by every later boot; the .xlog gets a new header for its new columns."""
        assert self.ekf is not None
        self.ekf = self.ekf.with_states(**added)
        self.ekf_config = self.ekf.config
        self._xlog_header = False
        return self.ekf

    def _watch(self, fix: Fix) -> None:
        """The LSQ's checks of the EKF (spec 2.2.9) on one fix: a failure raises, a
        sustained disagreement re-initialises the EKF to the fix."""
        ekf = self.ekf
        decision = self.safety.on_fix(fix, None if ekf is None
                                      else (float(ekf.x[0, 0]), float(ekf.x[1, 0])))
        if decision is None:
            return
        if decision.kind == FAILED:
            raise NavigationFailure(decision.why)
        if decision.kind != REINITIALISED:
            self._decide(decision)
            return
        assert ekf is not None
        ekf.reinitialise(fix.x, fix.y, max(fix.sigma, fix.rms, BOOT_SIGMA), yaw=self._last_yaw)
        ekf.warnings.pop()  # its "re-initialised" line: the decision says it, and why
        self.reinitialisations += 1
        self.alignment.clear()  # its runs were taken against the bias the filter held
        self._decide(decision)
        self._doubt_from_ranges(fix.t)

    def _score(self, sensor: str, d2: float, dof: int, accepted: bool) -> None:
        tally = self.nis.get(sensor)
        if tally is None:
            tally = self.nis[sensor] = NisTally()
        tally.add(d2, dof, accepted)

    def _channel_agrees(self, r: Reading) -> bool:
        rule = self._rules.get(r.sensor.name)
        if rule is None or not r.channel:
            return True
        key = (r.sensor.name, r.channel)
        channel = self._channels.get(key)
        if channel is None:
            channel = self._channels[key] = SensorChannel(rule.points, rule.tolerance)
        if channel.test(r.obs.t, r.raw):
            return True
        self._log(r, "outlier")
        return False

    # ------------------------------------------------------------------ boot and watch

    def _boot_at_start(self, t: float) -> None:
        s = self.config.start
        assert s is not None
        self.ekf = EKF(t, s.x, s.y, s.yaw, beacons=self.config.beacons, config=self.ekf_config,
                       sigma_xy=s.sigma_xy, sigma_yaw=s.sigma_yaw)
        if self.ekf.i_z is not None:
            self.ekf.x[self.ekf.i_z, 0] = s.z
        self.decisions.append(Decision(t, BOOTED, f"EKF started at the mission's start "
                                       f"({s.x:.1f}, {s.y:.1f}) ± {s.sigma_xy:g} m"))
        self._doubt_from_ranges(t, math.inf)  # its heading is the sensor's, unconfirmed

    def _try_boot(self, t: float, readings: list[Reading], fixes: list[Fix]) -> None:
        yaw = self._last_yaw if self._last_yaw is not None else 0.0
        sigma_yaw = None if self._last_yaw is not None else math.pi
        for r in readings:
            if isinstance(r.obs, Position):
                self.ekf = EKF(t, r.obs.x, r.obs.y, yaw, beacons=self.config.beacons,
                               config=self.ekf_config, sigma_xy=max(2.0 * r.obs.sigma, 1.0),
                               sigma_yaw=sigma_yaw)
                self._decide(Decision(t, BOOTED, f"EKF started at the first "
                                      f"{r.sensor.name} fix ({r.obs.x:.1f}, "
                                      f"{r.obs.y:.1f})"))
                if self.config.beacons:
                    self._doubt_from_ranges(t, math.inf)
                return
        if not self.config.beacons:
            return
        for each in fixes:
            self._stream.add(each)
        fix = self._stream.ready
        if fix is None:
            return
        beacons = list(self.config.beacons)
        if self.lsq is not None and self.lsq.estimate_offset:
            beacons = [Beacon(b.name, b.x, b.y, b.z, b.offset + fix.offset, b.turnaround)
                       for b in beacons]
        self.ekf = EKF(t, fix.x, fix.y, yaw, beacons=beacons, config=self.ekf_config,
                       sigma_xy=max(fix.sigma, fix.rms, BOOT_SIGMA), sigma_yaw=sigma_yaw)
        self.boot_fix = fix
        strays = self._stream.strays
        self._decide(Decision(t, BOOTED, f"EKF booted from the LSQ at ({fix.x:.1f}, "
                              f"{fix.y:.1f})" + (f", {strays} stray fix{'es' * (strays > 1)} "
                                                 "off the stream set aside" if strays else "")))
        self._doubt_from_ranges(t, math.inf)

    def _check_lsq(self, horizon: float) -> None:
        if self.lsq is None:
            return
        decision = self.safety.timed_out(horizon, self.lsq.observable, self.lsq.last_attempt,
                                         self.ekf is not None, self.lsq.window)
        if decision is not None and decision.kind == FAILED:
            raise NavigationFailure(decision.why)
        if decision is not None:
            self._decide(decision)

    def _fail(self, why: str) -> None:
        self.failure = why
        self._queue.clear()
        t = self.horizon if self.horizon is not None else 0.0
        self._decide(Decision(t, FAILED, f"navigation failure: {why}; the filters are "
                              "off-line"))

    # ------------------------------------------------------------------ logs

    def _log(self, r: Reading, fate: str, detail: str = "", d2: float | None = None) -> None:
        """Count a reading's fate and, when logging, keep its .olog line (``d2``: its χ²
        distance)."""
        self.counts[fate] = self.counts.get(fate, 0) + 1
        if self.logging:
            self._olog.append((r.obs.t, r.sensor.name, r.sensor.type, r.obs, fate, detail, d2))

    def state_names(self) -> list[str]:
        return [] if self.ekf is None else self.ekf.state_names()

    def _xlog_row(self) -> None:
        ekf = self.ekf
        assert ekf is not None
        if not self._xlog_header:
            self._xlog_header = True
            names = self.state_names()
            self._xlog.append("# t " + " ".join(names) + " | "
                              + " ".join(f"SIGMA_{n}" for n in names))
        self._xlog.append((ekf.t, ekf.x.ravel().tolist(), ekf.P.diagonal().tolist()))

    def take_olog(self) -> list[str]:
        """The .olog lines kept since the last call, formatted now."""
        lines = [e if isinstance(e, str) else _olog_line(*e) for e in self._olog]
        self._olog = []
        return lines

    def take_xlog(self) -> list[str]:
        """The .xlog lines kept since the last call, formatted now."""
        lines = [e if isinstance(e, str) else _xlog_line(*e) for e in self._xlog]
        self._xlog = []
        return lines


OlogEntry = tuple[float, str, str, Observation, str, str, float | None]
"""A reading's .olog line unformatted: time, sensor name and type, observation, fate, detail,
χ² distance (None: the detail stands)."""
XlogEntry = tuple[float, list[float], list[float]]
"""A tick's .xlog line unformatted: time, state, the covariance's diagonal."""


def _olog_line(t: float, name: str, kind: str, obs: Observation, fate: str, detail: str,
               d2: float | None) -> str:
    if d2 is not None:
        detail = f"{d2:.2f}"
    return f"{t:.3f} {name} {kind} {describe(obs)} {fate}{' ' + detail if detail else ''}"


def _xlog_line(t: float, x: list[float], variances: list[float]) -> str:
    return (f"{t:.3f} " + " ".join(f"{v:.5g}" for v in x) + " | "
            + " ".join(f"{math.sqrt(max(v, 0.0)):.4g}" for v in variances))


def _has_speed(obs: Observation) -> bool:
    """A body velocity with a forward or starboard speed: it ties the heading to the motion."""
    return isinstance(obs, BodyVelocity) and (obs.forward is not None
                                              or obs.starboard is not None)


def _channel(obs: Range | Position, sensor: str) -> tuple[str, str]:
    """What a noise scale is kept for: a sensor, and for ranges each beacon of it."""
    return (sensor, obs.beacon if isinstance(obs, Range) else "")


def _rate_label(r: Reading) -> str:
    """A body velocity sensor's yaw rate as the operator knows it: its name and variable."""
    return f"{r.sensor.source}_YAW_VEL (sensor {r.sensor.name})"
