"""The identification manoeuvre, written as an ordinary mission of its own.

It is flown by the helm like any mission, so everything it sends passes the bridge's guards
and each step shows on the console and the status channel as a task. From the user's mission
it keeps the origin, the link (iMAVLink, with full rudder asking for ``probe_rate``), pNav, the
serial instruments and the logger; its pHelm block is its own:

1. ``TuneStart``: to the start point, a quarter of the box's long side in from its centre;
2. ``TuneSettle``, ``TuneSpeedUp``: along the long side at the low, then the high thrust (a
   speed step);
3. ``TuneZig1``, ``TuneZag1``: ±``ZIG`` degrees off it (yaw-rate steps, the rudder saturated);
4. ``TuneTurn``: back the other way (a long turn at the vehicle's own rate limit);
5. ``TuneZig2``, ``TuneZag2``, ``TuneSlow``: the same back towards the start, then the low
   thrust again (a speed step down);
6. ``TuneEnd`` (EndMission, handing back in HOLD) after the last step, when the vehicle is
   about to leave the box (``LimitBox``, and the runner's look-ahead, post ``TuneStop``), or at
   the time limit (``OverallTimeOut``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mavhelm.core.mission import Mission

ZIG = 35.0
"""Degrees each side of the course in a zig-zag: enough to saturate the rudder."""
PROBE_KP = 2.0
"""The manoeuvre's heading gain: a 10° error is full rudder, so each zig is a rate step."""
STOP_FLAG = "TuneStop"
END_TASK = "TuneEnd"
STEPS = ("TuneSettle", "TuneSpeedUp", "TuneZig1", "TuneZag1", "TuneTurn", "TuneZig2",
         "TuneZag2", "TuneSlow")
"""The identification steps, in order (the runner watches them as tasks)."""
KEPT_BLOCKS = ("imavlink", "pnav", "plogger")
"""The user's blocks the manoeuvre keeps (and every iSerial_<label>)."""
MIN_SIDE = 20.0
"""A box narrower than this (m) is refused: nothing can be identified in it."""


@dataclass(frozen=True)
class Box:
    """The open water the user confirmed, in the mission's frame (x east, y north, m)."""

    x_min: float
    y_min: float
    x_max: float
    y_max: float

    @classmethod
    def parse(cls, text: str) -> Box:
        """``XMIN,YMIN,XMAX,YMAX``; refuses a box that is not finite or smaller than MIN_SIDE."""
        try:
            values = [float(v) for v in text.split(",")]
        except ValueError:
            raise ValueError(f"--box {text!r}: expected XMIN,YMIN,XMAX,YMAX in metres") from None
        if len(values) != 4 or not all(math.isfinite(v) for v in values):
            raise ValueError(f"--box {text!r}: expected four finite numbers XMIN,YMIN,XMAX,YMAX")
        box = cls(*values)
        if box.x_max - box.x_min < MIN_SIDE or box.y_max - box.y_min < MIN_SIDE:
            raise ValueError(f"--box {text!r}: each side must be at least {MIN_SIDE:g} m, and "
                             "XMAX > XMIN, YMAX > YMIN")
        return box

    @property
    def centre(self) -> tuple[float, float]:
        return (self.x_min + self.x_max) / 2.0, (self.y_min + self.y_max) / 2.0

    def contains(self, x: float, y: float, margin: float = 0.0) -> bool:
        return (self.x_min - margin <= x <= self.x_max + margin
                and self.y_min - margin <= y <= self.y_max + margin)

    def outside_by(self, x: float, y: float) -> float:
        """How far (m) the point is outside the box; 0 inside."""
        dx = max(self.x_min - x, 0.0, x - self.x_max)
        dy = max(self.y_min - y, 0.0, y - self.y_max)
        return math.hypot(dx, dy)


@dataclass(frozen=True)
class Manoeuvre:
    """What the identification asks of the vehicle."""

    low_thrust: float = 40.0
    high_thrust: float = 80.0
    step_seconds: float = 6.0
    """How long each step lasts (the turn back: 1.5 times as long)."""
    probe_rate: float = 90.0
    """MaxTurnRate while identifying, deg/s: above what the vehicle can turn, so its own
    limit shows."""
    time_limit: float = 180.0

    def course(self, box: Box) -> tuple[tuple[float, float], float]:
        """The start point and the outbound heading: along the box's long side, from a
        quarter in from the centre, so the outbound run has three quarters of it."""
        cx, cy = box.centre
        if box.x_max - box.x_min >= box.y_max - box.y_min:
            return (cx - (box.x_max - box.x_min) / 4.0, cy), 90.0
        return (cx, cy - (box.y_max - box.y_min) / 4.0), 0.0

    def steps(self, heading: float) -> list[tuple[str, float, float, float]]:
        """(name, heading, thrust, seconds) of each step."""
        back = heading + 180.0
        s, lo, hi = self.step_seconds, self.low_thrust, self.high_thrust
        plan = [(heading, lo, s), (heading, hi, s), (heading + ZIG, hi, s),
                (heading - ZIG, hi, s), (back, hi, 1.5 * s), (back + ZIG, hi, s),
                (back - ZIG, hi, s), (back, lo, s)]
        return [(name, h % 360.0, t, d) for name, (h, t, d) in zip(STEPS, plan, strict=True)]


