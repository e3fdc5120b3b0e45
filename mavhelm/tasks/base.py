"""The Task base: everything spec Table 1 gives every task, so a task type only says what it does.

Modelled on MOOS's IvPBehavior (and py_trees' Behaviour hooks): the base owns the name, flags,
time-out, initial state, priority, PID bookkeeping and the three ways a task ends (spec 1.1.1).
A task type declares its own settings once, in ``params`` (see ``mavhelm.core.params``); the
base reads the block against the base properties plus those, refusing unknown keys, missing
required ones and every non-finite or out-of-range value, and sets each as an attribute.
A subclass may then override a few hooks:

- ``check(block)``: constraints between settings, once all are read;
- ``needs() -> set[str]``: variables it starves without;
- ``initialise(now)``: going active;
- ``update(nav, now) -> Votes | None``: one online tick; call ``self.complete()`` on success;
- ``terminate(cause)``: it has ended.

Tasks never touch the bus: what they want posted goes into an outbox the helm drains
(spec 1.1: each task thinks it has its own comms client).
"""

from __future__ import annotations

import enum
from collections.abc import Mapping
from typing import ClassVar, Protocol

from mavhelm.core.bus import Message
from mavhelm.core.geodesy import wrap_degrees, yaw_to_heading
from mavhelm.core.mission import Block
from mavhelm.core.names import NAV_HEADING, NAV_YAW, NO_SOURCE
from mavhelm.core.params import Boolean, Choice, Names, Number, Param, Schema, Seconds, Word
from mavhelm.tasks.pid import HelmGains, ScalarPID

Votes = dict[str, float]
"""Actuator name (RUDDER, THRUST, ELEVATOR or an auxiliary) → desired value."""

STARVATION_S = 10.0
HEADING = NAV_HEADING

COMPLETE = "complete"
TIMEOUT = "timeout"
STARVED = "starved"

THRUST = Number(-100.0, 100.0)
"""A thrust vote in percent of full ahead (negative astern)."""

BASE_PARAMS: tuple[Param, ...] = (
    Param("Name", Word(), None, doc="the task's name in flags, logs and messages "
          "(default: the task type)"),
    Param("Priority", Number(1, 1000, integer=True), 3,
          doc="1 is the most important; 0 is reserved for EndMission"),
    Param("StartFlag", Names(), [], repeat=True, attr="start_flags",
          doc="variables that start the task when posted"),
    Param("FinishFlag", Names(), [], repeat=True, attr="finish_flags",
          doc="posted when the task ends (value: DONE or the reason)"),
    Param("EventFlag", Names(), [], repeat=True, attr="event_flags",
          doc="posted on an event that does not end the task"),
    Param("TimeOut", Seconds(), 100.0, "s", "the longest the task may run", attr="timeout"),
    Param("InitialState", Choice(("ON", "OFF")), None, attr="initial_state",
          doc="ON runs from the mission start; default ON unless the task has a StartFlag"),
    Param("LOGPID", Boolean(), False, attr="log_pid",
          doc="post the heading controller's terms as <NAME>_YAW_PID"),
    Param("TimeOutClock", Choice(("ONLINE", "ALWAYS")), "ONLINE", attr="timeout_clock",
          doc="ONLINE: TimeOut counts only time the helm is online, so a leg interrupted by "
              "the operator in MANUAL still gets its full time after hand-back; ALWAYS: "
              "wall time since it started"),
)


class State(enum.Enum):
    IDLE = "idle"
    ACTIVE = "active"
    DONE = "done"


_SAME_QUANTITY = {NAV_YAW: NAV_HEADING, NAV_HEADING: NAV_YAW}


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

    @property
    def any_lost(self) -> bool:
        """Whether pNav has declared any variable lost (most ticks: none, nothing to check)."""
        return bool(self._lost)

    def lost(self, name: str) -> bool:
        """pNav has no live source for this variable: its last value must not be acted on."""
        return name in self._lost

    def time(self, name: str) -> float | None:
        """Data time stamp of the latest value, or None if never heard."""
        return self._times.get(name)

    @property
    def times(self) -> Mapping[str, float]:
        """Every variable heard, with the data time of its latest value."""
        return self._times

    @property
    def heading(self) -> float | None:
        return self._values.get(HEADING)

    @property
    def x(self) -> float | None:
        return self._values.get("NAV_X")

    @property
    def y(self) -> float | None:
        return self._values.get("NAV_Y")


class TaskWatcher(Protocol):
    """What drains the tasks' outboxes (the helm). Told of each post, so with dozens of idle
    tasks in a mission it visits only those with something to say; a task changes state only
    with a post (TASK_STARTED, TASK_ENDED), so it also learns when the running set changes."""

    def task_posted(self, task: Task, name: str) -> None: ...


