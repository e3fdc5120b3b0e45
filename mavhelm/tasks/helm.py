"""The Helm app (spec 1): runs the mission's tasks and arbitrates their votes on the actuators.

Online only while the latest ``HELM_ONLINE`` is 1 (the MAVLink bridge decides: link up and the
autopilot in an online mode). Offline, tasks still hear every message (so start flags are
not lost) but none is run and no ``DESIRED_*`` is posted: the human has the vehicle.
"""

from __future__ import annotations

import math

from mavhelm.core.app import App
from mavhelm.core.bus import Bus, Message
from mavhelm.core.mission import Block, Mission, MissionError
from mavhelm.core.moos import APP_PARAMS
from mavhelm.core.names import (
    END_MISSION,
    HELM_ONLINE,
    MAIN_ACTUATORS,
    NAV_HEADING,
    NAV_X,
    NAV_Y,
    NAV_YAW,
    desired,
    source_variable,
)
from mavhelm.core.params import Number, Param, PathName, Refused, Schema
from mavhelm.core.sender import sender_of_source
from mavhelm.core.thirdparty import REPLY_VARIABLE, REQUEST_VARIABLE
from mavhelm.tasks.base import HEADING, NavState, Task, Votes
from mavhelm.tasks.end_mission import EndMission
from mavhelm.tasks.overall_timeout import OverallTimeOut
from mavhelm.tasks.pid import GAIN_PARAMS, HelmGains
from mavhelm.tasks.registry import build_task
from mavhelm.tasks.third_party import AllowSpec, ThirdParty
from mavhelm.tasks.trackline import link_track_lines

ONLINE_VAR = HELM_ONLINE
ALWAYS_HEARD = (NAV_X, NAV_Y, NAV_HEADING, NAV_YAW)

HELM_SCHEMA = Schema("pHelm", (
    Param("AppTick", Number(1.0, 50.0), 10.0, "Hz",
          "how often the companion ticks (link, nav, helm, output); GUIDED needs >= 1 Hz",
          attr="app_tick"),
    Param("TaskFile", PathName(), None, doc="a .hoof file of Task blocks, relative to the mission",
          attr="task_file"),
    *GAIN_PARAMS,
    Param("Allow", AllowSpec(), [], repeat=True, attr="allow",
          doc="grant a third party (spec 1.3) tasks of these types; all else is denied"),
    Param("PIDLOGPATH", Refused("a task's LOGPID = true posts its controller's terms as "
                                "<NAME>_YAW_PID, which the .alog holds; there is no PID log "
                                "file"), None, attr="pid_log_path"),
), moos=APP_PARAMS)
"""The pHelm block's own settings (its Task blocks are read by the task types' schemas)."""


