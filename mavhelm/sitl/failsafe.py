"""Rover's failsafes (Rover/failsafe.cpp, Rover/ekf_check.cpp): the GCS failsafe (heartbeats
from MAV_GCS_SYSID stop for FS_GCS_TIMEOUT, then FS_TIMEOUT more, then FS_ACTION) and the EKF
failsafe (about 1 s without a usable position while armed, then FS_EKF_ACTION).

Apart from the modes because they act on whichever mode is running, changing it as upstream's
failsafe_trigger and failsafe_ekf_event do."""

from __future__ import annotations

from typing import TYPE_CHECKING

from mavhelm.sitl.attitude_control import clamp
from mavhelm.sitl.mavlink_defs import SEVERITY_CRITICAL, SEVERITY_INFO, SEVERITY_WARNING
from mavhelm.sitl.modes.base import AUTO, HOLD, LOITER, RTL, SMART_RTL

if TYPE_CHECKING:
    from mavhelm.sitl.autopilot import Autopilot


class Failsafe:
    """The failsafe state of one autopilot: ``triggered`` (GCS) and ``ekf`` are what the
    HEARTBEAT's CRITICAL status and Rover::position_ok read."""

    def __init__(self, autopilot: Autopilot) -> None:
        self.ap = autopilot
        self.gcs_last_seen: float | None = None
        self.bits = 0
        self.start = 0.0
        self.triggered = 0
        self.ekf = False
        self.ekf_bad_time = 0.0

    def gcs_heartbeat(self, sysid: int, now: float) -> None:
        if sysid == int(self.ap.params["MAV_GCS_SYSID"]):
            self.gcs_last_seen = now

    def check_gcs(self, now: float) -> None:
        """Rover::failsafe_gcs_check and failsafe_trigger, once per control-loop pass."""
        if not self._gcs_lost(now):
            self.bits = 0
            if self.triggered:
                self.ap.text(SEVERITY_INFO, "GCS Failsafe Cleared")
                self.triggered = 0
            return
        if not self.bits:
            self.bits = 1
            self.start = now
        params = self.ap.params
        in_hold_ok = self.ap.mode != HOLD or int(params.get("FS_OPTIONS", 0)) & 1
        if (not self.triggered
                and now - self.start > params.get("FS_TIMEOUT", 1.5)
                and self.ap.mode != RTL and in_hold_ok):
            self._trigger(now)

    def _gcs_lost(self, now: float) -> bool:
        """FS_GCS_ENABLE on, a GCS heard once, and silent for more than FS_GCS_TIMEOUT."""
        params = self.ap.params
        if not params.get("FS_GCS_ENABLE", 0) or self.gcs_last_seen is None:
            return False
        return now - self.gcs_last_seen > params.get("FS_GCS_TIMEOUT", 5.0)

    def _trigger(self, now: float) -> None:
        """Rover::failsafe_trigger: announce, drop the RC overrides, then FS_ACTION."""
        self.triggered = self.bits
        # Rover::failsafe_trigger names whichever check first sees FS_TIMEOUT pass; with
        # FS_THR_ENABLE on (the default) the radio check runs every loop and is nearly
        # always first, so a GCS failsafe is announced as "Radio Failsafe" (measured). The
        # radio itself never fails here (the simulated receiver is always valid).
        who = "Radio" if int(self.ap.params.get("FS_THR_ENABLE", 0)) else "GCS"
        self.ap.text(SEVERITY_WARNING, f"{who} Failsafe")
        self.ap.rc.clear_overrides()
        if self.ap.mode == AUTO and int(self.ap.params["FS_GCS_ENABLE"]) == 2:
            self.ap.text(SEVERITY_WARNING, "Failsafe - Continuing Auto Mode")
            return
        self._action(int(self.ap.params.get("FS_ACTION", 2)), now)

    def _action(self, action: int, now: float) -> None:
        """FS_ACTION: 0 nothing, 1 RTL, 2 Hold, 3 SmartRTL or RTL, 4 SmartRTL or Hold,
        5 terminate (disarm), 6 Loiter or Hold; each falls back to Hold."""
        if action == 0:
            return
        if action == 5:
            self.ap.arm(False, now)
            return
        if action == 6 and self.ap.set_mode(LOITER, now):
            return
        if action in (3, 4) and self.ap.set_mode(SMART_RTL, now):
            return
        if action in (1, 3) and self.ap.set_mode(RTL, now):
            return
        self.ap.set_mode(HOLD, now)

    def check_ekf(self, now: float, dt: float) -> None:
        """Rover's ekf_check: ~1 s without a usable position while armed → EKF failsafe
        (FS_EKF_ACTION 1: HOLD if the mode needs position; 2: report only; 0: off)."""
        if not self.ap.armed or self.ap.params.get("FS_EKF_THRESH", 0.8) <= 0:
            self.ekf_bad_time = 0.0
            if self.ekf and not self.ap.armed:
                self.ekf = False
            return
        bad = not self.ap.est.position_ok
        self.ekf_bad_time = clamp(self.ekf_bad_time + (dt if bad else -dt), 0.0, 1.0)
        if bad and not self.ekf and self.ekf_bad_time >= 1.0:
            self.ekf = True
            action = int(self.ap.params.get("FS_EKF_ACTION", 1))
            if self.ap.current.requires_position() and action != 0:
                if action == 1:
                    self.ap.set_mode(HOLD, now)
                self.ap.text(SEVERITY_CRITICAL, "EKF failsafe")
        elif not bad and self.ekf and self.ekf_bad_time <= 0.0:
            self.ekf = False
            self.ap.text(SEVERITY_CRITICAL, "EKF failsafe cleared")
