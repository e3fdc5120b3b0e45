"""``mavhelm tune``: fly the identification manoeuvre on the connected vehicle, fit its
response and propose (or write) the gains that suit it.

The manoeuvre is a mission of its own (``mavhelm.tuning.manoeuvre``) run by an ordinary
companion, so the operator hands over in GUIDED as for any mission, every demand passes the
bridge's guards, and the steps show as tasks. This module adds one app, ``pTune``, that

- records what was sent and what came back (``mavhelm.tuning.identify.Recording``), each
  turn rate placed when the autopilot took it (``INS_AGE`` earlier than it was heard);
- refuses to go on if the vehicle is outside the box at its first fix;
- posts ``TuneStop`` (the manoeuvre's EndMission: thrust 0, hand back in HOLD) as soon as the
  position a look-ahead ahead would be outside the box;
- ends the run in the tick the helm goes offline for any other reason than the end of the
  manoeuvre (the operator changed the mode, the link was lost): the tune is aborted, and
  nothing more is sent, even if control is handed back;
- keeps the furthest the vehicle has been outside the box.
"""

from __future__ import annotations

import argparse
import math
import shutil
import tempfile
from collections.abc import Callable, Set
from dataclasses import dataclass, field
from pathlib import Path

from mavhelm.companion.bridge.config import IMAVLINK_SCHEMA
from mavhelm.companion.companion import Companion
from mavhelm.companion.console import say
from mavhelm.core.app import App
from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import AutopilotClock, WallClock
from mavhelm.core.mission import Mission, load_mission, parse_mission, read_text_file
from mavhelm.tasks.pid import HelmGains
from mavhelm.tasks.trackline import DEFAULT_LEAD_TIME, TURN_LAG_S
from mavhelm.tuning.gains import Gains
from mavhelm.tuning.identify import Recording, Tuning, identify
from mavhelm.tuning.manoeuvre import STOP_FLAG, Box, Manoeuvre, tune_mission_text
from mavhelm.tuning.model import FitError
from mavhelm.tuning.write import rewrite

LOOKAHEAD_S = 3.0
"""The manoeuvre is stopped when where the vehicle will be this many seconds on, at its
speed and heading, is outside the box: enough for a boat at a few m/s to coast to a stop."""

RECORDED = {"AP_CMD_YAW_RATE": ("turn_command", math.degrees),
            "AP_CMD_THRUST": ("thrust_command", lambda v: 100.0 * v),
            "INS_YAW_VEL": ("turn_rate", lambda v: -math.degrees(v)),
            "NAV_SPEED": ("speed", float), "AP_SPEED": ("autopilot_speed", float),
            "NAV_HEADING": ("heading", float), "NAV_X": ("x", float), "NAV_Y": ("y", float)}
"""Bus variable → the Recording's list and the conversion: turn rates to deg/s clockwise,
thrust to percent."""

AGE = "INS_AGE"
"""How late the ATTITUDE that carried the turn rate was heard (s): the sample is placed that
much earlier, when the autopilot took it (``mavhelm.companion.bridge.lateness``)."""

WATCHED = frozenset({*RECORDED, "NAV_X", "NAV_Y", "NAV_HEADING", "HELM_STATE", "AP_MODE",
                     "MISSION_ENDED", AGE})


@dataclass
class TuneWatch(App):
    """The tune's own app: recorder, box guard and abort on a mode change."""

    bus: Bus
    box: Box
    recording: Recording = field(default_factory=Recording)
    online_once: bool = False
    ended: bool = False
    aborted: str | None = None
    stopped: str | None = None
    worst_excursion: float = 0.0
    mode: str = "?"
    _x: float | None = None
    _y: float | None = None
    _heading: float | None = None
    _speed: float = 0.0
    _age: tuple[float, float] | None = None
    """(stamp, INS_AGE) of the latest ATTITUDE: it goes with the turn rate of that stamp."""

    name = "pTune"

    def subscriptions(self) -> Set[str]:
        return WATCHED

    def on_mail(self, mail: list[Message], now: float) -> None:
        for m in mail:
            self._take(m)

    def _take(self, m: Message) -> None:
        if m.name == "AP_MODE":
            self.mode = m.string
        elif m.name == "HELM_STATE":
            self._helm_state(m.string)
        elif m.name == "MISSION_ENDED":
            self.ended = True
        elif m.is_double:
            self._sample(m)

    def _helm_state(self, state: str) -> None:
        if state == "ONLINE":
            self.online_once = True
        elif self.online_once and not self.ended and self.aborted is None:
            self.aborted = f"the helm went offline (mode {self.mode}) before the manoeuvre ended"

    def _sample(self, m: Message) -> None:
        v, t = m.double, m.time
        if not math.isfinite(v):
            return
        if m.name == "NAV_X":
            self._x = v
        elif m.name == "NAV_Y":
            self._y = v
        elif m.name == "NAV_HEADING":
            self._heading = v
        elif m.name in ("NAV_SPEED", "AP_SPEED"):
            self._speed = v
        elif m.name == AGE:
            self._age = (t, v)
        if m.name in RECORDED and self.online_once and not self.ended:
            self._record(m.name, t, v)

    def _record(self, name: str, t: float, v: float) -> None:
        series, convert = RECORDED[name]
        if series == "turn_rate":
            age = self._age[1] if self._age is not None and self._age[0] == t else 0.0
            self.recording.turn_rate_age.append((t, age))
            t -= age
        getattr(self.recording, series).append((t, convert(v)))

    def iterate(self, now: float) -> None:
        if self._x is None or self._y is None:
            return
        self.worst_excursion = max(self.worst_excursion, self.box.outside_by(self._x, self._y))
        if not self.online_once and not self.box.contains(self._x, self._y):
            outside = self.box.outside_by(self._x, self._y)
            self.aborted = self.aborted or (f"the vehicle is {outside:.1f} m outside the box: "
                                            "bring it inside before tuning")
            return
        if self.stopped is None and self.online_once and not self.ended and self._ahead_outside():
            self.stopped = "the vehicle was about to leave the box"
            self.notify(STOP_FLAG, "box")

    def _ahead_outside(self) -> bool:
        assert self._x is not None and self._y is not None
        heading = math.radians(self._heading or 0.0)
        run = self._speed * LOOKAHEAD_S
        return not self.box.contains(self._x + run * math.sin(heading),
                                     self._y + run * math.cos(heading))


