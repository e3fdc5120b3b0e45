"""The web view: its pieces alone (address, actions, the picture's data, the server process),
then the view on a companion and simulator in lockstep: frames, and the control actions
refused without the token and obeyed with it."""

from __future__ import annotations

import json
import math
import signal
import socket
import time
import urllib.error
import urllib.request

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.web import picture
from mavhelm.companion.web.control import WEB_COMPONENT, Action, as_heard
from mavhelm.companion.web.server import TOKEN_HEADER, WebProcess, parse_address
from mavhelm.companion.web.view import FAILURE_REPEAT_S, WebView
from mavhelm.core.bus import Bus
from mavhelm.core.clock import SimClock
from mavhelm.core.mission import load_mission
from mavhelm.demo.harness import SimulatedRun
from mavhelm.tasks.helm import Helm
from tests.support.mission import mission_text
from tests.support.waiting import wait_for
from tests.support.web_rig import TASKS


def test_address_is_loopback_unless_a_host_is_given():
    assert parse_address("8080") == ("127.0.0.1", 8080)
    assert parse_address("0.0.0.0:80") == ("0.0.0.0", 80)
    assert parse_address("[::1]:9000") == ("::1", 9000)
    for bad in ("", "x", "70000", "host:-1", "host:"):
        with pytest.raises(ValueError, match="PORT"):
            parse_address(bad)


def _state(server: WebProcess) -> dict:
    with urllib.request.urlopen(server.url + "api/state", timeout=5) as answer:
        return json.loads(answer.read())


def test_offering_never_waits_and_drops_what_the_server_cannot_take():
    server = WebProcess("127.0.0.1", 0)
    server.start()
    try:
        assert server.offer({"type": "frame", "n": 1, "track": [[1.0, 2.0]]})
        wait_for(lambda: _state(server).get("n") == 1, 10.0, "the frame at the server")
        assert _state(server)["track_points"] == 1
        server._proc.send_signal(signal.SIGSTOP)  # a server that takes nothing
        try:
            t0 = time.perf_counter()
            for n in range(5000):
                server.offer({"type": "frame", "n": n, "track": [], "pad": "x" * 500})
            assert time.perf_counter() - t0 < 2.0 and server.dropped > 0
        finally:
            server._proc.send_signal(signal.SIGCONT)
        wait_for(lambda: server.offer({"type": "frame", "n": -1, "track": []})
                 and _state(server).get("n") == -1, 10.0, "the server taking frames again")
        assert server.offer({"type": "frame", "bad": math.nan})  # JSON has no NaN
        problems = wait_for(lambda: server.actions() or server.problems(), 10.0,
                            "the server saying the frame could not be made")
        assert "ValueError" in problems[0] and _state(server).get("n") == -1
    finally:
        server.stop()
    assert not server.offer({"n": 2})


def test_an_address_in_use_is_refused_at_start():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        server = WebProcess("127.0.0.1", taken.getsockname()[1])
        with pytest.raises(OSError, match="cannot listen"):
            server.start()


def test_actions_are_the_commands_a_ground_station_sends_the_companion():
    target = (1, 191)
    stop = Action.parse("allstop", {}, "1.2.3.4").command("GUIDED", target)
    assert (stop.command, stop.target_system, stop.target_component) == \
        (mavlink.MAV_CMD_DO_SET_MODE, 1, 191)
    assert stop.param2 == 4  # HOLD
    assert Action.parse("handback", {}, "p").command("GUIDED", target).param2 == 15
    assert Action.parse("restart", {}, "p").command("GUIDED", target).command == \
        mavlink.MAV_CMD_USER_1
    flag = Action.parse("flag", {"index": 2}, "p").command("GUIDED", target)
    assert (flag.command, flag.param1) == (mavlink.MAV_CMD_USER_2, 2.0)
    heard = as_heard(stop, (1, WEB_COMPONENT))
    assert (heard.get_srcSystem(), heard.get_srcComponent()) == (1, WEB_COMPONENT)
    for body in ({}, {"index": 0}, {"index": 1.5}, {"index": True}, {"index": "1"},
                 {"index": math.nan}, {"index": 256}):
        with pytest.raises(ValueError, match="index"):
            Action.parse("flag", body, "p")
    with pytest.raises(ValueError, match="unknown"):
        Action.parse("launch", {}, "p")


