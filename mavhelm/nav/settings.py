"""The pNav block's filter settings, each declared once, and the config fields built from them.

A setting is one :class:`~mavhelm.core.params.Param` (name, kind and range, unit, default,
doc). A config dataclass (``EKFConfig``, ``FusionConfig``) names the declaration a field
comes from with :func:`setting`; the field's default is then the declaration's (times the
field's unit scale), :func:`config_from` fills the fields from a block read by the schema, and
:func:`check_config` holds a config built in code to the same ranges. Adding a setting is one
``Param`` here and one ``setting(...)`` field where it is used: the parser, the refusal, the
default and the line in ``docs/parameters.md`` follow from the declaration.

The σ minimums are physical: below a centimetre, a tenth of a degree, a millimetre per second,
a start or a sensor is claimed better than anything afloat measures, and the filter's
covariance would span more orders of magnitude than double precision keeps.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any, Final, TypeVar

from mavhelm.core.params import Alias, Boolean, Mapped, Number, Param, Seconds

SETTING: Final = "mavhelm.setting"
"""Metadata key of a config field declared by a setting: ``(param, scale)``."""

T = TypeVar("T")

RADIANS_PER_DEGREE: Final = math.pi / 180.0
"""The scale of a config field in radians whose setting is declared in degrees."""

_DYNAMICS = Number(0.0, 10.0)

EKF_X = Param("EKF_X", Number(-1e5, 1e5), None, "m", "EKF start X (with EKF_Y; else the LSQ "
              "or the first XY fix starts it)", attr="ekf_x")
EKF_Y = Param("EKF_Y", Number(-1e5, 1e5), None, "m", "EKF start Y", attr="ekf_y")
EKF_Z = Param("EKF_Z", Number(-1e4, 1e4), 0.0, "m", "EKF start Z (up)", attr="ekf_z")
EKF_HEADING = Param("EKF_HEADING", Number(-360.0, 360.0), None, "deg",
                    "EKF start heading (default: the first orientation reading, else unknown)",
                    attr="ekf_heading", aliases=(Alias("EKF_H"),))
EKF_SIGMA_XY = Param("EKF_SIGMA_XY", Number(0.01, 1e5), 30.0, "m", "1-σ of the start position",
                     attr="ekf_sigma_xy", aliases=(Alias("EKF_SIGMA_XX"), Alias("EKF_SIGMA_YY")))
EKF_SIGMA_HEADING = Param("EKF_SIGMA_HEADING", Number(0.1, 360.0), 90.0, "deg",
                          "1-σ of the start heading", attr="ekf_sigma_heading",
                          aliases=(Alias("EKF_SIGMA_HH"),))
EKF_SIGMA_Z = Param("EKF_SIGMA_Z", Number(0.01, 1e5), 10.0, "m", "1-σ of the start Z",
                    attr="ekf_sigma_z", aliases=(Alias("EKF_SIGMA_ZZ"),))
EKF_XY_DYNAMICS = Param("EKF_XY_DYNAMICS", _DYNAMICS, 5.0, "",
                        "0 (never changes) to 10 (very mobile)", attr="ekf_xy_dynamics")
EKF_YAW_DYNAMICS = Param("EKF_YAW_DYNAMICS", _DYNAMICS, 5.0, "", "0 to 10, as above, for yaw",
                         attr="ekf_yaw_dynamics")
EKF_Z_DYNAMICS = Param("EKF_Z_DYNAMICS", _DYNAMICS, 5.0, "", "0 to 10, as above, for Z",
                       attr="ekf_z_dynamics")
EKF_MOBILE = Param("EKF_MOBILE", Boolean(), True, "", "false: a static vehicle (no rate "
                   "states); the original's EKF_VEHICLE_TYPE defaults to static, mavhelm's to "
                   "mobile (a boat moves)", attr="ekf_mobile",
                   aliases=(Alias("EKF_VEHICLE_TYPE", Mapped((("MOBILE", True),
                                                              ("STATIC", False)))),))
EKF_LAG = Param("EKF_LAG", Number(0.0, 4.0), 0.0, "s", "run the EKF this far behind time "
                "(spec 2.2.7; the LBL listen window); the original's default is 2 s, mavhelm's "
                "0 as nothing lags without LBL", attr="ekf_lag")
EKF_TIME_SIGMA = Param("EKF_TIME_SIGMA", Number(0.0, 2.0), 0.1, "s", "RMS of how late the "
                       "data are stamped (serial and link latency, a GPS's own lag): the "
                       "published position is uncertain by this times the speed along the "
                       "track, a heading by this times the turn rate", attr="ekf_time_sigma")
EKF_YAW_BIAS = Param("EKF_YAW_BIAS", Boolean(), False, "", "estimate the orientation sensors' "
                     "heading bias (needs a BODY_VEL and a position sensor, spec 2.2.10)",
                     attr="ekf_yaw_bias", aliases=(Alias("EKF_ESTIMATE_YAW_BIAS"),))
EKF_YAW_DRIFT = Param("EKF_YAW_DRIFT", Boolean(), True, "", "with the heading-bias state, "
                      "estimate the rate the bias drifts at too: an odometry- or "
                      "gyro-integrated heading drifts at a rate that changes slowly, and "
                      "through a stretch without position data only that rate carries the "
                      "heading (false: the bias is a random walk alone)", attr="ekf_yaw_drift")
EKF_YAW_SCALE = Param("EKF_YAW_SCALE", Boolean(), True, "", "with the heading-bias state, "
                      "when the orientation sensor's heading is a body-velocity sensor's yaw "
                      "rate integrated (the same source: wheel odometry, a gyro), learn that "
                      "yaw rate's scale error: the heading's error then grows with each turn "
                      "(an odometer's wheel base), which a drift in time does not follow",
                      attr="ekf_yaw_scale")
EKF_SPEED_SCALE = Param("EKF_SPEED_SCALE", Boolean(), True, "", "learn a scale error of the "
                        "body-velocity sensors' speeds, shared by them (a wheel odometer's "
                        "wheel size, a DVL's sound speed): the state is added at the first "
                        "speed a body-velocity sensor gives, where an XY, LBL or RANGE sensor "
                        "observes it (false: the speeds are taken at their word)",
                        attr="ekf_speed_scale")
_TIDE_IN_METRES = ("in the original pNav EKF_TIDE is the start tide in metres, which mavhelm "
                   "does not take; here it says whether the tide is estimated")
EKF_TIDE = Param("EKF_TIDE", Boolean(number_reason=_TIDE_IN_METRES), False, "",
                 "estimate the tide (needs depth and beacon ranges, or FIXEDTIDE); the "
                 "original's EKF_TIDE is the start tide in metres, which mavhelm does not take",
                 attr="ekf_tide")
EKF_RANGE_SCALE = Param("EKF_RANGE_SCALE", Boolean(), True, "", "learn a range scale error "
                        "shared by every beacon (sound speed, clock rate)",
                        attr="ekf_range_scale")
EKF_BEACON_OFFSETS = Param("EKF_BEACON_OFFSETS", Boolean(), True, "", "learn each beacon's "
                           "range offset (false: offsets held at zero)",
                           attr="ekf_beacon_offsets")
EKF_GATE = Param("EKF_GATE", Number(0.9, 0.999999), 0.999, "", "χ² acceptance probability of "
                 "the data rejection", attr="ekf_gate")
MAX_EKF_POSITION_UNCERTAINTY = Param(
    "MaxEKFPositionUncertainty", Number(1.0, 1e5), 100.0, "m", "EKF position 1-σ beyond this: "
    "the EKF is lost (off-line until the LSQ boots it again; without an LSQ a navigation "
    "failure)", attr="ekf_max_sigma_xy")
EKF_MAX_SPEED = Param("EKF_MAX_SPEED", Number(0.1, 100.0), 10.0, "m/s", "speed states beyond "
                      "this are reset", attr="ekf_max_speed")
LSQ = Param("LSQ", Boolean(), True, "", "run the LSQ on beacon ranges (boots and watches the "
            "EKF)", attr="lsq", aliases=(Alias("UseLSQ"),))
LSQ_WINDOW = Param("LSQ_WINDOW", Number(0.5, 60.0), 5.0, "s", "ranges older than this are not "
                   "combined into a fix", attr="lsq_window")
LSQ_TIMEOUT = Param("LSQTimeOut", Seconds(3600.0), 30.0, "s", "no LSQ fix for this long is a "
                    "navigation failure (NEVER: never)", attr="lsq_timeout")
LSQ_OFFSET = Param("LSQ_OFFSET", Boolean(), False, "", "solve a common range offset too (needs "
                   "a fourth beacon)", attr="lsq_offset")
MAX_LSQ_EKF_DEVIATION = Param("MaxLSQEKFDeviation", Number(1.0, 1e4), 20.0, "m", "an LSQ fix "
                              "this far from the EKF is a disagreement; 6 in a row take the EKF "
                              "off-line and re-initialise it to the LSQ",
                              attr="lsq_divergence")
MAX_MEDIAN_LSQ_SHIFT = Param("MaxMedianLSQShift", Number(1.0, 1e5), 20.0, "m", "the median "
                             "jump between the last 8 LSQ fixes beyond this is a navigation "
                             "failure (the LSQ is all over the shop)", attr="lsq_max_shift")

EKF_START: Final = (EKF_X, EKF_Y, EKF_Z, EKF_HEADING)
"""The start pose settings (a ``Start`` is built from them, with the start σ)."""


def setting(param: Param, scale: float = 1.0) -> Any:
    """A config field declared by ``param``: its default is the declaration's times
    ``scale`` (the field's unit over the setting's, e.g. radians per degree)."""
    default = param.default
    if scale != 1.0 and isinstance(default, int | float) and not isinstance(default, bool):
        default = default * scale
    elif isinstance(default, list):
        return dataclasses.field(default_factory=tuple, metadata={SETTING: (param, scale)})
    return dataclasses.field(default=default, metadata={SETTING: (param, scale)})


def _declared(config_type: Any) -> list[tuple[str, Param, float]]:
    return [(f.name, *f.metadata[SETTING]) for f in dataclasses.fields(config_type)
            if SETTING in f.metadata]


def config_from(config_type: type[T], settings: Mapping[str, Any], **derived: Any) -> T:
    """``config_type`` with every declared field taken from a block read by the schema
    (``Schema.read``'s attribute → value), and ``derived`` for the rest."""
    values: dict[str, Any] = {}
    for name, param, scale in _declared(config_type):
        value = settings[param.attribute]
        if isinstance(value, list):
            value = tuple(value)
        elif scale != 1.0 and isinstance(value, int | float) and not isinstance(value, bool):
            value = value * scale
        values[name] = value
    values.update(derived)
    return config_type(**values)


def check_config(config: object) -> None:
    """Raise ValueError if a declared field holds a value its setting refuses (a config
    built in code, where the schema has not checked it)."""
    for name, param, scale in _declared(type(config)):
        value = getattr(config, name)
        if isinstance(value, tuple) and param.repeat:
            value = list(value)
        elif scale != 1.0 and isinstance(value, int | float) and not isinstance(value, bool):
            value = value / scale
            if param.kind.check_value(round(value, 9)):
                value = round(value, 9)  # degrees back from radians, to the declared range
        if not param.accepts(value):
            raise ValueError(f"{name} ({param.name}) must be {param.kind.describe()}, "
                             f"got {value!r}")

