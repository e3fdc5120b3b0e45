"""``mavhelm remote``, the iRemote console: what each key sends, what it refuses, what the
screen shows, and the real thing on a pseudo-terminal against ``mavhelm sim``.

The unit tests feed ``RemoteState`` real MAVLink frames (encoded with a source system and
component, then parsed back, as the link delivers them) and read the messages it returns.
"""

from __future__ import annotations

import fcntl
import os
import pty
import re
import select
import signal
import struct
import subprocess
import sys
import termios
import threading
import time

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.remote import (
    KeyReader,
    RemoteState,
    parse_ids,
    render,
)
from mavhelm.companion.status import HelmReloaded, HelmState, MissionEnded, TaskEnded, TaskStarted
from mavhelm.companion.status_wire import STATUS_PAYLOAD_TYPE, encode
from tests.support.interop_helpers import REPO, Companion, SimProcess, _child_env
from tests.support.waiting import wait_for

AP = (1, 1)
COMPANION = (1, 191)
GCS = (255, 190)
MODES = {"MANUAL": 0, "HOLD": 4, "GUIDED": 15}


# -- helpers ---------------------------------------------------------------------------------

def frame(msg: mavlink.MAVLink_message, src: tuple[int, int] = AP) -> mavlink.MAVLink_message:
    """The message as the link would deliver it: encoded by ``src``, parsed back."""
    encoder = mavlink.MAVLink(None, srcSystem=src[0], srcComponent=src[1])
    parsed = mavlink.MAVLink(None).parse_buffer(msg.pack(encoder))
    assert parsed and len(parsed) == 1
    return parsed[0]


def heartbeat(mode: str = "MANUAL", armed: bool = False) -> mavlink.MAVLink_message:
    base = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    if armed:
        base |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    return frame(mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_SURFACE_BOAT, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, base, MODES[mode],
        mavlink.MAV_STATE_ACTIVE, 3))


def companion_heartbeat(src: tuple[int, int] = COMPANION) -> mavlink.MAVLink_message:
    return frame(mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
        mavlink.MAV_STATE_ACTIVE, 3), src)


def text(line: str, src: tuple[int, int] = COMPANION) -> mavlink.MAVLink_message:
    return frame(mavlink.MAVLink_statustext_message(6, line.encode()), src)


def status(event) -> mavlink.MAVLink_message:
    """A typed status event from the companion, in a TUNNEL to every listener."""
    payload = encode(event)
    return frame(mavlink.MAVLink_tunnel_message(0, 0, STATUS_PAYLOAD_TYPE, len(payload),
                                                payload.ljust(128, b"\0")), COMPANION)


def ack(command: int, result: int = mavlink.MAV_RESULT_ACCEPTED, src: tuple[int, int] = AP,
        to: tuple[int, int] = GCS) -> mavlink.MAVLink_message:
    return frame(mavlink.MAVLink_command_ack_message(command, result, 0, 0, *to), src)


def named(name: str, value: float) -> mavlink.MAVLink_message:
    return frame(mavlink.MAVLink_named_value_float_message(0, name.encode(), value), COMPANION)


def state_up(mode: str = "MANUAL", armed: bool = True, now: float = 10.0, **kw) -> RemoteState:
    """A console connected to an autopilot whose HEARTBEAT says ``mode``/``armed``."""
    s = RemoteState(**kw)
    s.connection(True, now)
    s.tick(now)
    s.receive(heartbeat(mode, armed), now)
    return s


def types(messages) -> list[str]:
    return [m.get_type() for m in messages]


def is_set_mode(m, mode: str) -> bool:
    return (m.get_type() == "COMMAND_LONG" and m.command == mavlink.MAV_CMD_DO_SET_MODE
            and m.target_system == 1 and m.target_component == 1
            and m.param1 == mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
            and m.param2 == MODES[mode])


def channels(m) -> list[int]:
    assert m.get_type() == "RC_CHANNELS_OVERRIDE"
    assert (m.target_system, m.target_component) == AP
    return [getattr(m, f"chan{i}_raw") for i in range(1, 9)]


def override(steer: int, throttle: int) -> list[int]:
    return [steer, 65535, throttle, 65535, 65535, 65535, 65535, 65535]


