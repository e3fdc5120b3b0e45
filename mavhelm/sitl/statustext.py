"""The STATUSTEXTs ArduPilot Rover SITL says by itself: the boot sequence and the banner.

Recorded from the real Rover 4.8-dev SITL (motorboat; times are autopilot seconds from the
ground station's connection, ±0.1 s): a GCS watching the boot of ``mavhelm sim`` sees the same
lines in the same order at about the same times. Lines that name the build (the version banner,
the board id) say "mavhelm" instead, because the simulator is not that build.

Also here: splitting a long text into MAVLink 2 STATUSTEXT chunks (50 characters each, one id),
as ArduPilot's GCS does, so a text like "Ignoring SET_POSITION_TARGET_LOCAL_NED; set ACC_IGNORE
in mask" arrives whole at a MAVLink 2 reader and as two lines at a MAVLink 1 one.
"""

from __future__ import annotations

from dataclasses import dataclass

INFO, DEBUG = 6, 7
STATUSTEXT_LEN = 50


@dataclass(frozen=True)
class BootText:
    """A text said at ``at`` seconds of the measured timeline (autopilot.Timeline() maps it
    onto a compressed one), or when ``event`` happens: "home" (first GPS fix), "origin"
    (EKF origin set) or "gps" (EKF using GPS)."""

    at: float
    severity: int
    text: str
    event: str | None = None


BOOT_TEXTS: tuple[BootText, ...] = (
    BootText(0.0, INFO, "Calibrating barometer"),
    BootText(0.1, INFO, "Barometer 1 calibration complete"),
    BootText(0.1, INFO, "Barometer 2 calibration complete"),
    BootText(0.2, INFO, "Beginning INS calibration. Do not move vehicle"),
    BootText(0.2, DEBUG, "INS: alloc 6144 bytes for ISB (free=524288)"),
    BootText(1.4, INFO, "ArduPilot Ready"),
    BootText(1.4, DEBUG, "RCInput: decoding UDP (Pulses)"),
    BootText(1.4, INFO, "AHRS: DCM active"),
    BootText(4.4, INFO, "EKF3 IMU0 initialised"),
    BootText(4.4, INFO, "EKF3 IMU1 initialised"),
    BootText(6.0, INFO, "EKF3 IMU0 tilt alignment complete"),
    BootText(6.0, INFO, "EKF3 IMU1 tilt alignment complete"),
    BootText(6.1, INFO, "EKF3 IMU0 MAG0 initial yaw alignment complete"),
    BootText(6.1, INFO, "EKF3 IMU1 MAG0 initial yaw alignment complete"),
    BootText(6.1, INFO, "AHRS: EKF3 active"),
    BootText(9.7, INFO, "GPS 1: probing for u-blox at 230400 baud"),
    BootText(9.7, INFO, "GPS 1: detected u-blox"),
    BootText(9.9, INFO, "Set HOME to {lat:.5f} {lon:.6f} at 0.00m", "home"),
    BootText(19.9, INFO, "EKF3 IMU0 origin set", "origin"),
    BootText(19.9, INFO, "EKF3 IMU1 origin set", "origin"),
    BootText(20.0, INFO, "Field Elevation Set: 0m", "origin"),
    BootText(41.9, INFO, "EKF3 IMU0 is using GPS", "gps"),
    BootText(41.9, INFO, "EKF3 IMU1 is using GPS", "gps"),
)

# GCS_MAVLINK::send_banner (on PARAM_REQUEST_LIST and on request): firmware and board id.
BANNER: tuple[str, ...] = ("ArduRover V4.8.0-dev (mavhelm)", "6d617668656c6d2073696d2020202020")


def chunks(text: str) -> list[tuple[int, bytes]]:
    """(chunk_seq, ≤50 bytes) pieces of a text; one piece when it fits (then the MAVLink 2
    id stays 0, as ArduPilot sends short texts)."""
    raw = text.encode()
    if len(raw) <= STATUSTEXT_LEN:
        return [(0, raw)]
    return [(i, raw[k:k + STATUSTEXT_LEN])
            for i, k in enumerate(range(0, len(raw), STATUSTEXT_LEN))]
