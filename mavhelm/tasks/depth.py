"""The base of tasks that hold a depth: the depth-by-pitch controller of spec 1.4.2 voting on
ELEVATOR, as ConstantDepth, GoToDepth, ZPattern and DiveTask do.

Needs ``NAV_DEPTH`` (metres, positive down) and ``NAV_PITCH`` (radians, nose up) and starves
without either, as the original's depth tasks did. The controller is the helm's one set of
gains (``Z_TO_PITCH_PID_*``, ``PITCH_PID_*``, ``MAXPITCH``, ``MAXELEVATOR``), fresh for each
task, and forgets its history when the task starts or the helm comes back online.
"""

from __future__ import annotations

import math

from mavhelm.core.mission import Block
from mavhelm.core.names import NAV_DEPTH, NAV_PITCH
from mavhelm.tasks.base import NavState, Task
from mavhelm.tasks.pid import DepthByPitch, HelmGains


class DepthTask(Task):
    reversing = False
    """A reverse dive flips the controller (see :class:`~mavhelm.tasks.pid.DepthByPitch`)."""

    def __init__(self, block: Block, gains: HelmGains | None = None) -> None:
        super().__init__(block, gains)
        self.depth_pid: DepthByPitch = self.gains.depth_pid(reversing=self.reversing)

    def needs(self) -> set[str]:
        return {NAV_DEPTH, NAV_PITCH}

    def start(self, now: float) -> None:
        self.depth_pid.reset()
        super().start(now)

    def resume(self, now: float | None = None) -> None:
        self.depth_pid.reset()
        super().resume(now)

    def depth_error(self, nav: NavState, target: float) -> float:
        """Metres still to go down to ``target`` (negative when too deep)."""
        depth = nav.get(NAV_DEPTH)
        assert depth is not None
        return target - depth

    def elevator(self, target: float, nav: NavState) -> float:
        """Elevator (degrees, positive dives) that brings NAV_DEPTH to ``target`` metres."""
        depth_t = nav.time(NAV_DEPTH)
        pitch = nav.get(NAV_PITCH)
        pitch_t = nav.time(NAV_PITCH)
        assert depth_t is not None and pitch is not None and pitch_t is not None
        out = self.depth_pid.run(self.depth_error(nav, target), depth_t, math.degrees(pitch),
                                 pitch_t)
        if self.log_pid:
            self.post(f"{self.name}_DEPTH_PID", self.depth_pid.describe())
        return out
