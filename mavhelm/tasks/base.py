"""The Task base: everything spec Table 1 gives every task, so a task type only says what it does.

Modelled on MOOS's CMOOSBehaviour (and py_trees' Behaviour hooks): the base owns the name,
flags, time-out, initial state, priority, PID bookkeeping and the three ways a task ends
(spec 1.1.1). A subclass overrides a few hooks:

- ``set_param(key, entry) -> bool``: its own parameters (key lower-case);
- ``check(block)``: required parameters, once all entries are read;
- ``needs() -> set[str]``: variables it starves without;
- ``initialise(now)``: going active;
- ``update(nav, now) -> Votes | None``: one online tick; call ``self.complete()`` on success;
- ``terminate(cause)``: it has ended.

A subclass sets its own defaults before calling ``super().__init__``, which reads the block.
Tasks never touch the bus: what they want posted goes into an outbox the helm drains
(spec 1.1: each task thinks it has its own comms client).
"""

from __future__ import annotations

import enum
from typing import ClassVar

from mavhelm.companion.bus import Message
from mavhelm.companion.mission import Block, Entry
from mavhelm.geo import wrap_degrees, yaw_to_heading
from mavhelm.tasks.pid import HelmGains, ScalarPID

Votes = dict[str, float]
"""Actuator name (RUDDER, THRUST, ELEVATOR or an auxiliary) → desired value."""

STARVATION_S = 10.0
HEADING = "NAV_HEADING"

COMPLETE = "complete"
TIMEOUT = "timeout"
STARVED = "starved"

_BASE_KEYS = (
    "Name",
    "StartFlag",
    "FinishFlag",
    "EventFlag",
    "TimeOut",
    "InitialState",
    "Priority",
    "LOGPID",
)


class State(enum.Enum):
    IDLE = "idle"
    ACTIVE = "active"
    DONE = "done"


NO_SOURCE = "NONE"
_SAME_QUANTITY = {"NAV_YAW": "NAV_HEADING", "NAV_HEADING": "NAV_YAW"}


def source_variable(name: str) -> str:
    """Where pNav declares which source feeds a NAV variable (``NAV_X`` → ``NAV_X_SOURCE``)."""
    return f"{name}_SOURCE"


class NavState:
    """Latest value and data time of every double variable the helm hears.

    ``NAV_YAW`` (radians, yaw = −heading) also fills ``NAV_HEADING`` (degrees), so a navigator
    that publishes either one keeps steering tasks fed. It also remembers which NAV variables
    pNav has declared lost (``NAV_<K>_SOURCE = NONE``: every source in the queue timed out).
    """

    def __init__(self) -> None:
        self._values: dict[str, float] = {}
        self._times: dict[str, float] = {}
        self._lost: set[str] = set()

    def update(self, msg: Message) -> None:
        if not msg.is_double:
            if msg.name.startswith("NAV_") and msg.name.endswith("_SOURCE"):
                name = msg.name[: -len("_SOURCE")]
                names = {name, _SAME_QUANTITY.get(name, name)}
                if msg.string == NO_SOURCE:
                    self._lost |= names
                else:
                    self._lost -= names
            return
        self._values[msg.name] = msg.double
        self._times[msg.name] = msg.time
        if msg.name == "NAV_YAW":
            self._values[HEADING] = yaw_to_heading(msg.double)
            self._times[HEADING] = msg.time

    def get(self, name: str) -> float | None:
        return self._values.get(name)

    def lost(self, name: str) -> bool:
        """pNav has no live source for this variable: its last value must not be acted on."""
        return name in self._lost

    def time(self, name: str) -> float | None:
        """Data time stamp of the latest value, or None if never heard."""
        return self._times.get(name)

    @property
    def heading(self) -> float | None:
        return self._values.get(HEADING)

    @property
    def x(self) -> float | None:
        return self._values.get("NAV_X")

    @property
    def y(self) -> float | None:
        return self._values.get("NAV_Y")


def parse_flags(entry: Entry) -> list[str]:
    """A comma-separated flag list; an empty item is a typo, not a flag."""
    flags = [f.strip() for f in entry.value.split(",")]
    if not flags or any(not f for f in flags):
        raise entry.error(
            f"{entry.key} expects comma-separated variable names, got {entry.value!r}"
        )
    return flags