RELEASE = override(0, 0)


# -- ground-station duties -------------------------------------------------------------------

def test_gcs_heartbeat_every_second_and_streams_asked_when_the_autopilot_appears():
    s = RemoteState()
    s.connection(True, 0.0)
    first = s.tick(0.0)
    assert types(first) == ["HEARTBEAT"]
    assert first[0].type == mavlink.MAV_TYPE_GCS
    assert first[0].autopilot == mavlink.MAV_AUTOPILOT_INVALID
    assert s.tick(0.5) == []
    assert types(s.tick(1.0)) == ["HEARTBEAT"]
    out = s.receive(heartbeat("MANUAL"), 1.2)
    assert types(out) == ["REQUEST_DATA_STREAM"]
    req = out[0]
    assert (req.target_system, req.target_component) == AP
    assert (req.req_stream_id, req.req_message_rate, req.start_stop) == (
        mavlink.MAV_DATA_STREAM_ALL, 2, 1)
    assert s.link_up and s.mode == "MANUAL" and not s.armed
    assert s.receive(heartbeat("MANUAL"), 1.5) == []  # asked once per link-up
    # nothing but heartbeats for 5 s: asked again; a stream arriving stops that
    for t in (3.0, 5.0, 6.2):
        s.receive(heartbeat("MANUAL"), t)
    assert "REQUEST_DATA_STREAM" not in types(s.tick(6.1))
    assert "REQUEST_DATA_STREAM" in types(s.tick(6.3))
    s.receive(frame(mavlink.MAVLink_vfr_hud_message(0, 1.5, 90, 20, 0, 0)), 6.4)
    s.receive(heartbeat("MANUAL"), 8.0)
    assert "REQUEST_DATA_STREAM" not in types(s.tick(9.0))
    assert s.vfr == (1.5, 90.0, 20)


def test_link_down_after_three_seconds_without_heartbeat():
    s = state_up(now=0.0)
    s.tick(2.9)
    assert s.link_up
    s.tick(3.1)
    assert not s.link_up
    assert "DOWN" in s.status
    assert "LINK DOWN (no HEARTBEAT for 3 s)" in "\n".join(render(s))


def test_a_companion_heartbeat_or_a_gcs_heartbeat_is_not_the_autopilot():
    s = RemoteState()
    s.connection(True, 0.0)
    s.receive(companion_heartbeat(), 0.1)
    s.receive(frame(mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 4, 3), (1, 1)), 0.1)
    assert not s.link_up and s.mode is None
    assert s.companion_heard == 0.1


# -- space: ALL STOP -------------------------------------------------------------------------

def test_space_is_all_stop_hold_and_sticks_released():
    s = state_up("MANUAL", armed=True)
    s.handle_key("w", 10.1)
    out = s.handle_key(" ", 10.2)
    assert types(out) == ["RC_CHANNELS_OVERRIDE"] * 3 + ["COMMAND_LONG"]
    assert all(channels(m) == RELEASE for m in out[:3])
    assert is_set_mode(out[3], "HOLD")
    assert (s.thrust, s.rudder) == (0, 0)
    assert "ALL STOP" in s.status
    s.receive(ack(mavlink.MAV_CMD_DO_SET_MODE), 10.3)
    assert s.status == "mode HOLD: accepted"


def test_space_is_never_refused_while_connected_even_in_guided_or_without_heartbeat():
    s = state_up("GUIDED", armed=True)
    out = s.handle_key(" ", 10.1)
    assert len(out) == 1 and is_set_mode(out[0], "HOLD")  # nothing was overridden
    silent = RemoteState()
    silent.connection(True, 0.0)
    out = silent.handle_key(" ", 0.1)
    assert len(out) == 1 and is_set_mode(out[0], "HOLD")


def test_space_without_a_connection_says_so_loudly():
    s = RemoteState()
    assert s.handle_key(" ", 0.0) == []
    assert "NOT SENT" in s.status


