"""Third-party requests (spec 1.3): the request string, the Allow lines, and the helm granting,
denying (with the reason, to the requester), timing out sessions and closing transactions."""

from __future__ import annotations

import pytest

from mavhelm.core.mission import MissionError
from mavhelm.core.thirdparty import (
    Request,
    RequestError,
    ThirdPartyRequest,
    parse_request,
)
from tests.support.helm_rig import Rig, Spec, one, safety, values


def test_a_request_is_built_and_read_back():
    text = (ThirdPartyRequest("Sample", "iScience").add_property("Location", "10,20")
            .add_property("Radius", 3).execute_task("GoToWayPoint"))
    assert text == "Sample@iScience:TASK=GoToWayPoint|Location=10,20|Radius=3"
    assert parse_request(text) == Request("Sample", "iScience", "GoToWayPoint",
                                          (("Location", "10,20"), ("Radius", "3")))
    assert parse_request(ThirdPartyRequest("Sample", "iScience").close()) == \
        Request("Sample", "iScience", None)


@pytest.mark.parametrize("text", ["", "nobody", "job@:CLOSE", "job@c:", "job@c:Location=1,2",
                                  "job@c:TASK=", "job@c:TASK=Go|Radius", "job c@x:CLOSE"])
def test_a_malformed_request_is_refused_with_a_reason(text):
    with pytest.raises(RequestError):
        parse_request(text)


def test_the_builder_refuses_what_could_not_be_read_back():
    with pytest.raises(RequestError, match="may not be empty or hold"):
        ThirdPartyRequest("a", "b").add_property("Location", "1|2")
    with pytest.raises(RequestError, match="longer than 128 bytes"):
        ThirdPartyRequest("a", "b").add_property("Name", "x" * 130).execute_task("Timer")


def guest_rig(*allow: str, leg_priority: str = "3") -> Rig:
    spec = Spec()
    tasks = [spec.task("TrackLine", ("Name", "Leg"), ("P1", "0,-100"), ("P2", "0,1000"),
                       ("Thrust", "50"), ("Priority", leg_priority), ("TimeOut", "NEVER")),
             *safety(spec)]
    return Rig(tasks, spec, *(("Allow", a) for a in allow))


NAV = {"NAV_X": 0.0, "NAV_Y": 0.0, "NAV_HEADING": 0.0}


def ask(rig: Rig, text: str, **posts) -> tuple[str, list]:
    out = rig.tick(THIRDPARTY_REQUEST=text, **NAV, **posts)
    return str(one(out, "THIRDPARTY_REPLY")), out


def test_a_priority_2_guest_takes_the_rudder_from_a_priority_3_track_line_and_gives_it_back():
    rig = guest_rig("Sample@iScience:GoToWayPoint | SessionTimeOut = 5")
    rig.tick(HELM_ONLINE=1.0, **NAV)
    rig.tick(**NAV)
    assert rig.helm.last_winners["RUDDER"][1].name == "Leg"
    reply, out = ask(rig, "Sample@iScience:TASK=GoToWayPoint|Location=100,0|Thrust=80|Priority=1")
    assert reply == "Sample@iScience:ACCEPTED:task Sample_iScience at priority 2", \
        "never more important than 2"
    assert rig.helm.last_winners["RUDDER"][1].name == "Sample_iScience"
    assert one(out, "DESIRED_THRUST") == 80.0
    out = rig.tick(NAV_X=99.0, NAV_Y=0.0, NAV_HEADING=90.0)
    assert one(out, "TASK_ENDED") == "Sample_iScience:complete"
    out = rig.tick(**NAV)
    assert rig.helm.last_winners["RUDDER"][1].name == "Leg", "the line resumes"


