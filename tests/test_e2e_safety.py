"""Safety, end to end: loss of navigation and loss of the autopilot link stop helm actuation.

Faults are injected in the simulator with a scenario (the same file format a user replays), and
the companion sees them only through MAVLink, as it would on the water.
"""

from __future__ import annotations

import pytest

from mavhelm.core.mission import parse_mission
from mavhelm.demo.harness import SimulatedRun
from mavhelm.sitl.faults import Scenario
from tests.support.mission import mission_text

pytestmark = pytest.mark.slow

TASKS = """
    Task = GoToWayPoint
    {
        Name = FarAway
        Location = 0, 3000
        Radius = 5
        Thrust = 60
        TimeOut = NEVER
        FinishFlag = EndMission
    }
"""


def start(x_queue: str, scenario: str, params: dict[str, float] | None = None) -> SimulatedRun:
    mission = parse_mission(mission_text(
        TASKS, imavlink={"OnlineModes": "GUIDED"}, overall_timeout=2000, end_name="AllStop",
        nav={"X": x_queue, "Y": x_queue, "Yaw": "INS @ 1.0"}), "safety.moos")
    return SimulatedRun.start(mission, fast_start=True,
                              scenario=Scenario.from_text(scenario, "safety.scn"),
                              record={"NAV_Y_SOURCE"}, params=params)


# The autopilot's own EKF failsafe (FS_EKF_ACTION = 1, HOLD) would take the vehicle away from the
# helm ~10 s after it loses position; switched off, only the helm's starvation rule is left.
NO_EKF_FAILSAFE = {"FS_EKF_ACTION": 0.0}


def actuation_between(run: SimulatedRun, t0: float, t1: float) -> list:
    return [m for m in run.values("DESIRED_RUDDER") + run.values("DESIRED_THRUST")
            if t0 <= m.time < t1]


def test_gps_loss_with_no_other_source_starves_the_motion_task():
    with start("GPS @ 2.0", "seed = 1\ngps_outage from 40 to 400\n", NO_EKF_FAILSAFE) as run:
        run.hand_over()
        assert run.run_until(lambda _n: run.mission_ended(), 120.0)
        last_fix = max(m.time for m in run.values("NAV_X"))
        assert 39.0 <= last_fix <= 41.0, "NAV_X must stop when GPS stops"
        sources = [(m.time, m.string) for m in run.values("NAV_X_SOURCE")]
        assert sources[-1][1] == "NONE"
        lost_at = sources[-1][0]
        assert last_fix + 2.0 <= lost_at <= last_fix + 2.0 + 0.25
        thrust = [(m.time, m.double) for m in run.values("DESIRED_THRUST")]
        before = [v for t, v in thrust if lost_at - 1.0 <= t < lost_at]
        assert len(before) >= 9 and set(before) == {60.0}, "driving until the loss"
        assert all(v == 0.0 for t, v in thrust if t >= lost_at), "stop in the declaring tick"
        ended = [m for m in run.values("TASK_ENDED") if m.string.startswith("FarAway:")]
        assert ended and ended[0].string == "FarAway:starved"
        assert last_fix + 9.5 <= ended[0].time <= last_fix + 10.5
        errors = [m for m in run.messages if m.name.endswith("_ERROR")]
        assert errors and "FARAWAY" in errors[0].name.upper()
        assert run.values("MISSION_ENDED")[0].string == "AllStop", "FinishFlag did not fire"
        assert all(m.double == 0.0 for m in run.values("DESIRED_THRUST")
                   if m.time >= ended[0].time)


def nav_sources(run: SimulatedRun) -> list[tuple[float, str]]:
    """NAV_X's source changes after the first fix (pNav announces NONE before any data)."""
    sources = [(m.time, m.string) for m in run.values("NAV_X_SOURCE")]
    first_fix = next(i for i, (_, name) in enumerate(sources) if name != "NONE")
    return sources[first_fix:]