def test_a_mode_request_is_repeated_until_the_heartbeat_shows_it_three_times_at_most():
    s = state_up("GUIDED", armed=True, now=0.0)
    assert is_set_mode(s.handle_key(" ", 0.0)[0], "HOLD")
    s.receive(heartbeat("GUIDED", True), 0.5)
    assert not [m for m in s.tick(0.5) if m.get_type() == "COMMAND_LONG"]
    s.receive(heartbeat("GUIDED", True), 1.0)
    again = [m for m in s.tick(1.0) if m.get_type() == "COMMAND_LONG"]
    assert len(again) == 1 and is_set_mode(again[0], "HOLD")
    s.receive(heartbeat("GUIDED", True), 2.0)
    assert len([m for m in s.tick(2.0) if m.get_type() == "COMMAND_LONG"]) == 1
    s.receive(heartbeat("GUIDED", True), 3.0)
    assert not [m for m in s.tick(3.0) if m.get_type() == "COMMAND_LONG"]
    assert "not taken after 3 requests" in s.status
    # shown by the heartbeat: no more requests
    s.handle_key(" ", 4.0)
    s.receive(heartbeat("HOLD", True), 4.2)
    assert s.mode_request is None
    assert not [m for m in s.tick(5.5) if m.get_type() == "COMMAND_LONG"]


def test_a_refused_mode_change_is_not_asked_again_and_the_refusal_is_shown():
    s = state_up("MANUAL", armed=True, now=0.0)
    s.handle_key("o", 0.0)
    s.receive(ack(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_RESULT_FAILED), 0.1)
    assert s.status == "mode GUIDED: failed"
    s.receive(heartbeat("MANUAL", True), 1.0)
    assert not [m for m in s.tick(1.5) if m.get_type() == "COMMAND_LONG"]


# -- o: toggle -------------------------------------------------------------------------------

@pytest.mark.parametrize("mode, wanted", [("GUIDED", "MANUAL"), ("MANUAL", "GUIDED"),
                                          ("HOLD", "GUIDED")])
def test_o_toggles_guided_and_manual(mode, wanted):
    s = state_up(mode, armed=True)
    out = s.handle_key("o", 10.1)
    assert len(out) == 1 and is_set_mode(out[0], wanted)
    assert ("helm online" if wanted == "GUIDED" else "helm offline") in s.status


def test_o_to_guided_while_disarmed_says_the_helm_waits_for_arming():
    s = state_up("MANUAL", armed=False)
    assert is_set_mode(s.handle_key("o", 10.1)[0], "GUIDED")
    assert "once armed" in s.status


def test_o_is_refused_without_an_autopilot_heartbeat():
    s = RemoteState()
    s.connection(True, 0.0)
    assert s.handle_key("o", 0.1) == []
    assert s.status == "o refused: no HEARTBEAT from the autopilot"
    assert RemoteState().handle_key("o", 0.1) == []


# -- A and D D -------------------------------------------------------------------------------

def test_A_arms_and_the_ack_is_shown():
    s = state_up("MANUAL", armed=False)
    out = s.handle_key("A", 10.1)
    assert types(out) == ["COMMAND_LONG"]
    assert out[0].command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM and out[0].param1 == 1
    assert (out[0].target_system, out[0].target_component) == AP
    s.receive(ack(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, mavlink.MAV_RESULT_FAILED), 10.2)
    assert s.status == "arm: failed"
    s.receive(text("Arm: Need Position Estimate", AP), 10.2)
    assert "AP    Arm: Need Position Estimate" in "\n".join(render(s))


def test_A_is_refused_when_armed():
    s = state_up("MANUAL", armed=True)
    assert s.handle_key("A", 10.1) == []
    assert s.status == "A refused: already armed"


def test_disarm_needs_D_twice_within_two_seconds():
    s = state_up("GUIDED", armed=True, now=0.0)
    assert s.handle_key("D", 1.0) == []
    assert "press D again" in s.status
    out = s.handle_key("D", 2.9)
    assert types(out) == ["COMMAND_LONG"]
    assert out[0].command == mavlink.MAV_CMD_COMPONENT_ARM_DISARM and out[0].param1 == 0
    s.receive(ack(mavlink.MAV_CMD_COMPONENT_ARM_DISARM), 3.0)
    assert s.status == "disarm: accepted"