def _fmt(value: float) -> str:
    return f"{value:.6g}"


def _block(name: str, lines: list[str]) -> list[str]:
    return [f"ProcessConfig = {name}", "{", *[f"    {line}" for line in lines], "}"]


def _task(kind: str, settings: list[tuple[str, object]]) -> list[str]:
    return ["    Task = " + kind, "    {", *[f"        {k} = {v}" for k, v in settings], "    }"]


def _kept(mission: Mission, probe_rate: float) -> list[str]:
    out = [f"{e.key} = {e.value}" for e in mission.globals.entries]
    for name, block in mission.processes.items():
        lower = name.lower()
        if lower not in KEPT_BLOCKS and not lower.startswith("iserial_"):
            continue
        lines = [f"{e.key} = {e.value}" for e in block.entries
                 if not (lower == "imavlink" and e.key.lower() == "maxturnrate")]
        if lower == "imavlink":
            lines.append(f"MaxTurnRate = {_fmt(probe_rate)}")
        out += _block(name, lines)
    if mission.process("iMAVLink") is None:
        out += _block("iMAVLink", [f"MaxTurnRate = {_fmt(probe_rate)}"])
    return out


def _helm_settings(mission: Mission) -> list[str]:
    """The user's AppTick and actuator limits (what the gains will run under)."""
    helm = mission.process("pHelm")
    keep = {"apptick", "maxrudder", "maxthrust"}
    lines = [] if helm is None else [f"{e.key} = {e.value}" for e in helm.entries
                                     if e.key.lower() in keep]
    return [*lines, f"YAW_PID_KP = {_fmt(PROBE_KP)}", "YAW_PID_KD = 0", "YAW_PID_KI = 0"]


def tune_mission_text(mission: Mission, box: Box, manoeuvre: Manoeuvre) -> str:
    """The mission that flies the identification inside ``box``, from the user's mission."""
    start, heading = manoeuvre.course(box)
    tasks: list[str] = []
    tasks += _task("LimitBox", [("Name", "TuneBox"), ("Priority", 1), ("XMin", _fmt(box.x_min)),
                                ("XMax", _fmt(box.x_max)), ("YMin", _fmt(box.y_min)),
                                ("YMax", _fmt(box.y_max)), ("EventFlag", STOP_FLAG)])
    tasks += _task("OverallTimeOut", [("Name", "TuneTimeLimit"),
                                      ("TimeOut", _fmt(manoeuvre.time_limit)),
                                      ("TimeOutClock", "ALWAYS"), ("FinishFlag", STOP_FLAG)])
    tasks += _task("GoToWayPoint", [("Name", "TuneStart"),
                                    ("Location", f"{_fmt(start[0])},{_fmt(start[1])}"),
                                    ("Thrust", _fmt(manoeuvre.low_thrust)), ("Radius", 3),
                                    ("TimeOut", _fmt(manoeuvre.time_limit)),
                                    ("FinishFlag", "TuneGo")])
    previous = "TuneGo"
    for name, step_heading, thrust, seconds in manoeuvre.steps(heading):
        tasks += _task("ConstantHeading", [("Name", name), ("Heading", _fmt(step_heading)),
                                           ("Thrust", _fmt(thrust)), ("TimeOut", _fmt(seconds)),
                                           ("StartFlag", previous), ("FinishFlag", f"{name}Done")])
        previous = f"{name}Done"
    tasks += _task("EndMission", [("Name", END_TASK), ("StartFlag", previous),
                                  ("StartFlag", STOP_FLAG), ("HandBack", "HOLD")])
    lines = ["// mavhelm tune: the identification manoeuvre (generated)", *_kept(mission,
             manoeuvre.probe_rate), "ProcessConfig = pHelm", "{",
             *[f"    {line}" for line in _helm_settings(mission)], *tasks, "}"]
    return "\n".join(lines) + "\n"
