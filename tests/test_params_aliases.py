"""The schema's means for MOOS missions: aliases (with their own kind), two spellings that
must agree, settings refused with a reason, and boilerplate checked but not returned."""

from __future__ import annotations

import pytest

from mavhelm.core.mission import MissionError, parse_mission
from mavhelm.core.params import Alias, Boolean, Mapped, Number, Param, Refused, Schema

SCHEMA = Schema("Test", (
    Param("Sigma", Number(0.0, 10.0), 3.0, "m", "a sigma",
          aliases=(Alias("SigmaX"), Alias("SigmaY"))),
    Param("Mobile", Boolean(), True, doc="moves",
          aliases=(Alias("VehicleType", Mapped((("MOBILE", True), ("STATIC", False)))),)),
    Param("TopDown", Refused("no such engine"), None),
), moos=(Param("CommsTick", Number(0.0, 100.0, lo_open=True), None, unused="no MOOSDB"),))


def _read(*lines: str) -> dict:
    text = "ProcessConfig = Test\n{\n" + "\n".join(lines) + "\n}\n"
    return SCHEMA.read(parse_mission(text, "t.moos").processes["Test"])


def test_an_alias_sets_its_setting_and_may_parse_its_own_way():
    assert _read("SigmaX = 2")["sigma"] == 2.0
    assert _read("VehicleType = static")["mobile"] is False
    with pytest.raises(MissionError, match="VehicleType expects one of MOBILE, STATIC"):
        _read("VehicleType = true")


def test_two_spellings_that_agree_are_one_setting_and_two_that_differ_are_refused():
    assert _read("SigmaX = 2", "SigmaY = 2")["sigma"] == 2.0
    with pytest.raises(MissionError) as err:
        _read("SigmaX = 2", "Sigma = 4")
    assert str(err.value) == ("t.moos:4: Sigma disagrees with SigmaX at line 3: both set Sigma, "
                              "which mavhelm holds once; give them one value")
    with pytest.raises(MissionError, match="SigmaX is already set at line 3"):
        _read("SigmaX = 2", "SigmaX = 2")


def test_a_refused_setting_says_why_and_is_not_offered():
    with pytest.raises(MissionError) as err:
        _read("TopDown = true")
    assert str(err.value) == "t.moos:3: TopDown is not supported by mavhelm: no such engine"
    with pytest.raises(MissionError) as err:
        _read("TopDwn = true")
    assert "TopDown" not in err.value.reason
    assert SCHEMA.known() == "Sigma, Mobile"


def test_boilerplate_is_checked_and_noted_but_not_returned():
    values = _read("CommsTick = 5")
    assert "comms_tick" not in values
    with pytest.raises(MissionError, match="CommsTick must be a number in"):
        _read("CommsTick = 0")
    with pytest.raises(MissionError, match="CommsTick is already set at line 3"):
        _read("CommsTick = 5", "CommsTick = 5")
    block = parse_mission("ProcessConfig = Test\n{\nCommsTick = 5\nSigmaX = 1\n}\n",
                          "t.moos").processes["Test"]
    assert [(e.key, p.name) for e, p in SCHEMA.unused_entries(block)] == [("CommsTick",
                                                                           "CommsTick")]


def test_the_reference_shows_aliases_refusals_and_boilerplate():
    text = SCHEMA.reference("Test")
    assert "| `Sigma` | m | 3 | number in [0, 10] | a sigma (also written `SigmaX`, `SigmaY`) |" \
        in text
    assert "| `TopDown` | — | — | refused: no such engine |" in text
    assert "Also accepts the MOOS boilerplate `CommsTick` (see MOOS missions)." in text


def test_the_original_filter_switches_are_honoured_or_refused_with_why():
    """pNav's UseLSQ is LSQ; UseEKF = TRUE is what mavhelm does, FALSE is refused naming why."""
    from mavhelm.core.mission import MissionError, parse_mission
    from mavhelm.nav.navigator import NAV_SCHEMA

    def read(lines: str) -> dict:
        mission = parse_mission("ProcessConfig = pNav\n{\n" + lines + "}\n", "nav.moos")
        return NAV_SCHEMA.read(mission.process("pNav"))

    assert read("UseLSQ = FALSE\n")["lsq"] is False
    assert read("UseEKF = TRUE\n")["use_ekf"] is True
    try:
        read("UseEKF = FALSE\n")
    except MissionError as exc:
        assert str(exc).startswith("nav.moos:3:") and "SENSOR_" in str(exc)
    else:
        raise AssertionError("UseEKF = FALSE accepted")