@dataclass
class TuneSession:
    """A companion flying the manoeuvre, and its watch."""

    companion: Companion
    watch: TuneWatch
    manoeuvre: Manoeuvre

    @classmethod
    def attach(cls, companion: Companion, box: Box, manoeuvre: Manoeuvre) -> TuneSession:
        watch = TuneWatch(companion.bus, box)
        apps = companion.community.apps
        apps.insert(apps.index(companion.bridge.output) + 1, watch)
        return cls(companion, watch, manoeuvre)

    @property
    def finished(self) -> bool:
        return self.watch.aborted is not None or self.companion.mission_over()

    def tuning(self) -> Tuning:
        """The fit of what was recorded (``FitError`` if it cannot identify the vehicle)."""
        gains = self.companion.helm.gains
        return identify(self.watch.recording, max_rudder=gains.max_rudder,
                        app_tick=self.companion.helm.app_tick,
                        cruise_thrust=self.manoeuvre.high_thrust, baseline=default_gains(),
                        turn_lag=TURN_LAG_S)


def default_gains() -> Gains:
    """The product's defaults, read from their declarations: what a tune must beat."""
    rate = next(p.default for p in IMAVLINK_SCHEMA.params if p.name == "MaxTurnRate")
    helm = HelmGains()
    return Gains(yaw_kp=helm.yaw_kp, yaw_kd=helm.yaw_kd,
                 max_turn_rate=float(rate), lead_time=DEFAULT_LEAD_TIME,
                 line_kp=helm.line_kp, line_kd=helm.line_kd)


def tune_mission(mission: Mission, box: Box, manoeuvre: Manoeuvre, folder: Path) -> Path:
    """Write the manoeuvre's mission next to the logs; returns its path."""
    path = folder / f"tune_{Path(mission.path).stem}.moos"
    text = tune_mission_text(mission, box, manoeuvre)
    parse_mission(text, str(path))
    path.write_text(text)
    return path


def write_gains(mission_path: Path, tuning: Tuning, out: Path | None) -> tuple[Path, Path | None]:
    """Write the tuned mission to ``out`` (a copy), or in place with a ``.bak`` of the
    original when ``out`` is None; returns (written, backup)."""
    text = read_text_file(mission_path)
    g = tuning.gains
    new = rewrite(text, str(mission_path), yaw_kp=g.yaw_kp, yaw_kd=g.yaw_kd,
                  line_kp=g.line_kp, line_kd=g.line_kd, max_turn_rate=g.max_turn_rate,
                  lead_for=tuning.lead_for)
    backup = None
    if out is None:
        backup = mission_path.with_suffix(mission_path.suffix + ".bak")
        shutil.copy2(mission_path, backup)
        out = mission_path
    out.write_text(new)
    return out, backup


def fly(session: TuneSession, clock: WallClock | AutopilotClock,
        echo: Callable[[str], None]) -> None:
    """Tick the companion until the manoeuvre is over or aborted."""
    session.companion.run_until(clock, lambda: session.finished)
    if session.watch.aborted:
        echo(f"mavhelm tune: ABORTED: {session.watch.aborted}; nothing more is sent")


def _positive(text: str) -> float:
    value = float(text)
    if not math.isfinite(value) or value <= 0:
        raise argparse.ArgumentTypeError(f"{text!r} is not a positive number")
    return value


