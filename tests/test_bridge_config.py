"""The iMAVLink block: what a skipper can set, and each mistake refused with file:line."""

from __future__ import annotations

import pytest

from mavhelm.companion.mavlink_bridge import BridgeConfig
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
    ("Actuation = rc_override", 5, "not supported yet"),
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