def test_gps_loss_falls_back_to_the_autopilot_estimate_and_pops_back():
    with start("GPS @ 2.0, AP @ 2.0", "seed = 2\ngps_outage from 40 to 48\n") as run:
        run.hand_over()
        run.run_until(lambda n: n >= 70.0, 120.0)
        sources = nav_sources(run)
        assert [name for _, name in sources] == ["GPS", "AP", "GPS"], sources
        fell_back, popped = sources[1][0], sources[2][0]
        last_gps = max(m.time for m in run.values("NAV_X") if m.time < 40.5)
        assert last_gps + 2.0 <= fell_back <= last_gps + 2.0 + 0.25
        assert 48.0 <= popped <= 49.5
        assert not [m for m in run.values("TASK_ENDED") if m.string.startswith("FarAway")]
        driving = [m.double for m in run.values("DESIRED_THRUST") if 42.0 <= m.time < 48.0]
        assert driving and all(v == 60.0 for v in driving), "keep driving on the fallback"


def test_long_gps_loss_exhausts_the_fallback_and_starves():
    """The autopilot's EKF dead-reckons only for a while; then no source is left at all."""
    with start("GPS @ 2.0, AP @ 2.0", "seed = 4\ngps_outage from 40 to 400\n",
               NO_EKF_FAILSAFE) as run:
        run.hand_over()
        assert run.run_until(lambda _n: run.mission_ended(), 120.0)
        sources = nav_sources(run)
        assert [name for _, name in sources] == ["GPS", "AP", "NONE"], sources
        none_at = sources[2][0]
        ended = [m for m in run.values("TASK_ENDED") if m.string.startswith("FarAway:")]
        assert ended[0].string == "FarAway:starved"
        assert none_at + 7.5 <= ended[0].time <= none_at + 8.5 + 0.25


def test_long_gps_loss_with_ekf_failsafe_hands_the_vehicle_to_hold():
    """ArduPilot's default EKF failsafe switches to HOLD; the helm sees the mode and stops."""
    with start("GPS @ 2.0, AP @ 2.0", "seed = 4\ngps_outage from 40 to 400\n") as run:
        run.hand_over()
        run.run_until(lambda n: n >= 80.0, 120.0)
        hold = [m.time for m in run.values("AP_MODE") if m.string == "HOLD"]
        assert hold, "the autopilot's EKF failsafe should have switched to HOLD"
        assert any("EKF failsafe" in m.string for m in run.values("AP_STATUSTEXT"))
        offline = [m.time for m in run.values("HELM_ONLINE") if m.double == 0.0]
        assert offline and offline[0] == hold[0]
        assert not actuation_between(run, hold[0], 80.0)


def test_link_loss_puts_the_helm_offline_and_it_reengages_only_in_guided():
    scenario = "seed = 3\nlink_drop from 30 to 40 link=0\nlink_drop from 60 to 75 link=0\n"
    with start("GPS @ 2.0", scenario) as run:
        run.hand_over()
        assert run.run_until(lambda n: n >= 45.0, 60.0)
        lost = [m.time for m in run.values("AP_LINK") if m.double == 0.0]
        assert lost and 32.0 <= lost[0] <= 33.3, "link declared lost 3 s after the last HEARTBEAT"
        offline = [m.time for m in run.values("HELM_ONLINE") if m.double == 0.0]
        assert offline[0] == lost[0], "offline in the same tick the link is declared lost"
        assert not actuation_between(run, lost[0], 40.0)
        back = [m.time for m in run.values("HELM_ONLINE") if m.double == 1.0 and m.time > 40.0]
        assert back and back[0] <= 42.0, "link back while still GUIDED: online again"

        # second outage: the operator takes manual control while the companion cannot hear
        run.run_until(lambda n: n >= 65.0, 30.0)
        run.gcs.set_mode("MANUAL")
        peer = next(p for p in run.lockstep.peers if getattr(p.end, "conn", None) is run.gcs.conn)
        peer.tick = run.gcs.tick
        run.run_until(lambda n: n >= 90.0, 30.0)
        assert run.gcs.mode == "MANUAL"
        assert not actuation_between(run, 63.5, 90.0), "must not re-engage in MANUAL"
        assert [m.double for m in run.values("HELM_ONLINE")][-1] == 0.0
        # and once the operator hands back in GUIDED, the helm resumes
        run.gcs.set_mode("GUIDED")
        assert run.run_until(lambda _n: run.values("HELM_ONLINE")[-1].double == 1.0, 5.0)
