"""The helm: prioritised tasks vote on actuators (spec 1)."""

from mavhelm.tasks.base import NavState, Task, Votes
from mavhelm.tasks.helm import Helm, arbitrate
from mavhelm.tasks.pid import HelmGains, ScalarPID
from mavhelm.tasks.registry import TASK_TYPES, build_task, known_types

__all__ = [
    "TASK_TYPES",
    "Helm",
    "HelmGains",
    "NavState",
    "ScalarPID",
    "Task",
    "Votes",
    "arbitrate",
    "build_task",
    "known_types",
]
