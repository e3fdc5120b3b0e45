"""GUIDED (Rover/mode_guided.cpp): the companion's mode. Targets arrive by MAVLink (decoded in
``autopilot.py`` as GCS_Mavlink.cpp does) and select a sub-mode; heading and turn-rate targets
stop the vehicle when not refreshed for 3 s (fixed in 4.8: there is no GUID_TIMEOUT)."""

from __future__ import annotations

import enum
from typing import TYPE_CHECKING

from mavhelm.sitl.mavlink_defs import SEVERITY_WARNING
from mavhelm.sitl.modes.base import GUIDED, Mode

if TYPE_CHECKING:
    from mavhelm.sitl.autopilot import Autopilot

# Rover 4.8 has no GUID_TIMEOUT parameter: ModeGuided stops after a fixed 3 s without a target.
GUIDED_TIMEOUT = 3.0
GUIDED_TIMEOUT_TEXT = "target not received last 3secs, stopping"


class GuidedSubMode(enum.Enum):
    """ModeGuided::SubMode (Rover/mode.h)."""

    WP = "wp"  # drive to a location (position target, DO_REPOSITION)
    HEADING_AND_SPEED = "heading"
    TURN_RATE_AND_SPEED = "rate"
    LOITER = "loiter"  # a boat holding its spot with no target
    STOP = "stop"  # a rover (or a boat without position) with no target


_ATTITUDE_SUBS = (GuidedSubMode.HEADING_AND_SPEED, GuidedSubMode.TURN_RATE_AND_SPEED)


class ModeGuided(Mode):
    """Rover/mode_guided.cpp. With no target a boat loiters where it is and a rover stops
    (ModeGuided::_enter, and on arrival)."""

    number = GUIDED
    name = "GUIDED"

    def __init__(self, autopilot: Autopilot) -> None:
        super().__init__(autopilot)
        self.sub = GuidedSubMode.STOP
        self.target_time = 0.0  # when the last heading/rate target arrived
        self.have_attitude_target = False
        self.desired_heading = 0.0  # degrees
        self.desired_rate = 0.0  # deg/s
        self.desired_speed = 0.0  # m/s
        self.speed: float | None = None  # DO_CHANGE_SPEED / DO_REPOSITION, until the mode ends

    def requires_position(self) -> bool:
        return True

    def is_autopilot_mode(self) -> bool:
        return True

    def _start(self) -> None:
        self.have_attitude_target = False
        self.speed = None
        self.ap.wp = None
        self.idle()

    def _exit(self) -> None:
        self.speed = None

    def idle(self) -> None:
        """No target (ModeGuided::_enter, arrival, a timed-out target): a boat loiters at its
        stopping point (start_loiter), a rover stops (start_stop)."""
        a = self.ap
        if a.boat and a.position_ok():
            self.sub = GuidedSubMode.LOITER
            self.start_loiter()
        else:
            self.sub = GuidedSubMode.STOP

    # ------------------------------------------------------------------ targets
    def set_desired_heading_and_speed(self, heading: float, speed: float, now: float) -> None:
        if self.sub != GuidedSubMode.HEADING_AND_SPEED:
            self.ap.atc.rate_pid.reset()
        self.sub = GuidedSubMode.HEADING_AND_SPEED
        self.desired_heading = heading % 360.0
        self.desired_speed = speed
        self.target_time = now
        self.have_attitude_target = True

    def set_desired_turn_rate_and_speed(self, rate: float, speed: float, now: float) -> None:
        self.sub = GuidedSubMode.TURN_RATE_AND_SPEED
        self.desired_rate = rate
        self.desired_speed = speed
        self.target_time = now
        self.have_attitude_target = True

    def set_desired_location(self, x: float, y: float) -> None:
        """Drive to (x, y) local metres; MISSION_ITEM_REACHED on arrival."""
        a = self.ap
        a.wp = (x, y)
        a.wp_notify = True
        self.sub = GuidedSubMode.WP
        self.have_attitude_target = False

    def check_timeout(self, now: float) -> None:
        """A heading or rate target not refreshed for 3 s (fixed) stops the vehicle; checked
        while disarmed too."""
        if (self.sub in _ATTITUDE_SUBS and self.have_attitude_target
                and now - self.target_time > GUIDED_TIMEOUT):
            self.ap.text(SEVERITY_WARNING, GUIDED_TIMEOUT_TEXT)
            self.have_attitude_target = False

    # ------------------------------------------------------------------ control
    def update(self, now: float, dt: float) -> None:
        a = self.ap
        est = a.est
        sub = self.sub
        if sub in _ATTITUDE_SUBS:
            self.check_timeout(now)
            if self.have_attitude_target:
                nudge = self.speed_nudge(self.desired_speed, now)
                if sub == GuidedSubMode.HEADING_AND_SPEED:
                    a.steering = a.atc.heading_control(self.desired_heading, est.heading,
                                                       est.yaw_rate, dt, now)
                else:
                    a.steering = a.atc.rate_control(self.desired_rate, est.yaw_rate, dt, now)
                # a zero speed (a velocity target of 0) is the controlled stop
                self.calc_throttle(nudge, now, dt)
            else:
                # timed out: a boat loiters at its stopping point, a rover stops
                self.idle()
                if self.sub == GuidedSubMode.LOITER:
                    self.loiter(now, dt)
                else:
                    self.stop_vehicle(now, dt)
        elif sub == GuidedSubMode.WP and a.wp is not None:
            if self.navigate_to_waypoint(a.wp, self.speed or a.params["WP_SPEED"], now, dt):
                if a.wp_notify:
                    a.wp_notify = False
                    a.out.reached.append(0)
                a.wp = None
                self.idle()
        elif sub == GuidedSubMode.LOITER:
            self.loiter(now, dt)
        else:
            self.stop_vehicle(now, dt)
