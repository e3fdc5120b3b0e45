"""The companion's typed status channel: events, the state they build, their TUNNEL encoding,
and ``mavhelm remote`` learning the helm's state from it alone, end to end in the simulator."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mavhelm.companion.console import BusEvents, StatusConsole
from mavhelm.companion.link import AutopilotLink
from mavhelm.companion.remote import RemoteState
from mavhelm.companion.status import (
    Alert,
    Armed,
    AutopilotMode,
    AutopilotText,
    CompanionStatus,
    Goal,
    HandedBack,
    HelmReloaded,
    HelmState,
    LinkNote,
    LinkUp,
    MissionEnded,
    NavFailure,
    NavSource,
    NavWarning,
    RemoteFlagPosted,
    Severity,
    Snapshot,
    TaskEnded,
    TaskEvent,
    TaskStarted,
    ThirdPartyReply,
)
from mavhelm.companion.status_wire import MAX_PAYLOAD, NAME_MAX, WIRE_VERSION, decode, encode, fit
from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock

DEMO = Path(__file__).resolve().parents[1] / "examples" / "demo.moos"


# -- the reducer -------------------------------------------------------------------------------

def replay(*events) -> CompanionStatus:
    state = CompanionStatus()
    for event in events:
        state = state.apply(event)
    return state


def test_the_reducer_follows_link_mode_helm_tasks_and_goal():
    s = replay(LinkUp(True), AutopilotMode("GUIDED"), Armed(True),
               HelmState(True, "ONLINE: autopilot armed in GUIDED"),
               TaskStarted("InitialDelay"), TaskStarted("MissionClock"),
               TaskEnded("InitialDelay", "timeout"), TaskStarted("South"),
               TaskStarted("South"), Goal("South", ""), Goal("South", "heading 180 deg"))
    assert (s.link_up, s.mode, s.armed, s.online) == (True, "GUIDED", True, True)
    assert s.tasks == ("MissionClock", "South")
    assert (s.owner, s.goal) == ("South", "heading 180 deg")
    s = s.apply(TaskEnded("South", "complete"))
    assert s.tasks == ("MissionClock",) and (s.owner, s.goal) == ("", ""), \
        "a task that ended steers no more"
    s = s.apply(HelmState(False, "offline: autopilot in MANUAL; select GUIDED to hand over"))
    assert s.online is False
    assert s.status == "offline: autopilot in MANUAL; select GUIDED to hand over"


def test_news_changes_nothing_and_a_reload_forgets_the_mission():
    s = replay(TaskStarted("A"), Goal("A", "waypoint"), MissionEnded("AllStop"),
               HandedBack("HOLD"))
    for news in (LinkNote("connected"), TaskEvent("A", "left the box"),
                 RemoteFlagPosted("GoHome"), ThirdPartyReply("x@y:ACCEPTED"),
                 AutopilotText("Throttle armed")):
        assert s.apply(news) is s
    assert (s.mission_ended, s.handed_back) == ("AllStop", "HOLD")
    s = s.apply(HelmReloaded("demo.moos: 6 tasks"))
    assert (s.tasks, s.owner, s.mission_ended, s.handed_back) == ((), "", None, None)


def test_nav_health_and_alerts():
    s = replay(NavSource("X", "GPS"), NavSource("Y", "GPS"), NavSource("X", "NONE"),
               NavWarning("EKF reset"), Alert("Leg_ERROR", "starved", Severity.ERROR))
    assert s.nav_sources == (("X", "NONE"), ("Y", "GPS")) and s.nav_lost == ("X",)
    assert s.nav_warning == "EKF reset" and s.last_alert.source == "Leg_ERROR"
    assert s.apply(NavFailure("every filter timed out")).nav_failure == "every filter timed out"


def test_a_snapshot_catches_a_late_console_up_without_shortening_what_it_knew():
    s = replay(HelmState(False, "offline: autopilot in MANUAL; select GUIDED to hand over"))
    snap = Snapshot(False, "offline: autopilot in MANUAL; select", "MANUAL", True,
                    ("MissionClock",), "", "")
    s = s.apply(snap)
    assert s.status == "offline: autopilot in MANUAL; select GUIDED to hand over"
    assert (s.mode, s.armed, s.tasks) == ("MANUAL", True, ("MissionClock",))
    assert CompanionStatus().apply(snap).snapshot() == snap
    # a cut task list adds what it names and keeps what it could not
    s = replay(TaskStarted("A"), TaskStarted("B"))
    s = s.apply(Snapshot(True, "ONLINE: x", "GUIDED", True, ("C",), "C", "", tasks_cut=True))
    assert s.tasks == ("C", "A", "B")


# -- the bus as events ------------------------------------------------------------------------

def msg(name: str, value: float | str) -> Message:
    return Message(name, value, 0.0, "test")


def test_bus_variables_become_events_and_states_only_when_they_change():
    events = BusEvents()
    assert events.of(msg("HELM_STATUS", "ONLINE: autopilot armed in GUIDED")) == HelmState(
        True, "ONLINE: autopilot armed in GUIDED")
    assert events.of(msg("HELM_STATUS", "ONLINE: autopilot armed in GUIDED")) is None
    assert events.of(msg("HELM_GOAL", "South steers: heading 180 deg")) == Goal(
        "South", "heading 180 deg")
    assert events.of(msg("HELM_RUDDER_OWNER", "none")) == Goal("", "")
    assert events.of(msg("TASK_ENDED", "Leg:starved")) == TaskEnded("Leg", "starved")
    assert events.of(msg("TASK_EVENT", "Box: left the box")) == TaskEvent("Box", "left the box")
    assert events.of(msg("NAV_HEADING_SOURCE", "NONE")) == NavSource("HEADING", "NONE")
    assert events.of(msg("NAV_WARNING", "w")) == NavWarning("w")
    assert events.of(msg("NAVIGATION_FAILURE", "f")) == NavFailure("f")
    assert events.of(msg("MAVLINK_OUTPUT_REFUSED", "r")) == Alert(
        "MAVLINK_OUTPUT_REFUSED", "r", Severity.WARNING)
    assert events.of(msg("NAV_X", 3.0)) is None


def test_the_console_sends_every_event_and_a_snapshot_a_second_through_the_tunnel():
    clock = SimClock(0.0)
    bus = Bus(clock)
    payloads: list[bytes] = []
    console = StatusConsole(bus, None, tunnel=payloads.append)
    bus.subscribe(console.name, console.subscriptions())

    def tick(**posts) -> list:
        for name, value in posts.items():
            bus.notify(name, value, "test")
        before = len(payloads)
        console.on_mail(bus.fetch(console.name), clock.now())
        console.idle()
        return [decode(p) for p in payloads[before:]]

    first = tick(AP_MODE="GUIDED", TASK_STARTED="South", AP_STATUSTEXT="Throttle armed")
    assert first[:2] == [AutopilotMode("GUIDED"), TaskStarted("South")], \
        "the autopilot's own texts are not repeated"
    assert first[2] == Snapshot(None, "", "GUIDED", None, ("South",), "", "")
    clock.advance(0.5)
    assert tick(GPS_WARNING="flaky") == [Alert("GPS_WARNING", "flaky", Severity.WARNING)]
    clock.advance(0.1)
    assert tick(GPS_WARNING="flaky") == [], "a repeat within the quiet time is held back"
    clock.advance(0.4)
    assert [type(e) for e in tick()] == [Snapshot]
    assert all(len(p) <= MAX_PAYLOAD for p in payloads)


# -- the encoding ---------------------------------------------------------------------------

names = st.text(max_size=60)
texts = st.text(max_size=300)
maybe = st.none() | st.booleans()
events = st.one_of(
    st.builds(LinkUp, st.booleans()), st.builds(LinkNote, texts),
    st.builds(AutopilotMode, names), st.builds(Armed, st.booleans()),
    st.builds(HelmState, st.booleans(), texts), st.builds(TaskStarted, names),
    st.builds(TaskEnded, names, names), st.builds(TaskEvent, names, texts),
    st.builds(Goal, names, texts), st.builds(Alert, names, texts, st.sampled_from(Severity)),
    st.builds(MissionEnded, names), st.builds(HelmReloaded, texts),
    st.builds(HandedBack, names), st.builds(RemoteFlagPosted, names),
    st.builds(ThirdPartyReply, texts), st.builds(AutopilotText, texts),
    st.builds(NavSource, names, names), st.builds(NavWarning, texts),
    st.builds(NavFailure, texts),
    st.builds(Snapshot, maybe, texts, st.none() | names, maybe,
              st.lists(names, max_size=12).map(tuple), names, texts, st.booleans()))


@settings(max_examples=400, deadline=None)
@given(events)
def test_every_event_round_trips_as_it_was_fitted(event):
    payload = encode(event)
    assert len(payload) <= MAX_PAYLOAD
    assert decode(payload) == fit(event)
    assert fit(fit(event)) == fit(event)


@settings(max_examples=200, deadline=None)
@given(st.builds(TaskStarted, st.from_regex(r"[A-Za-z0-9_]{1,32}", fullmatch=True)),
       st.from_regex(r"[ -~]{0,90}", fullmatch=True))
def test_plain_names_and_short_texts_arrive_unchanged(started, why):
    assert decode(encode(started)) == started
    helm = HelmState(False, why)
    assert decode(encode(helm)) == helm


def test_long_names_are_cut_the_same_way_everywhere_and_texts_on_a_character_boundary():
    name = "Survey_" + "é" * 40
    arrived = [decode(encode(e)) for e in (TaskStarted(name), TaskEnded(name, "complete"))]
    assert len(arrived[0].name.encode()) <= NAME_MAX and name.startswith(arrived[0].name)
    assert replay(*arrived).tasks == (), "the end matches the start"
    long = decode(encode(HelmState(False, "offline: " + "ü" * 200)))
    assert long.status.startswith("offline: üü") and "\ufffd" not in long.status
    snap = decode(encode(Snapshot(True, "ONLINE: x", "GUIDED", True,
                                  tuple(f"Task{i:02d}_with_a_long_name" for i in range(10)),
                                  "Task00_with_a_long_name", "heading 180 deg")))
    assert snap.tasks_cut and 0 < len(snap.tasks) < 10 and snap.goal == "heading 180 deg"
    assert decode(encode(Alert("X_WARNING", "\x1b[2J\x07bell", Severity.WARNING))).text == \
        "?[2J?bell", "nothing that moves a terminal's cursor"


@settings(max_examples=500, deadline=None)
@given(st.binary(max_size=200))
def test_garbage_is_refused_without_raising(data):
    event = decode(data)
    if event is not None:
        assert decode(encode(event)) == fit(event)


@pytest.mark.parametrize("payload", [
    b"", bytes([WIRE_VERSION]), bytes([2, 6, 1, 65]), bytes([WIRE_VERSION, 99]),
    bytes([WIRE_VERSION, 6, 5, 65]),                   # a name longer than the payload
    bytes([WIRE_VERSION, 6, 1, 65, 0]),                # a byte left over
    bytes([WIRE_VERSION, 1, 2]),                       # a flag that is neither 0 nor 1
    bytes([WIRE_VERSION, 6, 1, 0x1b]),                 # a control character
    bytes([WIRE_VERSION, 6, 2, 0xc3, 0x28]),           # not UTF-8
    bytes([WIRE_VERSION, 10, 1, 65, 0, 9]),            # no such severity
    bytes([WIRE_VERSION, 6, 1, 65]) + bytes(130),      # longer than a TUNNEL payload
    [WIRE_VERSION, 6, 300],                            # not bytes at all
])
def test_malformed_payloads_are_refused(payload):
    assert decode(payload) is None


def test_a_payload_arrives_as_the_tunnels_list_of_numbers():
    assert decode(list(encode(TaskStarted("South")))) == TaskStarted("South")


# -- end to end ----------------------------------------------------------------------------

@pytest.mark.slow
def test_the_remote_console_learns_the_helm_from_the_typed_channel_alone():
    """Companion, simulator, a scripted operator and ``RemoteState`` in lockstep; every
    STATUSTEXT is kept from the console, yet it learns the running tasks, a task's end and,
    after its own ``o`` switches the autopilot to MANUAL, why the helm went offline."""
    from mavhelm.demo.harness import SimulatedRun

    with SimulatedRun.start(DEMO) as run:
        link = AutopilotLink(f"tcp:127.0.0.1:{run.sim.ports[2]}", 57600, 254, 190, 1, 1)
        remote = RemoteState(sysid=254, compid=190)
        withheld: list[str] = []

        def send(messages) -> None:
            for m in messages:
                link.mav.send(m)

        def remote_tick(now: float) -> None:
            """As ``mavhelm remote``'s loop, but every STATUSTEXT withheld from the console."""
            messages = link.poll(now)
            send(remote.connection(link.connected, now))
            for m in messages:
                if m.get_type() == "STATUSTEXT":
                    withheld.append(m.text)
                elif m.get_type() != "BAD_DATA":
                    send(remote.receive(m, now))
            send(remote.tick(now))

        try:
            run.lockstep.add_peer(link, remote_tick)
            run.hand_over()
            assert run.run_until(lambda _now: "South" in remote.tasks, 30.0), remote.helm_status
            assert remote.tasks == ["MissionClock", "South"], "InitialDelay's end was heard"
            assert remote.helm == "ONLINE: autopilot armed in GUIDED" and remote.helm_online()
            assert remote.helm_status.owner == "South"
            assert remote.helm_status.goal == "heading 180 deg"
            send(remote.handle_key("o", remote.now))
            assert run.run_until(lambda _now: remote.helm_status.online is False, 10.0)
            assert remote.helm.startswith("offline: autopilot in MANUAL")
            assert remote.mode == "MANUAL" and not remote.helm_online()
            run.run_for(2.0)
            assert remote.tasks == ["MissionClock", "South"], "the snapshots agree"
            assert any("task South started" in t for t in withheld), \
                "the companion did send its lines, and the console never saw them"
            assert not [t for _, source, t in remote.texts if source == "helm"]
        finally:
            run.lockstep.remove_peer(link)
            link.close()