def test_the_picture_draws_each_task_and_only_finite_estimates(tmp_path):
    path = tmp_path / "m.moos"
    path.write_text(mission_text(TASKS))
    helm = Helm.from_mission(Bus(SimClock(0.0)), load_mission(path))
    shapes = {s["task"]: s for s in picture.mission_shapes(helm.tasks)}
    assert shapes["OutLeg"] == {"task": "OutLeg", "kind": "line",
                                "points": [[0.0, 0.0], [40.0, 0.0]], "r": 3.0}
    assert shapes["HomeLeg"]["kind"] == "point" and shapes["HomeLeg"]["p"] == [0.0, 20.0]
    assert shapes["Fence"] == {"task": "Fence", "kind": "box", "min": [-100, -100],
                               "max": [100, 100]}
    assert "Wait" not in shapes
    poses = picture.poses({"NAV_X": 1.0, "NAV_Y": 2.0, "NAV_HEADING": 370.0,
                           "GPS_X": math.nan, "GPS_Y": 1.0, "EKF_X": 1.0, "EKF_Y": 2.0,
                           "EKF_SIGMA_X": 3.0, "EKF_SIGMA_Y": 4.0, "TRUTH_X": "x"})
    assert poses == {"nav": {"x": 1.0, "y": 2.0, "heading": 10.0},
                     "ekf": {"x": 1.0, "y": 2.0, "sigma_x": 3.0, "sigma_y": 4.0}}
    assert picture.ranges({"RB_RANGE_B1": 12.345, "RB_RANGE_B2": math.inf}) == {"B1": 12.35}
    assert picture.flag_names(helm.tasks) == ["Back", "EndMission", "Go", "OutOfBox"]


def _post(url: str, token: str | None) -> int:
    headers = {"Content-Type": "application/json"}
    if token is not None:
        headers[TOKEN_HEADER] = token
    request = urllib.request.Request(url, data=b"{}", method="POST", headers=headers)
    try:
        with urllib.request.urlopen(request, timeout=5) as answer:
            return answer.status
    except urllib.error.HTTPError as exc:
        return exc.code


@pytest.fixture
def lockstep(tmp_path):
    path = tmp_path / "web.moos"
    path.write_text(mission_text(TASKS, overall_timeout=600))
    with SimulatedRun.start(path, record=["WEB_CONTROL_WARNING", "AP_MODE_REQUEST"]) as run:
        server = WebProcess("127.0.0.1", 0, token="sesame")
        server.start()
        run.companion.community.apps.append(WebView(run.companion, server))
        try:
            yield run, server
        finally:
            server.stop()


def test_frames_show_the_helm_and_control_needs_the_token(lockstep):
    run, server = lockstep
    run.hand_over()
    run.run_for(25.0)
    frame = wait_for(lambda: (f := _state(server)).get("t", 0) > 20 and f, 10.0, "a frame")
    assert frame["status"]["online"] is True
    assert frame["status"]["owner"] in ("OutLeg", "HomeLeg")
    assert frame["poses"]["nav"]["x"] > 5.0 and "truth" in frame["poses"]
    assert {s["task"] for s in frame["mission"]["shapes"]} == {"OutLeg", "HomeLeg", "Fence"}
    assert frame["goal"]["task"] == frame["status"]["owner"]
    assert frame["track_points"] > 10
    control = server.url + "api/control/allstop"
    assert _post(control, None) == 401
    assert _post(control, "wrong") == 403
    run.run_for(3.0)
    assert run.gcs.mode == "GUIDED" and not run.values("WEB_CONTROL_WARNING")
    assert _post(control, "sesame") == 202
    run.run_for(3.0)
    assert run.gcs.mode == "HOLD"
    said = [m.string for m in run.values("WEB_CONTROL_WARNING")]
    assert said == ["ALL STOP (HOLD) from the web page (127.0.0.1)"]
    assert any("ALL STOP (HOLD) from the web page" in text for _, text in run.gcs.statustexts)
    assert _post(server.url + "api/control/handback", "sesame") == 202
    run.run_for(3.0)
    assert run.gcs.mode == "GUIDED"


def test_without_control_every_action_is_refused(tmp_path):
    server = WebProcess("127.0.0.1", 0)
    server.start()
    try:
        assert _post(server.url + "api/control/allstop", "anything") == 403
        time.sleep(0.2)
        assert server.actions() == []
    finally:
        server.stop()


