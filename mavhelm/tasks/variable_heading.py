"""VariableHeading: hold whatever heading another process posts on a bus variable.

For a guest process (a plume tracker, an acoustic-modem command, a joystick bridge) that wants
to steer by heading without a third-party task per change: it posts degrees clockwise from
true north on ``HeadingVariable`` (default ``VARIABLE_HEADING``) and this task steers to the
latest valid value, with ``Thrust`` if given. The original MOOS task listened to
``VARIABLE_YAW`` in radians (yaw = −heading) and ``VARIABLE_THRUST``; here the set-point is in
degrees like every heading in a mission, and the thrust is the task's own setting.

A value that is not a finite number in [-360, 360] (a string, NaN, 400) is ignored — the task
keeps the last valid heading — and reported on ``<NAME>_WARNING`` (at most one every 5 s).
Until the first valid heading arrives the task votes nothing. The task needs NAV_HEADING and
the variable: when no valid heading has been posted for 10 s it starves (FinishFlags,
``<NAME>_ERROR``), so a guest process that dies does not leave the vehicle running on its
last wish. It ends on its TimeOut otherwise.
"""

from __future__ import annotations

import math

from mavhelm.core.bus import Message
from mavhelm.core.mission import Block, Entry
from mavhelm.core.params import Param, Word
from mavhelm.tasks.base import HEADING, STARVATION_S, NavState, State, Votes
from mavhelm.tasks.pid import HelmGains
from mavhelm.tasks.steering import SteeringTask

WARNING_EVERY_S = 5.0


class VariableName(Word):
    """A bus variable's name: letters, digits and '_', not starting with a digit."""

    def describe(self) -> str:
        return "a variable name such as VARIABLE_HEADING"

    def parse(self, entry: Entry) -> str:
        name = entry.value.strip()
        if not name or not (name[0].isalpha() or name[0] == "_") \
                or not all(c.isalnum() or c == "_" for c in name) or not name.isascii():
            raise entry.error(f"{entry.key} expects {self.describe()}, got {entry.value!r}")
        return name


class VariableHeading(SteeringTask):
    keyword = "VariableHeading"
    summary = ("holds the heading (deg) posted on HeadingVariable; ignores bad values with a "
               "warning; starves when no valid heading comes for 10 s")
    params = (
        Param("HeadingVariable", VariableName(), "VARIABLE_HEADING",
              doc="the bus variable carrying the heading to hold, degrees clockwise from "
                  "true north", attr="heading_variable"),
    )
    heading_variable: str

    def __init__(self, block: Block, gains: HelmGains | None = None) -> None:
        super().__init__(block, gains)
        self.goal: float | None = None
        self._goal_time: float | None = None
        self._warned_at: float | None = None

    def needs(self) -> set[str]:
        return {HEADING, self.heading_variable}

    def listens_to(self) -> set[str]:
        return super().listens_to() | {self.heading_variable}

    def offer(self, msg: Message, now: float) -> None:
        super().offer(msg, now)
        if msg.name != self.heading_variable or self.state is State.DONE:
            return
        value = msg.double if msg.is_double else None
        if value is not None and math.isfinite(value) and -360.0 <= value <= 360.0:
            self.goal = value % 360.0
            self._goal_time = msg.time
            return
        if self._warned_at is None or now - self._warned_at >= WARNING_EVERY_S:
            self._warned_at = now
            shown = msg.double if msg.is_double else repr(msg.string)
            kept = "nothing yet" if self.goal is None else f"{self.goal:g}"
            self.post(f"{self.name}_WARNING",
                      f"{self.heading_variable} = {shown} is not a heading in [-360, 360] "
                      f"degrees: ignored, holding {kept}")

    def starving(self, nav: NavState, now: float, needs: set[str] | None = None) -> list[str]:
        """As the base, but only valid headings feed the task: a stream of bad ones starves it."""
        assert self.start_time is not None
        silent = [n for n in super().starving(nav, now, needs) if n != self.heading_variable]
        since = self.start_time if self._goal_time is None else self._goal_time
        if now - since > STARVATION_S:
            silent.append(self.heading_variable)
        return sorted(silent)

    def update(self, nav: NavState, now: float) -> Votes | None:
        if self.goal is None:
            return None
        return self.drive(self.goal, nav)
