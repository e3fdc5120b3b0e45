"""The spine, end to end: simulator ↔ companion over real TCP MAVLink, nav, helm, ground station.

Every test here runs the real path: the simulator's ArduPilot-like endpoint on loopback TCP,
the companion's pymavlink connection, the bus, pNav, pHelm and back out as MAVLink.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from mavhelm.demo.harness import SimulatedRun

pytestmark = pytest.mark.slow

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def heading_error(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def task_window(run: SimulatedRun, name: str) -> tuple[float, float, str]:
    started = [m.time for m in run.values("TASK_STARTED") if m.string == name]
    ended = [m for m in run.values("TASK_ENDED") if m.string.rpartition(":")[0] == name]
    assert started, f"{name} never started"
    assert ended, f"{name} never ended"
    return started[0], ended[0].time, ended[0].string.rpartition(":")[2]


@pytest.fixture(scope="module")
def demo_run():
    with SimulatedRun.start(EXAMPLES / "demo.moos", fast_start=True) as run:
        ended = run.run_mission(max_time=500.0)
        yield run, ended


def test_demo_tasks_go_active_in_flag_order(demo_run):
    run, ended = demo_run
    assert ended, "EndMission never went active"
    order = [m.string for m in run.values("TASK_STARTED")]
    assert order.index("InitialDelay") < order.index("South") < order.index("North") \
        < order.index("Home") < order.index("AllStop")
    assert run.values("MISSION_ENDED")[0].string == "AllStop"
    causes = {name: task_window(run, name)[2] for name in ("InitialDelay", "South", "North",
                                                            "Home")}
    assert causes == {"InitialDelay": "timeout", "South": "timeout", "North": "timeout",
                      "Home": "complete"}


@pytest.mark.parametrize("name, goal", [("South", 180.0), ("North", 0.0)])
def test_demo_heading_settles_within_5_degrees(demo_run, name, goal):
    run, _ = demo_run
    start, end, _ = task_window(run, name)
    settled = [s for s in run.track if start + 20.0 <= s.t <= end]
    assert len(settled) > 100
    worst = max(heading_error(s.heading, goal) for s in settled)
    assert worst <= 5.0, f"{name}: heading strayed {worst:.1f} deg from {goal}"
    # and it actually moved along that heading
    first, last = settled[0], settled[-1]
    course = math.degrees(math.atan2(last.x - first.x, last.y - first.y)) % 360.0
    assert heading_error(course, goal) < 10.0


def test_demo_reaches_waypoint_inside_radius(demo_run):
    """The task judges arrival on NAV_X/NAV_Y (GPS here); ground truth may differ by GPS error."""
    run, _ = demo_run
    start, end, cause = task_window(run, "Home")
    assert cause == "complete"
    nav_x = [m for m in run.values("NAV_X") if m.time <= end][-1].double
    nav_y = [m for m in run.values("NAV_Y") if m.time <= end][-1].double
    assert math.hypot(nav_x - 60.0, nav_y - 0.0) <= 5.0
    at_end = min(run.track, key=lambda s: abs(s.t - end))
    gps_error_allowance = 1.5
    distance = math.hypot(at_end.x - 60.0, at_end.y - 0.0)
    assert distance <= 5.0 + gps_error_allowance, f"truth {distance:.1f} m from the waypoint"
    before = [s for s in run.track if start <= s.t <= start + 5.0]
    assert math.hypot(before[0].x - 60.0, before[0].y) > 50.0, "Home should start far away"


def test_demo_end_mission_stops_the_boat(demo_run):
    run, _ = demo_run
    ended_at = run.values("MISSION_ENDED")[0].time
    after = [m.double for m in run.values("DESIRED_THRUST") if m.time > ended_at]
    assert after and all(v == 0.0 for v in after)
    assert run.track[-1].surge < 0.3, "the boat should have slowed to a stop"


def _stays_in_manual(run: SimulatedRun) -> None:
    """Replace the operator with a ground station that only watches (no hand-over)."""
    peer = next(p for p in run.lockstep.peers if getattr(p.end, "conn", None) is run.gcs.conn)
    peer.tick = run.gcs.tick


def test_no_actuation_while_manual_then_online_within_one_tick():
    with SimulatedRun.start(EXAMPLES / "demo.moos", fast_start=True) as run:
        _stays_in_manual(run)
        run.run_for(30.0)
        assert run.gcs.mode == "MANUAL"
        assert not run.values("DESIRED_RUDDER"), "helm actuated while the autopilot was MANUAL"
        assert run.companion_link.received.get("SET_ATTITUDE_TARGET", 0) == 0
        # the operator arms and switches to GUIDED
        run.gcs.arm()
        run.run_for(1.0)
        run.gcs.set_mode("GUIDED")
        assert run.run_until(lambda _n: bool(run.values("HELM_ONLINE")), 5.0)
        online = [m for m in run.values("HELM_ONLINE") if m.double == 1.0][0]
        assert [m.time for m in run.values("DESIRED_RUDDER")][0] == online.time
        run.run_for(2.0)
        assert run.companion_link.received.get("SET_ATTITUDE_TARGET", 0) > 0


def test_mode_change_mid_mission_stops_actuation_within_one_tick():
    with SimulatedRun.start(EXAMPLES / "demo.moos", fast_start=True) as run:
        run.hand_over()
        run.run_for(20.0)
        assert run.values("DESIRED_RUDDER")
        # the operator takes back control (the spec's space bar)
        _stays_in_manual(run)
        asked_at = run.clock.now()
        run.gcs.set_mode("MANUAL")

        def manual_seen() -> list[float]:
            return [m.time for m in run.values("AP_MODE")
                    if m.string == "MANUAL" and m.time > asked_at]

        assert run.run_until(lambda _n: bool(manual_seen()), 3.0)
        manual_at = manual_seen()[0]
        offline = [m for m in run.values("HELM_ONLINE") if m.double == 0.0 and m.time > asked_at]
        assert offline and offline[0].time == manual_at
        sent_before = run.companion_link.received.get("SET_ATTITUDE_TARGET", 0)
        run.run_for(10.0)
        late = [m for m in run.values("DESIRED_RUDDER") + run.values("DESIRED_THRUST")
                if m.time >= manual_at]
        assert not late, "the helm kept actuating after the operator took back control"
        assert run.companion_link.received.get("SET_ATTITUDE_TARGET", 0) == sent_before
        assert [m.string for m in run.values("HELM_STATE")][-1] == "OFFLINE"


def test_the_ground_station_is_told_what_the_helm_does(demo_run):
    """Through the autopilot, as STATUSTEXT from the companion: online, tasks, goals, end."""
    run, _ = demo_run
    texts = [text for _, text in run.gcs.statustexts]
    for line in ("helm ONLINE: autopilot armed in GUIDED", "task South started",
                 "South steers: heading 180 deg", "task South ended: timeout",
                 "Home steers: waypoint (60, 0) within 5 m", "task Home ended: complete",
                 "MISSION ENDED (AllStop holds the vehicle)"):
        assert line in texts, f"{line!r} not among {texts}"


def test_a_long_helm_line_reaches_the_ground_station_whole(demo_run):
    """Longer than STATUSTEXT's 50 bytes: sent in MAVLink 2 chunks, joined again by the GCS."""
    run, _ = demo_run
    texts = [text for _, text in run.gcs.statustexts]
    long_lines = [t for t in texts if len(t) > 50]
    assert "helm offline: autopilot disarmed (arm it and select GUIDED to hand over)" in texts
    assert all(t.startswith(("helm ", "task ", "MISSION")) or "steers" in t
               for t in long_lines), long_lines