def test_disarm_window_expires_and_another_key_cancels_it():
    s = state_up("GUIDED", armed=True, now=0.0)
    assert s.handle_key("D", 1.0) == []
    s.receive(heartbeat("GUIDED", True), 2.5)
    s.tick(3.1)
    assert "disarm cancelled" in s.status
    assert s.handle_key("D", 3.2) == []  # primed again, not sent
    s.handle_key("z", 3.3)
    assert s.handle_key("D", 3.4) == []  # the z in between cancelled it
    assert "press D again" in s.status


def test_D_is_refused_when_disarmed():
    s = state_up("MANUAL", armed=False)
    assert s.handle_key("D", 10.1) == [] and s.handle_key("D", 10.2) == []
    assert s.status == "D refused: already disarmed"


# -- stick nudges ----------------------------------------------------------------------------

def test_nudges_send_rc_override_on_channels_3_and_1_and_are_refreshed_every_half_second():
    s = state_up("MANUAL", armed=True, now=0.0)
    assert [channels(m) for m in s.handle_key("w", 0.0)] == [override(1500, 1540)]
    assert [channels(m) for m in s.handle_key("w", 0.1)] == [override(1500, 1580)]
    assert [channels(m) for m in s.handle_key("a", 0.2)] == [override(1460, 1580)]
    assert [channels(m) for m in s.handle_key("d", 0.3)] == [override(1500, 1580)]
    assert [channels(m) for m in s.handle_key("d", 0.3)] == [override(1540, 1580)]
    assert [channels(m) for m in s.handle_key("s", 0.3)] == [override(1540, 1540)]
    assert not [m for m in s.tick(0.7) if m.get_type() == "RC_CHANNELS_OVERRIDE"]
    refresh = [m for m in s.tick(0.8) if m.get_type() == "RC_CHANNELS_OVERRIDE"]
    assert [channels(m) for m in refresh] == [override(1540, 1540)]
    assert not [m for m in s.tick(1.2) if m.get_type() == "RC_CHANNELS_OVERRIDE"]
    assert len([m for m in s.tick(1.3) if m.get_type() == "RC_CHANNELS_OVERRIDE"]) == 1
    assert "thrust +10 %  rudder +10 %   (RC override ch3 1540, ch1 1540)" in "\n".join(
        render(s, 120))


def test_x_centres_and_releases_with_zero():
    s = state_up("MANUAL", armed=True, now=0.0)
    s.handle_key("w", 0.0)
    out = s.handle_key("x", 0.1)
    assert [channels(m) for m in out] == [RELEASE] * 3
    assert (s.thrust, s.rudder) == (0, 0)
    assert not [m for m in s.tick(1.0) if m.get_type() == "RC_CHANNELS_OVERRIDE"]
    assert s.handle_key("x", 1.1) == []
    assert s.status == "sticks already centred"


def test_nudging_back_to_centre_releases():
    s = state_up("MANUAL", armed=True, now=0.0)
    s.handle_key("d", 0.0)
    assert [channels(m) for m in s.handle_key("a", 0.1)] == [RELEASE] * 3


def test_nudges_stop_at_full_scale():
    s = state_up("MANUAL", armed=True, now=0.0)
    for _ in range(10):
        out = s.handle_key("w", 0.0)
    assert [channels(m) for m in out] == [override(1500, 1900)]
    assert s.handle_key("w", 0.0) == []
    assert s.status == "thrust already at the limit"


@pytest.mark.parametrize("mode", ["GUIDED", "HOLD"])
def test_nudges_are_refused_outside_manual(mode):
    s = state_up(mode, armed=True)
    for key in "wsad":
        assert s.handle_key(key, 10.1) == []
        assert "refused: sticks only in MANUAL" in s.status


def test_nudges_are_refused_when_disarmed_without_a_link_and_while_the_helm_drives():
    s = state_up("MANUAL", armed=False)
    assert s.handle_key("w", 10.1) == [] and s.status == "thrust refused: disarmed (A arms)"
    s = RemoteState()
    s.connection(True, 0.0)
    assert s.handle_key("a", 0.1) == []
    assert s.status == "rudder refused: no HEARTBEAT from the autopilot"
    # rc_override actuation: the helm drives in MANUAL; the operator must take over first
    s = state_up("MANUAL", armed=True)
    s.receive(status(HelmState(True, "ONLINE: autopilot armed in MANUAL")), 10.1)
    assert s.handle_key("w", 10.2) == []
    assert "the helm is driving" in s.status


