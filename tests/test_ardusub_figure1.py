"""The spec's Figure 1 for an AUV, flown by ``mavhelm run`` on the real ArduSub SITL.

``examples/figure1_auv.moos`` is the mission as the spec writes it (an hour long); this test
flies a copy shrunk to fit in about a minute of wall time at ×10 — the same tasks in the same
order, with smaller distances and depths — plus one task the example does not have: ``Plunge``
(priority 2, above the survey's ConstantDepth) asks for a depth below the LimitDepth
(priority 1), so that the limit is seen to fire and to win the elevator (its EventFlag here
is ``TooDeep``, not EndMission, so the mission goes on).

Asserted from the companion's .alog (autopilot seconds): every task starts and ends in order;
once settled the depth is within 1 m of each target; LimitDepth fires when the vehicle is
pushed below its limit and brings it back; EndMission hands the vehicle to ArduSub's SURFACE
mode. The run's plot (track, heading, depth) is written beside the .alog. A second test flies
the example unchanged: in the SITL's 50 m of water its altitude limit ends it on the way down.

Needs MAVHELM_ARDUSUB (see tests/ardusub.py); skips without it.
"""

from __future__ import annotations

import statistics
from pathlib import Path

import pytest

from mavhelm.core.bus import Message
from mavhelm.core.mission import load_mission
from mavhelm.demo.report import plot_run
from mavhelm.sitl.truth import Truth
from tests.support.ardupilot import CompanionProcess
from tests.support.ardusub import SKIP_REASON, SubOperator, ardusub_binary, start_sub

pytestmark = pytest.mark.slow

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "figure1_auv.moos"
SPEEDUP = 10
AS_WRITTEN_SPEEDUP = 20
DIVE_M = 8.0
LIMIT_M = 12.0

# the example, shrunk: every occurrence of each text in examples/figure1_auv.moos replaced
SHRINK = (
    ("200, 400", "20, 30"),
    ("Depth      = 50", f"Depth      = {DIVE_M:g}"),
    ("A          = 100", "A          = 16"),
    ("B          = 60", "B          = 8"),
    ("Spacing    = 20", "Spacing    = 8"),
    ("LegTimeOut = 200", "LegTimeOut = 60"),
    ("FinishFlag = Return\n", "FinishFlag = Plunge\n"),
    ("MaximumDepth = 100\n        EventFlag    = EndMission",
     f"MaximumDepth = {LIMIT_M:g}\n        EventFlag    = TooDeep"),
)
PLUNGE = f"""
    Task = GoToDepth
    {{
        Name       = Plunge
        Priority   = 2
        Depth      = {LIMIT_M + 4:g}
        Tolerance  = 0.5
        TimeOut    = 40
        StartFlag  = Plunge
        FinishFlag = Return
    }}
"""
ORDER = ["InitialDelay", "Traverse", "Dive", "SurveyDepth", "Survey", "Plunge", "Return",
         "Surface", "Abort"]
ENDS = {"InitialDelay": "timeout", "Traverse": "complete", "Dive": "complete",
        "Survey": "complete", "Plunge": "timeout", "Return": "complete", "Surface": "complete"}


def test_mission() -> str:
    text = EXAMPLE.read_text()
    for old, new in SHRINK:
        assert old in text, old
        text = text.replace(old, new)
    return text.replace("    Task = LimitDepth", PLUNGE + "\n    Task = LimitDepth", 1)


test_mission.__test__ = False  # type: ignore[attr-defined]


def named(log: list[Message], name: str) -> list[Message]:
    return [m for m in log if m.name == name]


def wait(op: SubOperator, comp: CompanionProcess, fragment: str, timeout_s: float) -> None:
    def seen() -> bool:
        if not comp.running():
            raise AssertionError(f"the companion exited:\n{comp.output()}")
        return comp.find(fragment) is not None
    try:
        op.wait_until(seen, timeout_s, f"companion line {fragment!r}")
    except TimeoutError as exc:
        raise AssertionError(f"{exc}\ncompanion console:\n{comp.output(60)}") from None


def nav_track(log: list[Message]) -> list[Truth]:
    """pNav's pose as a track, one sample per NAV_X (the latest NAV_Y and NAV_HEADING)."""
    latest: dict[str, float] = {}
    track = []
    for m in log:
        if m.name in ("NAV_X", "NAV_Y", "NAV_HEADING") and m.is_double:
            latest[m.name] = m.double
            if m.name == "NAV_X" and len(latest) == 3:
                track.append(Truth(m.time, latest["NAV_X"], latest["NAV_Y"],
                                   latest["NAV_HEADING"]))
    return track


def depths_between(log: list[Message], t0: float, t1: float) -> list[float]:
    return [m.double for m in named(log, "NAV_DEPTH") if t0 <= m.time <= t1]