def test_denials_say_why():
    rig = guest_rig("Sample@iScience:GoToWayPoint")
    rig.tick(**NAV)
    reply, _ = ask(rig, "Sample@iScience:TASK=GoToWayPoint|Location=1,2")
    assert reply == ("Sample@iScience:DENIED:the helm is offline: the operator has the "
                     "vehicle")
    rig.tick(HELM_ONLINE=1.0, **NAV)
    assert ask(rig, "Sample@iScience:TASK=ConstantHeading|Heading=90")[0] == (
        "Sample@iScience:DENIED:not allowed: no Allow line grants Sample@iScience a "
        "ConstantHeading task")
    assert ask(rig, "Spy@iModem:TASK=GoToWayPoint|Location=1,2")[0] == (
        "Spy@iModem:DENIED:not allowed: no Allow line grants Spy@iModem a GoToWayPoint task")
    assert ask(rig, "Sample@iScience:TASK=GoToWayPoint|Location=nan,2")[0] == (
        "Sample@iScience:DENIED:Location must be x,y[,z] in finite metres within ±100000, "
        "got 'nan,2'")
    assert ask(rig, "garbage")[0] == ("garbage:DENIED:malformed request: expected "
                                      "job@client:TASK=Type|Key=Value|… or job@client:CLOSE")


def test_one_transaction_at_a_time_and_the_session_time_out():
    rig = guest_rig("Sample@iScience:GoToWayPoint | SessionTimeOut = 5",
                    "Map@iModem:GoToWayPoint")
    rig.tick(HELM_ONLINE=1.0, **NAV)
    assert "ACCEPTED" in ask(rig, "Sample@iScience:TASK=GoToWayPoint|Location=100,0")[0]
    assert ask(rig, "Map@iModem:TASK=GoToWayPoint|Location=0,100")[0] == (
        "Map@iModem:DENIED:busy: Sample@iScience holds the helm (one transaction at a time)")
    assert ask(rig, "Sample@iScience:TASK=GoToWayPoint|Location=5,5")[0] == (
        "Sample@iScience:DENIED:its task Sample_iScience is still running: wait for it to end "
        "or CLOSE")
    out = rig.tick(NAV_X=100.0, NAV_Y=0.0, NAV_HEADING=90.0)
    assert one(out, "TASK_ENDED") == "Sample_iScience:complete"
    # during the 5 s session only the same client may follow up
    assert "busy: Sample@iScience" in ask(rig, "Map@iModem:TASK=GoToWayPoint|Location=0,9")[0]
    for _ in range(5):
        rig.tick(**NAV)
    assert "ACCEPTED" in ask(rig, "Map@iModem:TASK=GoToWayPoint|Location=0,100|Name=M")[0], \
        "the session timed out"


def test_close_ends_the_clients_task_and_frees_the_helm():
    rig = guest_rig("Sample@iScience:GoToWayPoint | SessionTimeOut = 30",
                    "Map@iModem:GoToWayPoint")
    rig.tick(HELM_ONLINE=1.0, **NAV)
    ask(rig, "Sample@iScience:TASK=GoToWayPoint|Location=100,0|FinishFlag=SampleDone")
    assert ask(rig, "Map@iModem:CLOSE")[0] == "Map@iModem:DENIED:no open transaction to close"
    reply, out = ask(rig, "Sample@iScience:CLOSE")
    assert reply == "Sample@iScience:CLOSED:transaction closed"
    assert one(out, "TASK_ENDED") == "Sample_iScience:closed"
    assert one(out, "SampleDone") == "closed by Sample@iScience"
    assert "ACCEPTED" in ask(rig, "Map@iModem:TASK=GoToWayPoint|Location=0,100")[0]


def test_end_mission_locks_out_guests_too():
    rig = guest_rig("Sample@iScience:GoToWayPoint")
    rig.tick(HELM_ONLINE=1.0, **NAV)
    out = rig.tick(EndMission="abort", **NAV)
    assert values(out, "MISSION_ENDED") == ["Stop"]
    assert ask(rig, "Sample@iScience:TASK=GoToWayPoint|Location=1,2")[0] == (
        "Sample@iScience:DENIED:the mission has ended")


@pytest.mark.parametrize(("allow", "reason"), [
    ("Sample@iScience", "Allow expects job@client:Type1,Type2"),
    ("Sample@iScience:Fly", "Allow: unknown task type 'Fly'"),
    ("Sample@iScience:EndMission", "Allow: a third party cannot be granted EndMission"),
    ("Sample@iScience:Timer | SessionTimeOut = 60",
     "Allow: SessionTimeOut must be seconds in (0, 30], got 60"),
])
def test_allow_lines_are_checked_at_load(allow, reason):
    with pytest.raises(MissionError) as err:
        guest_rig(allow)
    assert reason in str(err.value)