def test_leaving_manual_releases_the_sticks():
    s = state_up("MANUAL", armed=True, now=0.0)
    s.handle_key("w", 0.0)
    out = s.receive(heartbeat("HOLD", True), 0.3)
    assert [channels(m) for m in out] == [RELEASE] * 3
    assert (s.thrust, s.rudder) == (0, 0)
    assert s.status == "stick nudges released: autopilot now in HOLD"
    assert not [m for m in s.tick(1.0) if m.get_type() == "RC_CHANNELS_OVERRIDE"]


def test_losing_the_link_drops_the_nudges():
    s = state_up("MANUAL", armed=True, now=0.0)
    s.handle_key("w", 0.0)
    out = s.tick(3.5)
    assert [channels(m) for m in out if m.get_type() == "RC_CHANNELS_OVERRIDE"] == [RELEASE] * 3
    assert (s.thrust, s.rudder) == (0, 0) and "nudges dropped" in s.status
    s.receive(heartbeat("MANUAL", True), 4.0)  # back: nothing resumes by itself
    assert not [m for m in s.tick(5.0) if m.get_type() == "RC_CHANNELS_OVERRIDE"]


def test_q_quits_and_releases():
    s = state_up("MANUAL", armed=True, now=0.0)
    s.handle_key("s", 0.0)
    assert [channels(m) for m in s.handle_key("q", 0.1)] == [RELEASE] * 3
    assert s.quit
    idle = state_up("MANUAL", armed=True)
    assert idle.handle_key("q", 10.1) == [] and idle.quit  # nothing overridden: nothing sent


def test_arrow_keys_nudge_and_unknown_keys_say_so():
    s = state_up("MANUAL", armed=True, now=0.0)
    assert [channels(m) for m in s.handle_key("up", 0.0)] == [override(1500, 1540)]
    assert [channels(m) for m in s.handle_key("right", 0.0)] == [override(1540, 1540)]
    assert s.handle_key("z", 0.1) == [] and "key z does nothing" in s.status
    assert s.handle_key("esc", 0.1) == [] and "does nothing" in s.status
    assert s.handle_key("\n", 0.1) == []


# -- R: RESTART_HELM -------------------------------------------------------------------------

def test_R_sends_restart_helm_to_the_companion_and_shows_its_ack():
    s = state_up("GUIDED", armed=True)
    assert s.handle_key("R", 10.1) == []
    assert s.status == "R refused: no companion heard at 1:191"
    s.receive(companion_heartbeat(), 10.2)
    out = s.handle_key("R", 10.3)
    assert types(out) == ["COMMAND_LONG"]
    cmd = out[0]
    assert cmd.command == mavlink.MAV_CMD_USER_1 and cmd.param1 == 1
    assert (cmd.target_system, cmd.target_component) == COMPANION
    s.receive(ack(mavlink.MAV_CMD_USER_1, src=COMPANION), 10.4)
    assert s.status == "RESTART_HELM: accepted"


def test_R_goes_to_the_configured_companion_and_a_silence_is_reported():
    s = state_up("GUIDED", armed=True, companion=(1, 42))
    s.receive(companion_heartbeat((1, 42)), 10.0)
    cmd = s.handle_key("R", 10.1)[0]
    assert (cmd.target_system, cmd.target_component) == (1, 42)
    s.tick(13.2)
    assert s.status == "RESTART_HELM: no answer in 3 s"
    s.receive(companion_heartbeat((1, 42)), 13.3)
    s.tick(19.0)  # companion silent again for 5.7 s
    assert s.handle_key("R", 19.0) == [] and "no companion heard at 1:42" in s.status


def test_another_ground_stations_ack_is_not_ours():
    s = state_up("MANUAL", armed=False)
    s.handle_key("A", 10.1)
    s.receive(ack(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, mavlink.MAV_RESULT_FAILED,
                  to=(254, 190)), 10.2)
    assert s.status == "arm requested"


# -- what the companion says ------------------------------------------------------------------

