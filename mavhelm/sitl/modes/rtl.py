"""RTL and SMART_RTL (Rover/mode_rtl.cpp, mode_smart_rtl.cpp): drive home, then a boat
loiters there and a rover stops."""

from __future__ import annotations

from mavhelm.sitl.mavlink_defs import SEVERITY_INFO, SEVERITY_WARNING
from mavhelm.sitl.modes.base import RTL, SMART_RTL, Mode


class ModeRTL(Mode):
    """Rover/mode_rtl.cpp: refused without home; at WP_RADIUS says "Reached destination"."""

    number = RTL
    name = "RTL"

    def requires_position(self) -> bool:
        return True

    def is_autopilot_mode(self) -> bool:
        return True

    def _can_enter(self) -> bool:
        return self.ap.home is not None

    def _enter(self) -> bool:
        if not self._can_enter():
            self.ap.text(SEVERITY_WARNING, "Flight mode change failed")
            return False
        self._start()
        return True

    def _start(self) -> None:
        a = self.ap
        a.wp = a.home or (a.est.x, a.est.y)
        a.wp_notify = False

    def update(self, now: float, dt: float) -> None:
        a = self.ap
        speed = a.params["RTL_SPEED"] or a.params["WP_SPEED"]
        if a.wp is not None and self.navigate_to_waypoint(a.wp, speed, now, dt):
            a.wp = None
            a.text(SEVERITY_INFO, "Reached destination")
            if a.boat:
                self.start_loiter()
        if a.wp is None:
            if a.boat:
                self.loiter(now, dt)
            else:
                self.stop_vehicle(now, dt)


class ModeSmartRTL(ModeRTL):
    """Rover/mode_smart_rtl.cpp, without the recorded path: needs a position while armed (its
    path is recorded from it), then drives home as RTL."""

    number = SMART_RTL
    name = "SMART_RTL"

    def _can_enter(self) -> bool:
        return self.ap.position_ok()
