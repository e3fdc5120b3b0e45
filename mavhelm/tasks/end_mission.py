"""EndMission: priority 0, holds every actuator at its end value and locks out all other tasks.

Commanding zero thrust for ever leaves a boat drifting (0.1 m/s in 3 m/s of wind, measured on
real ArduPilot). ``HandBack = HOLD`` (or LOITER, RTL, SMART_RTL; SURFACE on ArduSub) asks, as
the mission ends, for the autopilot to take the vehicle in that mode: the task posts
``HELM_HANDBACK`` and the MAVLink bridge switches the mode, confirms it from the HEARTBEAT,
and reports a refusal. With the mode changed the helm is offline, as after any hand-over
to the autopilot.
"""

from __future__ import annotations

from mavhelm.core.params import Choice, Fixed, Number, Param
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
        Param("HandBack", Choice(("NONE", "HOLD", "LOITER", "RTL", "SMART_RTL", "SURFACE")),
              "NONE",
              attr="hand_back",
              doc="at the end, hand the vehicle to the autopilot in this mode (confirmed from "
                  "its HEARTBEAT; a refusal is reported and the end values are held); SURFACE "
                  "is ArduSub's"),
    )
    end_rudder: float
    end_thrust: float
    end_elevator: float
    hand_back: str

    def initialise(self, now: float) -> None:
        if self.hand_back != "NONE":
            self.post("HELM_HANDBACK", self.hand_back)

    def describe_goal(self) -> str | None:
        return "mission over: end values held"

    def update(self, nav: NavState, now: float) -> Votes | None:
        return {"RUDDER": self.end_rudder, "THRUST": self.end_thrust,
                "ELEVATOR": self.end_elevator}