def test_helm_status_and_tasks_from_the_status_channel_and_its_texts_listed():
    """The companion says each thing twice: a STATUSTEXT line, listed for the operator, and a
    typed event, which alone updates the helm's state."""
    s = state_up("GUIDED", armed=True, now=0.0)

    def says(line, event, now):
        s.receive(text(line), now)
        s.receive(status(event), now)

    for line, event in [
            ("helm ONLINE: autopilot armed in GUIDED",
             HelmState(True, "ONLINE: autopilot armed in GUIDED")),
            ("task InitialDelay started", TaskStarted("InitialDelay")),
            ("task MissionClock started", TaskStarted("MissionClock")),
            ("task InitialDelay ended: timeout", TaskEnded("InitialDelay", "timeout")),
            ("task South started", TaskStarted("South"))]:
        says(line, event, 1.0)
    s.receive(text("South steers: heading 180 deg"), 1.0)
    assert s.helm == "ONLINE: autopilot armed in GUIDED"
    assert s.tasks == ["MissionClock", "South"]
    says("task South ended: complete", TaskEnded("South", "complete"), 2.0)
    says("task Home started", TaskStarted("Home"), 2.0)
    assert s.tasks == ["MissionClock", "Home"]
    says("MISSION ENDED (EndMission holds the vehicle)", MissionEnded("EndMission"), 3.0)
    says("helm offline: autopilot in MANUAL; select GUIDED t",
         HelmState(False, "offline: autopilot in MANUAL; select GUIDED to hand over"), 3.0)
    assert s.helm.startswith("offline: autopilot in MANUAL")
    assert s.mission_ended == "MISSION ENDED (EndMission holds the vehicle)"
    assert len(s.texts) == 8  # the last few only
    says("helm reloaded: demo.moos: 6 tasks", HelmReloaded("demo.moos: 6 tasks"), 4.0)
    assert s.tasks == [] and s.mission_ended is None


def test_named_values_from_the_companion_are_shown():
    s = state_up("GUIDED", armed=True, now=0.0)
    s.receive(companion_heartbeat(), 1.0)
    s.receive(status(HelmState(True, "ONLINE: autopilot armed in GUIDED")), 1.0)
    for name, value in [("NAV_X", 12.34), ("NAV_Y", -5.0), ("NAV_HDG", 181.0),
                        ("NAV_SPEED", 1.5), ("DES_RUDDER", -3.25), ("DES_THRUST", 80.0)]:
        s.receive(named(name, value), 1.0)
    s.receive(named("NAV_X", float("nan")), 1.0)  # never shown
    screen = "\n".join(render(s, 120))
    assert "nav        x 12.3 m   y -5.0 m   heading 181 deg   speed 1.50 m/s   (0 s ago)" \
        in screen
    assert "desired    rudder -3.2   thrust +80.0\n" in screen + "\n"
    s.receive(named("DES_RUDDER", -0.01), 1.5)
    assert "desired    rudder +0.0   thrust +80.0" in "\n".join(render(s, 120))  # not -0.0
    s.receive(status(HelmState(False, "offline: autopilot in HOLD; select GUIDED to")), 2.0)
    assert "(the helm's last, not driving)" in "\n".join(render(s, 120))


# -- the screen ------------------------------------------------------------------------------

def test_render_keeps_to_width_and_height():
    s = state_up("GUIDED", armed=True, now=0.0, url="tcp:127.0.0.1:5760")
    s.receive(companion_heartbeat(), 0.5)
    for i in range(8):
        s.receive(text(f"task T{i} started"), 0.5)
    lines = render(s, 40)
    assert all(len(line) <= 40 for line in lines)
    assert lines[0] == "mavhelm remote  tcp:127.0.0.1:5760  as G"
    assert lines[2] == "autopilot  LINK UP   mode GUIDED   ARMED"
    full = render(s, 100)
    short = render(s, 100, height=16)
    assert len(short) < len(full) and short[-2:] == full[-2:]
    assert "T7 started" in "\n".join(short)


