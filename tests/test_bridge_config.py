"""The iMAVLink block: what a skipper can set, and each mistake refused with file:line."""

from __future__ import annotations

import pytest

from mavhelm.companion.bridge import BridgeConfig
from mavhelm.core.mission import MissionError, parse_mission

BASE = """LatOrigin = 56.0
LongOrigin = -5.0
ProcessConfig = iMAVLink
{{
{body}
}}
"""


def config(body: str) -> BridgeConfig:
    mission = parse_mission(BASE.format(body=body), "boat.moos")
    return BridgeConfig.from_block(mission.process("iMAVLink"))


def test_settings_are_read():
    cfg = config("Connect = /dev/ttyAMA0\nBaud = 921600\nOnlineModes = guided, loiter\n"
                 "MaxTurnRate = 30\nStream = ATTITUDE@20\nStream = VFR_HUD@2\nLinkTimeOut = 2")
    assert cfg.connect == "/dev/ttyAMA0" and cfg.baud == 921600
    assert cfg.online_modes == ("GUIDED", "LOITER")
    assert cfg.max_turn_rate == 30.0 and cfg.link_timeout == 2.0
    assert cfg.streams["ATTITUDE"] == 20.0 and cfg.streams["VFR_HUD"] == 2.0
    assert cfg.streams["GPS_RAW_INT"] == 5.0, "defaults kept for streams not mentioned"


@pytest.mark.parametrize("body, line, words", [
    ("Conect = tcp:127.0.0.1:5760", 5,
     "unknown setting 'Conect' for iMAVLink (did you mean Connect? known: Connect,"),
    ("OnlineModes = GUIDED, AUTOPILOT", 5, "OnlineModes expects one of MANUAL"),
    ("Actuation = rc_override", 3, "Actuation = rc_override needs EngageChannel"),
    ("Actuation = rc_override\nEngageChannel = 17", 6,
     "EngageChannel must be a whole number in [1, 16], got 17"),
    ("Servo = WINCH@9", 5, "Servo expects NAME@output:min-max"),
    ("Servo = WINCH@17:1100-1900", 5, "Servo WINCH: output must be 1-16, got 17"),
    ("Servo = WINCH@9:1900-1100", 5, "PWM range must be min < max"),
    ("Servo = WINCH@9:1100-1900\nServo = LIGHTS@9:1000-2000", 6,
     "Servo LIGHTS@9 clashes with WINCH@9: one name per output"),
    ("Stream = ATTITUDE", 5, "MESSAGE_NAME@rate_hz"),
    ("Stream = NOT_A_MESSAGE@5", 5, "MESSAGE_NAME@rate_hz"),
    ("Stream = ATTITUDE@fast", 5, "Stream ATTITUDE rate expects a number"),
    ("MaxTurnRate = lots", 5, "MaxTurnRate expects a number"),
])
def test_mistakes_are_refused_where_they_are(body, line, words):
    with pytest.raises(MissionError) as err:
        config(body)
    assert str(err.value).startswith(f"boat.moos:{line}: ")
    assert words in str(err.value)


def test_rc_override_defaults_to_manual_and_asks_for_rc_channels():
    cfg = config("Actuation = rc_override\nEngageChannel = 7\nServo = winch@9:1100-1900")
    assert cfg.actuation == "rc_override" and cfg.engage_channel == 7 and cfg.engage_pwm == 1800
    assert cfg.online_modes == ("MANUAL",), "rc_override is for vehicles run in MANUAL"
    assert cfg.streams["RC_CHANNELS"] == 5.0
    assert [(s.name, s.channel, s.pwm(-100), s.pwm(0), s.pwm(100)) for s in cfg.servos] == [
        ("WINCH", 9, 1100, 1500, 1900)]
