"""SetActuator: hold a named auxiliary actuator (a winch, a sampler pump, lights) at a value.

Not in the original task library, which had no auxiliary actuators: a field engineer needs
"run the sampler for 30 s at the waypoint", chained by flags like any other task. It votes on
``Actuator`` only (never on the rudder or thrust) and ends on its TimeOut; the value goes out
through the iMAVLink block's ``Servo`` mapping of that name.
"""

from __future__ import annotations

import re

from mavhelm.core.mission import Entry
from mavhelm.core.names import MAIN_ACTUATORS
from mavhelm.core.params import Param, Word
from mavhelm.tasks.base import THRUST, NavState, Task, Votes


class ActuatorName(Word):
    """An auxiliary actuator's name (letters, digits, '_'), not one the helm steers with."""

    def describe(self) -> str:
        return "a name such as WINCH (not RUDDER, THRUST or ELEVATOR)"

    def parse(self, entry: Entry) -> str:
        name = entry.value.strip().upper()
        if not re.fullmatch(r"[A-Z][A-Z0-9_]*", name) or name in MAIN_ACTUATORS:
            raise entry.error(f"{entry.key} expects {self.describe()}, got {entry.value!r}")
        return name


class SetActuator(Task):
    keyword = "SetActuator"
    summary = "holds an auxiliary actuator (Servo in iMAVLink) at Value; ends on its TimeOut"
    params = (
        Param("Actuator", ActuatorName(), doc="the actuator's name (DESIRED_<NAME>)"),
        Param("Value", THRUST, unit="%", doc="its setting, -100..100 (PWM min..max)"),
    )
    actuator: str
    value: float

    def update(self, nav: NavState, now: float) -> Votes | None:
        return {self.actuator: self.value}