def test_the_last_three_things_said_are_all_on_screen():
    """An ACK and the HEARTBEAT that follows it come within one redraw: neither is lost."""
    s = state_up("MANUAL", armed=True, now=0.0)
    s.handle_key("w", 0.0)
    s.handle_key("o", 0.1)
    s.receive(ack(mavlink.MAV_CMD_DO_SET_MODE), 0.15)
    s.receive(heartbeat("GUIDED", True), 0.2)
    notes = [line for line in render(s, 100) if line.startswith("> ")]
    assert notes == ["> GUIDED requested: helm online", "> mode GUIDED: accepted",
                     "> stick nudges released: autopilot now in GUIDED"]


def test_render_before_anything_is_heard():
    lines = render(RemoteState(url="udp:0.0.0.0:14550"), 100)
    assert lines[2] == "autopilot  NOT CONNECTED"
    assert "helm       (no companion heard at 1:191)" in lines
    assert "(no messages yet)" in lines


# -- keys from the terminal ------------------------------------------------------------------

def test_key_reader_keeps_escape_sequences_whole():
    r = KeyReader()
    assert r.feed(b"wA \x1b[A\x1b[B\x1b[C\x1b[D\x1bOA", 0.0) == [
        "w", "A", " ", "up", "down", "right", "left", "up"]
    assert r.feed(b"\x1b[1;5A", 0.0) == ["esc"]  # Ctrl-up: not an A
    assert r.feed(b"\x1bA", 0.0) == ["esc"]  # Alt-A: not an arm
    assert r.feed(b"\x1b[", 0.0) == []  # cut in two reads
    assert r.feed(b"A", 0.01) == ["up"]
    assert r.feed(b"\x1b", 1.0) == [] and r.flush(1.05) == [] and r.flush(1.2) == ["esc"]
    assert r.feed("é".encode()[:1], 2.0) == [] and r.feed("é".encode()[1:], 2.0) == ["é"]


def test_parse_ids():
    assert parse_ids("1:191") == (1, 191)
    for bad in ("1", "1:", "a:b", "1:256"):
        with pytest.raises(Exception, match="SYSTEM:COMPONENT"):
            parse_ids(bad)


# -- the real thing --------------------------------------------------------------------------

class PtyConsole:
    """``python -m mavhelm.companion.remote`` on a pseudo-terminal: the test reads the screen
    from the master and types keys into it."""

    def __init__(self, *args: str) -> None:
        self.master, self.slave = pty.openpty()
        fcntl.ioctl(self.slave, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 120, 0, 0))
        self.before = termios.tcgetattr(self.slave)
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "mavhelm.companion.remote", *args], stdin=self.slave,
            stdout=self.slave, stderr=self.slave, cwd=REPO, env=_child_env(),
            start_new_session=True, close_fds=True)
        self._data = bytearray()
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        while not self._stop.is_set():
            if select.select([self.master], [], [], 0.05)[0]:
                try:
                    chunk = os.read(self.master, 65536)
                except OSError:
                    return
                with self._lock:
                    self._data += chunk

    def text(self) -> str:
        with self._lock:
            return self._data.decode("utf-8", "replace")

    def mark(self) -> int:
        return len(self.text())

    def screen(self) -> str:
        """The last whole frame drawn, without the escape codes."""
        frames = self.text().split("\x1b[H")
        last = frames[-2] if len(frames) > 2 else frames[-1]
        return re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", last)

    def wait_for(self, pattern: str, since: int = 0, timeout: float = 10.0) -> str:
        rx = re.compile(pattern)

        def seen() -> str | None:
            if self.proc.poll() is not None:
                raise AssertionError(f"the console exited ({self.proc.returncode}):\n"
                                     f"{self.screen()}")
            found = rx.search(self.text()[since:])
            return found.group(0) if found else None

        return wait_for(seen, timeout, f"the console to show {pattern!r}",
                        lambda: "\n" + self.screen())

    def press(self, key: str) -> int:
        at = self.mark()
        os.write(self.master, key.encode())
        return at

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
            self.proc.wait(timeout=5)
        self._stop.set()
        self._thread.join(timeout=2)
        os.close(self.master)
        os.close(self.slave)