def test_a_frame_that_cannot_be_made_is_reported_not_raised(lockstep):
    run, server = lockstep
    view = run.companion.community.apps[-1]
    assert isinstance(view, WebView)
    facts = view.facts
    view.facts = lambda now: {**facts(now), "t": math.nan}  # not JSON: as a bug would make
    run.record.add("WEB_VIEW_WARNING")
    run.run_for(2.0)
    wait_for(lambda: run.run_for(0.5) or view.failures >= 4, 20.0, "the server's refusals")
    said = [m.string for m in run.values("WEB_VIEW_WARNING")]
    assert len(said) == 1 and "the helm carries on" in said[0] and "ValueError" in said[0]
    view.facts = lambda now: {"unpicklable": lambda: None}  # fails in the tick itself
    run.run_for(11.0)
    # the server process may still refuse NaN frames sent before the change while the
    # lockstep simulation runs its 10 s in less than a wall second: run on until it has
    # drained and the tick's own failure is said
    wait_for(lambda: run.run_for(1.0) or any(
        "pickle" in m.string.lower() for m in run.values("WEB_VIEW_WARNING")[1:]), 30.0,
        "the tick's own failure said")
    warnings = run.values("WEB_VIEW_WARNING")
    said = [m.string for m in warnings]
    assert len(said) >= 2 and "pickle" in said[-1].lower(), said
    assert all("the helm carries on" in text for text in said)
    times = [m.time for m in warnings]
    assert all(b - a >= FAILURE_REPEAT_S - 1e-6 for a, b in zip(times, times[1:], strict=False))


def test_frames_wait_out_busy_ticks_but_keep_coming(lockstep):
    """A due frame skips a tick that is already slow (the picture's work lands in the slack,
    not on the helm's slowest ticks), never more than two in a row: the page still gets ≥ 2 Hz
    even when every other tick is slow."""
    from mavhelm.core.app import App

    run, server = lockstep
    view = run.companion.community.apps[-1]

    class SlowEveryOtherTick(App):
        name = "slow"
        ticks = 0
        framed_when_slow = 0

        def iterate(self, now: float) -> None:
            self.ticks += 1
            if self.ticks % 2:
                time.sleep(0.004)
                self.sent_before = server.sent

        def check(self) -> None:
            if self.ticks % 2 and server.sent > self.sent_before:
                self.framed_when_slow += 1

    slow = SlowEveryOtherTick(run.companion.bus)
    apps = run.companion.community.apps
    apps.insert(len(apps) - 1, slow)
    apps.append(type("Check", (App,), {"name": "check",
                                       "iterate": lambda self, now: slow.check()})(slow.bus))
    run.run_for(5.0)
    sent0, t0 = server.sent, run.clock.now()
    run.run_for(20.0)
    rate = (server.sent - sent0) / (run.clock.now() - t0)
    assert view.deferred > 10 and rate >= 2.0, (view.deferred, rate)
    assert slow.framed_when_slow <= 0.1 * slow.ticks, "frames made on the slow ticks"


def test_frames_keep_values_alerts_flags_and_a_track_between_facts():
    """The server's side: values persist across facts, alerts newest first, a non-finite flag
    shown as text (JSON has no NaN), a track point only after the vehicle moved 0.5 m."""
    from mavhelm.companion.status import CompanionStatus
    from mavhelm.companion.web.frames import Frames

    def facts(t: float, values: dict, mission: dict | None = None) -> dict:
        out = {"type": "facts", "t": t, "status": CompanionStatus(), "values": values,
               "goal": None, "running": [], "link": {}, "web": {"dropped": 0}}
        return out if mission is None else {**out, "mission": mission}

    frames = Frames()
    first = frames.frame(facts(1.0, {"NAV_X": 1.0, "NAV_Y": 2.0, "Go": math.nan,
                                     "HELM_WARNING": "first"},
                                 {"shapes": [], "beacons": [], "flags": ["Go", "Back"],
                                  "remote_flags": [], "path": "m.moos"}))
    assert first["track"] == [[1.0, 2.0]] and first["flags"] == {"Go": "nan"}
    assert first["mission"]["path"] == "m.moos" and "flags" not in first["mission"]
    second = frames.frame(facts(1.25, {"NAV_X": 1.2, "NAV_Y": 2.0, "Back": "DONE",
                                       "NAV_WARNING": "second"}))
    assert second["track"] == [] and "mission" not in second
    assert second["flags"] == {"Go": "nan", "Back": "DONE"}
    assert second["alerts"] == ["NAV_WARNING: second", "HELM_WARNING: first"]
    assert second["poses"]["nav"] == {"x": 1.2, "y": 2.0}
    third = frames.frame(facts(1.5, {"NAV_X": 1.8, "NAV_Y": 2.0}))
    assert third["track"] == [[1.8, 2.0]]
    json.dumps(third, allow_nan=False)