def parse_bool(entry: Entry) -> bool:
    v = entry.value.strip().lower()
    if v in ("true", "yes", "1", "on"):
        return True
    if v in ("false", "no", "0", "off"):
        return False
    raise entry.error(f"{entry.key} expects true or false, got {entry.value!r}")


def parse_thrust(entry: Entry) -> float:
    thrust = entry.as_float()
    if abs(thrust) > 100.0:
        raise entry.error(f"{entry.key} is a percentage in [-100, 100], got {entry.value}")
    return thrust


class Task:
    """Base of every helm task; see the module docstring for the hooks."""

    keyword: ClassVar[str] = "Task"
    default_priority: ClassVar[int] = 3
    default_timeout: ClassVar[float | None] = 100.0
    default_initial_on: ClassVar[bool | None] = None
    """None: ON unless the task has a StartFlag (what a mission without InitialState means)."""
    params: ClassVar[tuple[str, ...]] = ()
    """Task-specific parameter names, for the 'unknown parameter' message."""

    def __init__(self, block: Block, gains: HelmGains | None = None) -> None:
        self.block = block
        self.gains = gains or HelmGains()
        self.name = self.keyword
        self.start_flags: list[str] = []
        self.finish_flags: list[str] = []
        self.event_flags: list[str] = []
        self.timeout: float | None = self.default_timeout
        self.initial_on: bool | None = self.default_initial_on
        self.priority = self.default_priority
        self.log_pid = False
        self.state = State.IDLE
        self.start_time: float | None = None
        self.end_cause: str | None = None
        self.yaw_pid: ScalarPID = self.gains.yaw_pid()
        self._outbox: list[tuple[str, float | str]] = []
        self._completed = False
        self._holding = False
        for entry in block.entries:
            key = entry.key.lower()
            if not self._set_base(key, entry) and not self.set_param(key, entry):
                known = ", ".join(_BASE_KEYS + self.params)
                raise entry.error(
                    f"unknown parameter {entry.key!r} for a {self.keyword} task (known: {known})"
                )
        self.check(block)
        if self.initial_on is None:
            self.initial_on = not self.start_flags
        if not self.initial_on and not self.start_flags:
            raise block.error(
                f"task {self.name} is InitialState OFF with no StartFlag, so it can never run"
            )

    def _set_base(self, key: str, entry: Entry) -> bool:
        if key == "name":
            name = entry.value.strip()
            if not name or any(c.isspace() or c in ",:=" for c in name):
                raise entry.error(f"Name must be one word without ',', ':' or '=', got {name!r}")
            self.name = name
        elif key == "startflag":
            self.start_flags += parse_flags(entry)
        elif key == "finishflag":
            self.finish_flags += parse_flags(entry)
        elif key == "eventflag":
            self.event_flags += parse_flags(entry)
        elif key == "timeout":
            self.timeout = self.parse_timeout(entry)
        elif key == "initialstate":
            state = entry.value.strip().upper()
            if state not in ("ON", "OFF"):
                raise entry.error(f"InitialState expects ON or OFF, got {entry.value!r}")
            self.initial_on = state == "ON"
        elif key == "priority":
            self.priority = self.parse_priority(entry)
        elif key == "logpid":
            self.log_pid = parse_bool(entry)
        else:
            return False
        return True

    def parse_timeout(self, entry: Entry) -> float | None:
        if entry.value.strip().upper() == "NEVER":
            return None
        t = entry.as_float()
        if t <= 0:
            raise entry.error(f"TimeOut must be positive seconds or NEVER, got {entry.value}")
        return t

    def parse_priority(self, entry: Entry) -> int:
        p = entry.as_float()
        if not p.is_integer() or p < 1:
            raise entry.error(
                f"Priority must be a whole number >= 1 (0 is EndMission's), got {entry.value}"
            )
        return int(p)

    # ---- hooks for subclasses ------------------------------------------------------------

    def set_param(self, key: str, entry: Entry) -> bool:
        """Take a task-specific parameter (key lower-case); False if it is not one."""
        return False

    def check(self, block: Block) -> None:
        """Refuse a block that misses a required parameter (raise ``block.error``)."""

    def needs(self) -> set[str]:
        """Variables whose silence for 10 s starves the task."""
        return set()

    def initialise(self, now: float) -> None:
        """Called when the task goes active."""

    def update(self, nav: NavState, now: float) -> Votes | None:
        """One online tick while active: return votes, or call ``complete()``."""
        return None

    def terminate(self, cause: str) -> None:
        """Called once when the task ends (cause: complete, timeout or starved)."""

    # ---- helpers for subclasses --------------------------------------------------------------

    def complete(self) -> None:
        """Declare the goal reached; the task ends at the end of this tick with cause complete."""
        self._completed = True

    def post(self, name: str, value: float | str) -> None:
        self._outbox.append((name, value))

    def event(self, reason: str) -> None:
        """Something happened that does not end the task: post the EventFlags."""
        for flag in self.event_flags:
            self.post(flag, reason)

    def steer(self, heading: float, nav: NavState) -> float:
        """Rudder (degrees, positive turns clockwise) to bring NAV_HEADING to ``heading``."""
        current = nav.heading
        t = nav.time(HEADING)
        assert current is not None and t is not None
        rudder = self.yaw_pid.run(wrap_degrees(heading - current), t)
        if self.log_pid:
            self.post(f"{self.name}_YAW_PID", self.yaw_pid.describe())
        return rudder

    # ---- driven by the helm -----------------------------------------------------------------

    @property
    def active(self) -> bool:
        return self.state is State.ACTIVE

    def take_notifications(self) -> list[tuple[str, float | str]]:
        out, self._outbox = self._outbox, []
        return out

    def offer(self, msg: Message, now: float) -> None:
        """Every message the helm hears: a StartFlag wakes an idle task, whatever its value.

        An InitialState ON task does not listen for start flags (Table 1): it starts with the
        mission, not before.
        """
        if self.state is State.IDLE and not self.initial_on and msg.name in self.start_flags:
            self.start(now)

    def start(self, now: float) -> None:
        if self.state is not State.IDLE:
            return
        self.state = State.ACTIVE
        self.start_time = now
        self.yaw_pid.reset()
        self.post("TASK_STARTED", self.name)
        self.initialise(now)

    def resume(self) -> None:
        """The helm comes back online: controller history from before the gap is meaningless."""
        self.yaw_pid.reset()

    def starving(self, nav: NavState, now: float) -> list[str]:
        """Needed variables not heard for more than 10 s (counted from activation if never).

        As in MOOS, data that went silent before the task started counts: a task woken while
        the navigator is already dead ends at once instead of steering on old data.
        """
        assert self.start_time is not None
        silent = []
        for name in sorted(self.needs()):
            t = nav.time(name)
            since = self.start_time if t is None else t
            if now - since > STARVATION_S:
                silent.append(name)
        return silent

    def step(self, nav: NavState, now: float) -> Votes | None:
        """One online tick: time-out, starvation, then the task's own update.

        A task whose navigation pNav declares lost holds at once (casts no vote, so the helm
        commands zero on its actuators in that same tick) and starves 10 s after the last data.
        """
        if not self.active:
            return None
        assert self.start_time is not None
        if self.timeout is not None and now - self.start_time > self.timeout:
            self.end(TIMEOUT, f"task {self.name} timed out after {self.timeout:g} s")
            return None
        silent = self.starving(nav, now)
        if silent:
            self.end(
                STARVED,
                f"task {self.name} starved: no {', '.join(silent)} for {STARVATION_S:g} s",
            )
            return None
        if any(nav.get(name) is None for name in self.needs()):
            return None
        lost = sorted(name for name in self.needs() if nav.lost(name))
        if lost:
            if not self._holding:
                self.post(f"{self.name}_WARNING",
                          f"no source for {', '.join(lost)}: holding (no votes) until it returns")
            self._holding = True
            return None
        self._holding = False
        votes = self.update(nav, now)
        if self._completed:
            self.end(COMPLETE, "DONE")
            return None
        return votes

    def end(self, cause: str, reason: str) -> None:
        """Retire the task: TASK_ENDED, an error on starvation, then the FinishFlags."""
        if self.state is State.DONE:
            return
        self.state = State.DONE
        self.end_cause = cause
        self.post("TASK_ENDED", f"{self.name}:{cause}")
        if cause == STARVED:
            self.post(f"{self.name}_ERROR", reason)
        for flag in self.finish_flags:
            self.post(flag, reason)
        self.terminate(cause)

    def __repr__(self) -> str:
        return f"<{self.keyword} {self.name} {self.state.value} p{self.priority}>"
