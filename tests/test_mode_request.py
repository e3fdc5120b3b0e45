"""One mode request: DO_SET_MODE sent, re-sent ``retry_s`` apart up to ``tries`` times,
done only when a HEARTBEAT shows the mode, and a failure said with its reason."""

from __future__ import annotations

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.mode_request import ROVER_MODE_NUMBERS, ModeRequest, Step


def steps(request: ModeRequest, times: list[float]) -> list[Step]:
    return [request.step(t) for t in times]


def test_sent_at_once_then_every_retry_s_until_the_tries_are_spent():
    req = ModeRequest("HOLD", tries=3, retry_s=1.0)
    assert steps(req, [0.0, 0.5, 1.0, 1.5, 2.0, 2.9]) == [
        Step.SEND, Step.WAIT, Step.SEND, Step.WAIT, Step.SEND, Step.WAIT]
    assert req.step(3.0) is Step.FAILED and req.done and not req.confirmed
    assert req.why() == "no HEARTBEAT in HOLD after 3 requests"
    assert req.step(10.0) is Step.FAILED, "a failure stays a failure: nothing more is sent"


def test_confirmed_by_the_heartbeat_showing_the_mode_only():
    req = ModeRequest("HOLD")
    assert req.step(0.0) is Step.SEND
    assert not req.heartbeat("GUIDED"), "another mode is no confirmation"
    req.acknowledged(mavlink.MAV_RESULT_ACCEPTED)
    assert not req.done, "an ACK is no confirmation either"
    assert req.heartbeat("HOLD") and req.done
    assert not req.heartbeat("HOLD"), "confirmed once"
    assert req.step(5.0) is Step.CONFIRMED


def test_a_refusal_ends_the_request_at_once():
    req = ModeRequest("GUIDED")
    req.step(0.0)
    req.acknowledged(mavlink.MAV_RESULT_DENIED)
    assert req.step(0.1) is Step.FAILED
    assert req.why() == f"DO_SET_MODE refused, result {mavlink.MAV_RESULT_DENIED}"


def test_retry_refused_keeps_trying_and_reports_the_refusal():
    req = ModeRequest("HOLD", retry_refused=True)
    req.step(0.0)
    req.acknowledged(mavlink.MAV_RESULT_FAILED)
    assert steps(req, [0.5, 1.0, 2.0]) == [Step.WAIT, Step.SEND, Step.SEND]
    assert req.step(3.0) is Step.FAILED
    assert req.why() == f"DO_SET_MODE refused, result {mavlink.MAV_RESULT_FAILED}"


def test_the_message_is_do_set_mode_with_the_custom_mode():
    msg = ModeRequest("HOLD").message(1, 1)
    assert msg.command == mavlink.MAV_CMD_DO_SET_MODE
    assert (msg.target_system, msg.target_component) == (1, 1)
    assert msg.param1 == mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert msg.param2 == ROVER_MODE_NUMBERS["HOLD"]


@pytest.mark.parametrize("kwargs", [{"mode": "FLY"}, {"mode": "HOLD", "tries": 0},
                                    {"mode": "HOLD", "retry_s": float("nan")}])
def test_a_request_that_cannot_be_made_is_refused(kwargs):
    with pytest.raises(ValueError):
        ModeRequest(**kwargs)