class Task:
    """Base of every helm task; see the module docstring for the hooks."""

    keyword: ClassVar[str] = "Task"
    summary: ClassVar[str] = ""
    """One line for the parameter reference: what the task does and when it ends."""
    params: ClassVar[tuple[Param, ...]] = ()
    """This type's own settings; a name already declared by a base narrows it."""

    @classmethod
    def schema(cls) -> Schema:
        """The base properties and every class's ``params`` from the base down."""
        declared: list[Param] = list(BASE_PARAMS)
        for klass in reversed(cls.__mro__):
            declared.extend(klass.__dict__.get("params", ()))
        return Schema(f"a {cls.keyword} task", tuple(declared))

    def __init__(self, block: Block, gains: HelmGains | None = None) -> None:
        self.block = block
        self.gains = gains or HelmGains()
        self.name: str = ""
        self.start_flags: list[str] = []
        self.finish_flags: list[str] = []
        self.event_flags: list[str] = []
        self.timeout: float | None = None
        self.initial_state: str | None = None
        self.priority = 0
        self.log_pid = False
        self.timeout_clock = "ONLINE"
        label = block.get("Name") or self.keyword
        self.schema().apply(self, block, owner=f"{self.keyword} task {label}")
        if not self.name:
            self.name = self.keyword
        self.check(block)
        self.initial_on: bool = (not self.start_flags if self.initial_state is None
                                 else self.initial_state == "ON")
        if not self.initial_on and not self.start_flags:
            raise block.error(
                f"task {self.name} is InitialState OFF with no StartFlag, so it can never run"
            )
        self.state = State.IDLE
        self.start_time: float | None = None
        self.offline_time = 0.0
        """Seconds the helm spent offline while this task was active (for TimeOutClock)."""
        self._offline_since: float | None = None
        self.end_cause: str | None = None
        self.yaw_pid: ScalarPID = self.heading_pid()
        self._outbox: list[tuple[str, float | str]] = []
        self.watcher: TaskWatcher | None = None
        """Who drains the outbox (the helm), told of every post."""
        self._completed = False
        self._holding = False

    # ---- hooks for subclasses ------------------------------------------------------------

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

    def describe_goal(self) -> str | None:
        """What the task is steering for, in a few words for the operator (or None)."""
        return None

    def heading_pid(self) -> ScalarPID:
        """The task's heading controller, made once (``YAW_PID_*``; a task that holds a line
        has its own)."""
        return self.gains.yaw_pid()

    def terminate(self, cause: str) -> None:
        """Called once when the task ends (cause: complete, timeout or starved)."""

    # ---- helpers for subclasses --------------------------------------------------------------

    def complete(self) -> None:
        """Declare the goal reached; the task ends at the end of this tick with cause complete."""
        self._completed = True

    def post(self, name: str, value: float | str) -> None:
        self._outbox.append((name, value))
        if self.watcher is not None:
            self.watcher.task_posted(self, name)

    def event(self, reason: str) -> None:
        """Something happened that does not end the task: post the EventFlags, and say so
        (``TASK_EVENT``, which the operator sees on the console and the ground station)."""
        self.post("TASK_EVENT", f"{self.name}: {reason}")
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


    def listens_to(self) -> set[str]:
        """The variables ``offer`` reacts to (the helm offers only those): the StartFlags."""
        return set(self.start_flags)

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

    def pause(self, now: float) -> None:
        """The helm goes offline: the operator has the vehicle."""
        if self._offline_since is None:
            self._offline_since = now

    def resume(self, now: float | None = None) -> None:
        """The helm comes back online: controller history from before the gap is meaningless,
        and the gap is not counted against an ONLINE-clock TimeOut."""
        self.yaw_pid.reset()
        if self._offline_since is not None and now is not None:
            self.offline_time += now - self._offline_since
        self._offline_since = None

    def elapsed(self, now: float) -> float:
        """Time this task has run, as its TimeOutClock counts it."""
        assert self.start_time is not None
        run = now - self.start_time
        return run - self.offline_time if self.timeout_clock == "ONLINE" else run

    def starving(self, nav: NavState, now: float, needs: set[str] | None = None) -> list[str]:
        """Needed variables not heard for more than 10 s (counted from activation if never).

        As in MOOS, data that went silent before the task started counts: a task woken while
        the navigator is already dead ends at once instead of steering on old data.
        """
        start = self.start_time
        assert start is not None
        times = nav.times
        silent = [name for name in (self.needs() if needs is None else needs)
                  if now - times.get(name, start) > STARVATION_S]
        return sorted(silent) if silent else silent

    def step(self, nav: NavState, now: float) -> Votes | None:
        """One online tick: time-out, starvation, then the task's own update.

        A task whose navigation pNav declares lost holds at once (casts no vote, so the helm
        commands zero on its actuators in that same tick) and starves 10 s after the last data.
        """
        if self.state is not State.ACTIVE:
            return None
        assert self.start_time is not None
        if self.timeout is not None and self.elapsed(now) > self.timeout:
            self.end(TIMEOUT, f"task {self.name} timed out after {self.timeout:g} s")
            return None
        needs = self.needs()
        silent = self.starving(nav, now, needs)
        if silent:
            self.end(
                STARVED,
                f"task {self.name} starved: no {', '.join(silent)} for {STARVATION_S:g} s",
            )
            return None
        if not nav.times.keys() >= needs:
            return None
        lost = sorted(name for name in needs if nav.lost(name)) if nav.any_lost else []
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