def test_console_on_a_pty_without_an_autopilot_restores_the_terminal_on_sigterm():
    # a closed port: the link keeps retrying, the console keeps drawing
    console = PtyConsole("--connect", "tcp:127.0.0.1:9")
    try:
        console.wait_for(r"autopilot  NOT CONNECTED")
        lflag = termios.tcgetattr(console.slave)[3]
        assert not lflag & termios.ICANON and not lflag & termios.ECHO  # cbreak while running
        console.wait_for(r"waiting for the autopilot at tcp:127.0.0.1:9")
        at = console.press("w")
        console.wait_for(r"thrust refused: no connection to the autopilot", at)
        console.proc.send_signal(signal.SIGTERM)
        assert console.proc.wait(timeout=10) == 0
        assert termios.tcgetattr(console.slave) == console.before
        assert "mavhelm remote: stopped (SIGTERM)" in console.text()
    finally:
        console.close()


def test_console_reads_keys_from_a_pipe_and_quits_at_end_of_input():
    proc = subprocess.run(
        [sys.executable, "-m", "mavhelm.companion.remote", "--connect", "tcp:127.0.0.1:9"],
        input=b"x", capture_output=True, cwd=REPO, env=_child_env(), timeout=20)
    assert proc.returncode == 0, proc.stderr
    out = proc.stdout.decode()
    assert "> quit (end of input)" in out
    assert out.rstrip().endswith("mavhelm remote: stopped (end of input)")


def test_bad_arguments_are_refused():
    run = subprocess.run([sys.executable, "-m", "mavhelm.companion.remote", "--connect",
                          "tcp:nohost"], capture_output=True, text=True, cwd=REPO,
                         env=_child_env(), timeout=20, stdin=subprocess.DEVNULL)
    assert run.returncode == 2 and "expected tcp:HOST:PORT" in run.stderr


@pytest.mark.slow
def test_console_on_a_pty_drives_the_simulator():
    """Against ``mavhelm sim``: the screen shows MANUAL; A arms, w nudges the throttle, o hands
    over (GUIDED) and releases the override, space is ALL STOP (HOLD), q quits with exit 0 and
    the terminal as it was. RC_OVERRIDE_TIME = -1 (overrides never time out), so the override
    seen to go is the console's own release."""
    t0 = time.monotonic()
    with SimProcess("--fast-start", "--speedup", "5", "--param", "RC_OVERRIDE_TIME=-1") as sim, \
            Companion(sim.ports[1], sysid=200, compid=1) as watcher:
        watcher.conn.mav.request_data_stream_send(1, 1, mavlink.MAV_DATA_STREAM_RC_CHANNELS,
                                                  10, 1)
        console = PtyConsole("--connect", f"tcp:127.0.0.1:{sim.ports[0]}")
        try:
            console.wait_for(r"mode MANUAL +disarmed", timeout=15)
            assert not termios.tcgetattr(console.slave)[3] & termios.ICANON
            for _ in range(3):  # the autopilot refuses to arm for its first 1.5 s (sim time)
                at = console.press("A")
                try:
                    console.wait_for(r"mode MANUAL +ARMED\b", at, timeout=4)
                    break
                except AssertionError:
                    continue
            else:
                raise AssertionError(f"never armed:\n{console.screen()}")
            at = console.press("w")
            console.press("w")
            console.wait_for(r"thrust \+20 %", at)
            watcher.wait_for("RC_CHANNELS", lambda m: m.chan3_raw == 1580, 10,
                             "the throttle channel overridden to 1580")
            at = console.press("o")
            console.wait_for(r"mode GUIDED +ARMED\b", at)
            console.wait_for(r"mode GUIDED: accepted", at)
            watcher.wait_for("RC_CHANNELS", lambda m: m.chan3_raw == 1500, 10,
                             "the override released on leaving MANUAL")
            at = console.press(" ")
            console.wait_for(r"mode HOLD +ARMED\b", at)
            console.wait_for(r"AP +Throttle armed", 0)  # the autopilot's STATUSTEXT
            at = console.press("w")
            console.wait_for(r"thrust refused: sticks only in MANUAL", at)
            console.press("q")
            assert console.proc.wait(timeout=10) == 0
            assert termios.tcgetattr(console.slave) == console.before
            assert "mavhelm remote: stopped (q)" in console.text()
        finally:
            console.close()
    assert time.monotonic() - t0 < 60