def _thrusts(text: str) -> tuple[float, float]:
    try:
        low, high = (float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: expected LOW,HIGH in percent") from None
    if not (0 < low < high <= 100):
        raise argparse.ArgumentTypeError(f"{text!r}: expected 0 < LOW < HIGH <= 100")
    return low, high


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("mission", help="the mission to tune (its link, pNav and pHelm limits "
                        "are used; its gains are what --write changes)")
    parser.add_argument("--box", default=None, metavar="XMIN,YMIN,XMAX,YMAX",
                        help="the open water to tune in, metres in the mission's frame "
                             "(write --box=-50,-50,50,50 when it starts with a minus); "
                             "required")
    parser.add_argument("--confirm-open-water", action="store_true",
                        help="required: you confirm the box is clear water the vehicle may "
                             "manoeuvre in at full rudder")
    parser.add_argument("--margin", type=_positive, default=5.0,
                        help="how far past the box's edge it may coast after being stopped "
                             "there, m (default 5); a run that goes further fails")
    parser.add_argument("--time-limit", type=_positive, default=180.0,
                        help="the manoeuvre ends after this many seconds (default 180)")
    parser.add_argument("--thrust", type=_thrusts, default=(40.0, 80.0), metavar="LOW,HIGH",
                        help="the manoeuvre's two thrusts in percent (default 40,80)")
    parser.add_argument("--step-seconds", type=_positive, default=6.0,
                        help="how long each step of the manoeuvre lasts (default 6)")
    parser.add_argument("--connect", default=None, help="autopilot link (default: the "
                        "mission's Connect)")
    parser.add_argument("--clock", choices=["wall", "autopilot"], default="wall",
                        help="as for mavhelm run (autopilot: a SITL run with --speedup)")
    where = parser.add_mutually_exclusive_group()
    where.add_argument("--write", default=None, metavar="FILE",
                       help="write the tuned mission to FILE (a copy)")
    where.add_argument("--in-place", action="store_true",
                       help="write the tuned mission over MISSION, keeping MISSION.bak")


def refusal(args: argparse.Namespace) -> str | None:
    """Why the arguments may not start a tune (None: they may)."""
    if args.box is None:
        return "refused: give the open water to tune in with --box XMIN,YMIN,XMAX,YMAX"
    if not args.confirm_open_water:
        return ("refused: confirm the box is clear open water with --confirm-open-water "
                "(the vehicle turns at full rudder inside it)")
    return None


def run(args: argparse.Namespace) -> int:
    """The ``mavhelm tune`` command."""
    why = refusal(args)
    if why is not None:
        print(f"mavhelm tune: {why}", flush=True)
        return 2
    try:
        box = Box.parse(args.box)
    except ValueError as exc:
        print(f"mavhelm tune: refused: {exc}", flush=True)
        return 2
    mission = load_mission(args.mission)
    manoeuvre = Manoeuvre(low_thrust=args.thrust[0], high_thrust=args.thrust[1],
                          step_seconds=args.step_seconds, time_limit=args.time_limit)
    clock = AutopilotClock() if args.clock == "autopilot" else WallClock()
    echo: Callable[[str], None] = say
    folder = Path(tempfile.mkdtemp(prefix="mavhelm-tune-"))
    path = tune_mission(mission, box, manoeuvre, folder)
    companion = Companion.build(path, clock, connect=args.connect,
                                alog_path=folder / "tune.alog", echo=echo)
    session = TuneSession.attach(companion, box, manoeuvre)
    echo(f"mavhelm tune: {path} on {companion.bridge.config.connect}; hand over in GUIDED to "
         f"start (any other mode aborts); logs in {folder}")
    try:
        fly(session, clock, echo)
    except KeyboardInterrupt:
        echo("mavhelm tune: stopped")
        return 130
    finally:
        companion.close()
    return report(session, args, echo)


def report(session: TuneSession, args: argparse.Namespace, echo: Callable[[str], None]) -> int:
    """Print the fit and the gains, write them if asked; the exit status."""
    watch = session.watch
    status = 0
    if watch.worst_excursion > args.margin:
        echo(f"mavhelm tune: the vehicle went {watch.worst_excursion:.1f} m outside the box "
             f"(margin {args.margin:g} m)")
        status = 1
    if watch.aborted:
        return 1
    if watch.stopped:
        echo(f"mavhelm tune: stopped early: {watch.stopped}; fitting what was recorded")
    try:
        tuning = session.tuning()
    except FitError as exc:
        echo(f"mavhelm tune: cannot identify the vehicle: {exc}")
        return 1
    for line in tuning.report():
        echo(line)
    if args.write or args.in_place:
        out, backup = write_gains(Path(args.mission), tuning,
                                  Path(args.write) if args.write else None)
        echo(f"mavhelm tune: wrote {out}" + (f" (the original kept as {backup})"
                                              if backup else ""))
    return status