def fly(tmp_path: Path, mission: Path, speedup: float, mission_wall_s: float) -> list[Message]:
    """Start ArduSub, the companion on ``mission``, hand over in GUIDED, wait for the mission's
    end and the SURFACE hand-back; the companion's .alog."""
    if ardusub_binary() is None:
        pytest.skip(SKIP_REASON)
    # the stock rangefinder stops at 30 m; the SITL's water is 50 m deep (a flat bottom)
    sitl = start_sub(tmp_path / "ardusub", speedup=speedup, params={"RNGFND1_MAX": 60})
    op = None
    try:
        op = SubOperator(sitl.ports.serial0, heartbeat_s=1.0 / speedup)
        op.wait_until(lambda: op.heartbeats > 0, 10.0, "the autopilot's first HEARTBEAT")
        sitl.wait_listening(sitl.ports.serial1)
        comp = CompanionProcess(mission, sitl.ports.serial1, tmp_path / "companion")
        try:
            wait(op, comp, "helm offline: autopilot disarmed", 30.0)
            op.hand_over("GUIDED", timeout_s=60.0, retry_s=1.0 / speedup)
            wait(op, comp, "helm ONLINE", 10.0)
            wait(op, comp, "MISSION ENDED", mission_wall_s)
            wait(op, comp, "handed back to the autopilot in SURFACE", 10.0)
            assert op.mode == "SURFACE"
        finally:
            comp.stop()
    finally:
        if op is not None:
            op.close()
        sitl.stop()
    return comp.alog()


def test_figure1_auv_on_ardusub(tmp_path: Path) -> None:
    mission = tmp_path / "figure1_auv_test.moos"
    mission.write_text(test_mission())
    log = fly(tmp_path, mission, SPEEDUP, 120.0)

    started = [m.string for m in named(log, "TASK_STARTED")]
    ended = dict(m.string.split(":") for m in named(log, "TASK_ENDED"))
    times = {m.string: m.time for m in named(log, "TASK_STARTED")}
    end_times = {m.string.split(":")[0]: m.time for m in named(log, "TASK_ENDED")}
    events = named(log, "TooDeep")
    t0 = log[0].time
    shifted = [Message(m.name, m.value, m.time - t0, m.source) for m in log]
    plot_run(nav_track(shifted), shifted, load_mission(mission),
             tmp_path / "companion" / "track.png", "Figure 1 (AUV) on ArduSub SITL")
    print(f"\n[ardusub] started {started}\n[ardusub] ended {ended}\n[ardusub] plot "
          f"{tmp_path / 'companion' / 'track.png'}")
    print(f"[ardusub] task times (autopilot s): "
          f"{ {k: round(v - log[0].time, 1) for k, v in times.items()} }")
    last = named(log, "NAV_DEPTH")[-1]
    print(f"[ardusub] last NAV_DEPTH {last.double:.2f} m at {last.time - log[0].time:.1f} s; "
          f"Surface ended at {end_times['Surface'] - log[0].time:.1f} s")

    assert [n for n in started if n not in ("DepthLimit", "AltitudeLimit", "OneHour")] == ORDER
    assert {k: v for k, v in ended.items() if k in ENDS} == ENDS
    # settled depth: the last 10 s of the survey at DIVE_M, and the surface at the end
    survey = depths_between(log, end_times["Survey"] - 10.0, end_times["Survey"])
    assert survey and all(abs(d - DIVE_M) <= 1.0 for d in survey), survey
    surfaced = depths_between(log, end_times["Surface"] - 1.0, end_times["Surface"])
    assert surfaced and all(d <= 1.0 + 0.5 for d in surfaced), surfaced
    assert surfaced[-1] <= 1.0, surfaced
    # the depth limit: fired while Plunge pushed below it, won the elevator, held it off
    plunge = depths_between(log, times["Plunge"], end_times["Plunge"])
    print(f"[ardusub] plunge depths: max {max(plunge):.2f} m, median "
          f"{statistics.median(plunge):.2f} m; {len(events)} TooDeep events")
    assert events and times["Plunge"] <= events[0].time <= end_times["Plunge"]
    assert max(plunge) < LIMIT_M + 1.0, "LimitDepth kept the vehicle near its limit"
    assert [m.string for m in named(log, "HELM_HANDBACK_DONE")] == ["SURFACE"]
    # the pressure sensor's depth agrees with ArduSub's own while the survey holds its depth
    baro = [m.double for m in named(log, "BARO_DEPTH")
            if end_times["Survey"] - 10.0 <= m.time <= end_times["Survey"]]
    print(f"[ardusub] BARO_DEPTH over the survey's last 10 s: {min(baro):.2f}-{max(baro):.2f} m")
    assert baro and all(abs(d - DIVE_M) <= 1.0 for d in baro), baro
    assert (tmp_path / "companion" / "track.png").stat().st_size > 0


def test_figure1_auv_as_written_meets_the_sitl_seabed(tmp_path: Path) -> None:
    """The example unchanged: the SITL's water is 50 m deep, so diving for 50 m the vehicle
    comes within 7 m of the bottom, LimitAltitude fires EndMission and ArduSub surfaces it."""
    log = fly(tmp_path, EXAMPLE, AS_WRITTEN_SPEEDUP, 120.0)
    started = [m.string for m in named(log, "TASK_STARTED")]
    ended = dict(m.string.split(":") for m in named(log, "TASK_ENDED"))
    altitude_events = [m for m in named(log, "TASK_EVENT") if m.string.startswith("Altitude")]
    deepest = max(m.double for m in named(log, "NAV_DEPTH"))
    print(f"\n[ardusub] as written: started {started}; ended {ended}; deepest {deepest:.1f} m; "
          f"{altitude_events[:1]}")
    assert [n for n in started if n not in ("DepthLimit", "AltitudeLimit", "OneHour")] == [
        "InitialDelay", "Traverse", "Dive", "Abort"]
    assert ended["Traverse"] == "complete" and "Dive" not in ended
    assert altitude_events, "LimitAltitude fired"
    assert 40.0 < deepest < 50.0
    assert [m.string for m in named(log, "MISSION_ENDED")] == ["Abort"]