class Helm(App):
    """pHelm: builds tasks from the mission, feeds them mail, posts the winning votes."""

    name = "pHelm"

    def __init__(self, bus: Bus, block: Block, task_blocks: list[Block]) -> None:
        super().__init__(bus)
        self.block = block
        settings = HELM_SCHEMA.read(block)
        self.gains = HelmGains.from_values(
            settings, [p.name for p in GAIN_PARAMS if block.entry(p.name) is not None])
        self.app_tick: float = settings["app_tick"]
        self.third_party = ThirdParty(settings["allow"], self.gains)
        self._requests: list[tuple[str, str]] = []
        """(request text, bus source) of the guests' requests this tick."""
        self.tasks: list[Task] = []
        seen: dict[str, Block] = {}
        for tb in task_blocks:
            task = build_task(tb, self.gains)
            other = seen.get(task.name)
            if other is not None:
                raise tb.error(
                    f"task name {task.name!r} is already used at {other.file}:{other.line}; "
                    "give each task its own Name"
                )
            seen[task.name] = tb
            self.tasks.append(task)
        link_track_lines(self.tasks)
        for task in self.tasks:
            if isinstance(task, EndMission) and END_MISSION not in task.start_flags:
                # pNav's navigation failure ends the mission (spec 2.2.11) whatever the flags
                task.start_flags.append(END_MISSION)
        for cls in (EndMission, OverallTimeOut):
            if not any(isinstance(t, cls) for t in self.tasks):
                raise block.error(
                    f"the helm refuses a mission without an {cls.keyword} task "
                    f"(add Task = {cls.keyword} {{ … }})"
                )
        self.nav = NavState()
        self._subs: tuple[tuple, frozenset[str]] | None = None
        self._ends: tuple[tuple, list[Task]] | None = None
        self._task_events = 0
        self._routes: tuple[tuple, dict[str, list[Task]]] | None = None
        self.online = False
        self.mission_started = False
        self.mission_ended = False
        self._state_posted: bool | None = None
        self._rudder_owner: str | None = None
        self._aux_actuators: list[str] = []
        self.last_winners: dict[str, tuple[float, Task]] = {}
        self._posting: list[Task] = []
        """Tasks with posts not yet flushed, in the order they first posted."""
        self._running: list[Task] | None = None
        """The active tasks in mission order; None when a task has started or ended since."""
        for task in self.tasks:
            task.watcher = self

    @classmethod
    def from_mission(cls, bus: Bus, mission: Mission) -> Helm:
        """The helm of a parsed mission file; raises a located MissionError if it cannot run."""
        block = mission.process(cls.name)
        if block is None:
            raise MissionError(
                mission.path, 1, "no ProcessConfig = pHelm block: the helm has no mission"
            )
        return cls(bus, block, mission.tasks or block.tasks)

    def task(self, name: str) -> Task:
        for t in self.tasks:
            if t.name == name:
                return t
        raise KeyError(name)

    def subscriptions(self) -> frozenset[str]:
        """What the tasks need, and the vehicle's pose always: a task started by a guest or a
        reload then finds navigation already current, not one tick late. Rebuilt only when a
        task, its flags or its needs change (a HoldingPattern needs NAV_* once it has a place
        to hold): with fifty tasks, every tick, it was a tenth of an hour-long lockstep run."""
        key = self._tasks_key()
        if self._subs is None or self._subs[0] != key:
            subs = {ONLINE_VAR, REQUEST_VARIABLE, *ALWAYS_HEARD}
            subs.update(source_variable(name) for name in ALWAYS_HEARD)
            for t in self.tasks:
                subs.update(t.start_flags)
                subs.update(t.needs())
                subs.update(source_variable(name) for name in t.needs())
            if HEADING in subs:
                subs.update((NAV_YAW, source_variable(NAV_YAW)))
            self._subs = (key, frozenset(subs))
        return self._subs[1]

    def _tasks_key(self) -> tuple[int, int, int]:
        """Changes when the task list does (a guest's task appended) or a task starts or ends
        (a HoldingPattern's needs are known once it starts): what the cached subscriptions,
        listeners and EndMission list depend on."""
        return len(self.tasks), id(self.tasks[-1]) if self.tasks else 0, self._task_events

    def _end_missions(self) -> list[Task]:
        key = self._tasks_key()
        if self._ends is None or self._ends[0] != key:
            self._ends = (key, [t for t in self.tasks if isinstance(t, EndMission)])
        return self._ends[1]

    def _listeners(self) -> dict[str, list[Task]]:
        """Per variable, the tasks whose ``offer`` reacts to it (``Task.listens_to``): offering
        every message to every task was another tenth of that run."""
        key = self._tasks_key()
        if self._routes is None or self._routes[0] != key:
            listeners: dict[str, list[Task]] = {}
            for t in self.tasks:
                for name in t.listens_to():
                    listeners.setdefault(name, []).append(t)
            self._routes = (key, listeners)
        return self._routes[1]

    def task_posted(self, task: Task, name: str) -> None:
        if task not in self._posting:
            self._posting.append(task)
        if name in ("TASK_STARTED", "TASK_ENDED"):
            self._running = None

    def _running_tasks(self) -> list[Task]:
        if self._running is None:
            self._running = [t for t in self.tasks if t.active]
        return self._running

    def on_mail(self, mail: list[Message], now: float) -> None:
        listeners = self._listeners()
        for msg in mail:
            if msg.name == ONLINE_VAR:
                self.online = msg.is_double and msg.double == 1.0
            if msg.name == REQUEST_VARIABLE:
                self._requests.append((msg.string, msg.source))
            self.nav.update(msg)
            for t in listeners.get(msg.name, ()):
                t.offer(msg, now)

    def iterate(self, now: float) -> None:
        if self._state_posted != self.online:
            self.notify("HELM_STATE", "ONLINE" if self.online else "OFFLINE")
            if self.online and self.mission_started:
                for t in self._running_tasks():
                    t.resume(now)
            if not self.online:
                self._set_rudder_owner("none")
            self._state_posted = self.online
        if self.online and not self.mission_started:
            self.mission_started = True
            for t in self.tasks:
                if t.initial_on:
                    t.start(now)
        self._third_party_requests(now)
        if not self.online:
            for t in self._running_tasks():
                t.pause(now)
            self._flush()
            return
        self.last_winners = arbitrate(self._run_tasks(now))
        self._post_desired()

    def _third_party_requests(self, now: float) -> None:
        """Answer the guests' requests (spec 1.3): start what is granted, close what is
        closed, tell each requester why when denied."""
        requests, self._requests = self._requests, []
        for text, source in requests:
            names = {t.name for t in self.tasks}
            closed = ("the mission has ended" if self.mission_ended else None if self.online
                      else "the helm is offline: the operator has the vehicle")
            reply, task, closing = self.third_party.handle(text, closed, now, names,
                                                           sender_of_source(source))
            self.notify(REPLY_VARIABLE, str(reply))
            if task is not None:
                task.watcher = self
                self.tasks.append(task)
                task.start(now)
            if closing is not None:
                closing.end("closed", f"closed by {reply.who}")

    def _locked(self) -> list[Task]:
        return [t for t in self._end_missions() if t.active]

    def _run_tasks(self, now: float) -> list[tuple[Task, Votes]]:
        """Step every active task once, in mission order, and collect their ballots.

        Flags the tasks post are also offered to the tasks at once, so a task started by
        another's FinishFlag runs in the same tick: no tick with nobody at the helm (and
        DESIRED_THRUST = 0) between two legs. The bus delivers the same flags next tick, which
        is harmless, since a task starts only once.
        """
        stepped: set[Task] = set()
        ballots: list[tuple[Task, Votes]] = []
        nav = self.nav
        while True:
            todo = [t for t in (self._locked() or self._running_tasks())
                    if t.active and t not in stepped]
            if not todo:
                break
            stepped.update(todo)
            for t in todo:
                votes = t.step(nav, now)
                if votes:
                    ballots.append((t, votes))
            listeners = self._listeners()
            offered = False
            for name, value in self._flush():
                msg = Message(name, value, now, self.name)
                for t in listeners.get(name, ()):
                    t.offer(msg, now)
                    offered = True
            if not offered:  # only an offered flag can start a task
                break
        locked = self._locked()
        if locked:
            ballots = [b for b in ballots if b[0] in locked]
        return sorted(ballots, key=lambda b: self.tasks.index(b[0]))  # mission order

    def _flush(self) -> list[tuple[str, float | str]]:
        """Post what the tasks queued, task by task in mission order; return it."""
        posted: list[tuple[str, float | str]] = []
        posting, self._posting = self._posting, []
        for t in sorted(posting, key=self.tasks.index):
            for name, value in t.take_notifications():
                self.notify(name, value)
                posted.append((name, value))
                if name in ("TASK_STARTED", "TASK_ENDED"):
                    self._task_events += 1
                if name == "TASK_STARTED" and isinstance(t, EndMission) and not self.mission_ended:
                    self.mission_ended = True
                    self.notify("MISSION_ENDED", t.name)
        return posted

    def _post_desired(self) -> None:
        limits = {
            "RUDDER": self.gains.max_rudder,
            "THRUST": self.gains.max_thrust,
            "ELEVATOR": self.gains.max_elevator,
        }
        for actuator in self.last_winners:
            if actuator not in limits and actuator not in self._aux_actuators:
                self._aux_actuators.append(actuator)
        for actuator in (*MAIN_ACTUATORS, *self._aux_actuators):
            value = self.last_winners[actuator][0] if actuator in self.last_winners else 0.0
            if not math.isfinite(value):
                owner_name = self.last_winners[actuator][1].name
                self.notify("HELM_WARNING", f"task {owner_name} voted {value} on {actuator}: "
                            "not a number, 0 sent instead")
                value = 0.0
            limit = limits.get(actuator)
            if limit is not None:
                value = max(-limit, min(limit, value))
            self.notify(desired(actuator), value)
        owner = self.last_winners.get("RUDDER")
        self._set_rudder_owner(owner[1].name if owner else "none", owner[1] if owner else None)

    def _set_rudder_owner(self, owner: str, task: Task | None = None) -> None:
        """Say who steers, and what for: HELM_GOAL goes to the ground station as a line."""
        if owner != self._rudder_owner:
            self._rudder_owner = owner
            self.notify("HELM_RUDDER_OWNER", owner)
            goal = task.describe_goal() if task is not None else None
            if goal:
                self.notify("HELM_GOAL", f"{owner} steers: {goal}")


def arbitrate(ballots: list[tuple[Task, Votes]]) -> dict[str, tuple[float, Task]]:
    """Per actuator, the vote of the strictly lowest priority number; a tie keeps the first."""
    winners: dict[str, tuple[float, Task]] = {}
    for task, votes in ballots:
        for actuator, value in votes.items():
            best = winners.get(actuator)
            if best is None or task.priority < best[1].priority:
                winners[actuator] = (value, task)
    return winners
