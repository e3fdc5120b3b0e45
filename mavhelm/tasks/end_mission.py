"""EndMission: priority 0, holds every actuator at its end value and locks out all other tasks."""

from __future__ import annotations

from mavhelm.core.params import Fixed, Number, Param
from mavhelm.tasks.base import THRUST, NavState, Task, Votes

RUDDER_DEGREES = Number(-90.0, 90.0)


class EndMission(Task):
    """Never starves, never times out, never completes: the mission is over."""

    keyword = "EndMission"
    summary = "priority 0: holds every actuator at its end value and locks out all other tasks"
    params = (
        Param("Priority", Fixed("0", 0, "EndMission always has priority 0"), 0,
              doc="always 0: locks out every other task"),
        Param("TimeOut", Fixed("NEVER", None, "EndMission never times out; remove TimeOut or "
                                "write NEVER"), None, "s", "always NEVER", attr="timeout"),
        Param("EndRudder", RUDDER_DEGREES, 0.0, "deg", "rudder held after the mission"),
        Param("EndThrust", THRUST, 0.0, "%", "thrust held after the mission"),
        Param("EndElevator", RUDDER_DEGREES, 0.0, "deg", "elevator held after the mission"),
    )
    end_rudder: float
    end_thrust: float
    end_elevator: float

    def update(self, nav: NavState, now: float) -> Votes | None:
        return {"RUDDER": self.end_rudder, "THRUST": self.end_thrust,
                "ELEVATOR": self.end_elevator}
