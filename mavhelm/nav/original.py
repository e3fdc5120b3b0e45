"""Keywords the original pNav reads that mavhelm's navigator cannot honour, each refused with
why (a mission must not rely on a setting that does nothing). The ones it honours are aliases
on their settings (``EKF_SIGMA_XX`` on ``EKF_SIGMA_XY``, ``SV`` on ``LBL_SOUND_SPEED``)."""

from __future__ import annotations

from typing import Final

from mavhelm.core.params import AlwaysTrue, Names, Param, Refused

ALWAYS_READ = Param("ALWAYS_READ", Names(), [], repeat=True, attr="always_read",
                    doc="variables pNav subscribes to beyond its queues' and sensors' (the "
                    "original needed it for data such as LBL travel times; mavhelm's sensors "
                    "subscribe to theirs already)")

_NO_THRUST_MODEL = ("mavhelm does not derive velocity from thrust: declare a SENSOR_BODY_VEL "
                    "(a DVL, wheel odometry) or FIXEDSIDESLIP")

ORIGINAL_ONLY: Final = (
    Param("UseEKF", AlwaysTrue(reason="mavhelm's EKF runs whenever SENSOR_* lines are declared; "
                               "leave them out for a navigator of priority queues only"),
          True, attr="use_ekf", doc="the original's EKF switch: true only"),
    Param("Odometry", Refused("mavhelm posts no NAV_ODOMETRY; a wheel odometer is a "
                              "SENSOR_BODY_VEL"), None, attr="odometry"),
    Param("Pose", Refused("mavhelm posts no NAV_POSE; NAV_X, NAV_Y and NAV_YAW are posted "
                          "separately"), None, attr="pose"),
    Param("SENSOR_CONTROL", Refused(_NO_THRUST_MODEL), None, attr="sensor_control"),
    Param("THRUST2VELOCITY", Refused(_NO_THRUST_MODEL), None, attr="thrust2velocity"),
    Param("THRUST2VELOCITY_GAIN", Refused(_NO_THRUST_MODEL), None,
          attr="thrust2velocity_gain"),
    Param("USETOPDOWN", Refused("mavhelm has no top-down calibration engine"), None,
          attr="use_top_down"),
    Param("EKF_YAW_BIAS_NOISE", Refused("the heading-bias state's process noise is fixed in "
                                        "mavhelm's EKF"), None, attr="ekf_yaw_bias_noise"),
    Param("EKF_SIGMA_TIDE", Refused("the tide state starts with mavhelm's fixed 1-σ"), None,
          attr="ekf_sigma_tide"),
    Param("EKF_MAX_Z_VEL", Refused("mavhelm bounds the horizontal speed states only "
                                   "(EKF_MAX_SPEED)"), None, attr="ekf_max_z_vel"),
)
"""pNav keywords of the original refused with the reason (``Schema`` rows like any other)."""
