"""The autopilot's shape: ArduPilot Rover's mode table, its yes/no questions, the GUIDED
sub-modes and the MAVLink dispatch tables, checked without sockets."""

from __future__ import annotations

import re

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.sitl import autopilot as ap
from mavhelm.sitl.gcs_mavlink import GcsMavlink
from mavhelm.sitl.modes import MODE_CLASSES, GuidedSubMode, ModeGuided

M = mavlink


def test_the_mode_table_is_keyed_by_rovers_numbers_and_names_its_sources():
    assert {n: cls.name for n, cls in MODE_CLASSES.items()} == {
        0: "MANUAL", 1: "ACRO", 3: "STEERING", 4: "HOLD", 5: "LOITER", 6: "FOLLOW",
        7: "SIMPLE", 10: "AUTO", 11: "RTL", 12: "SMART_RTL", 15: "GUIDED", 16: "INITIALISING"}
    assert ap.MODES == {n: cls.name for n, cls in MODE_CLASSES.items()}
    for cls in MODE_CLASSES.values():
        assert re.search(r"Rover/mode(_\w+\.cpp|\.h)", cls.__doc__ or ""), cls.__name__


def test_each_mode_answers_rovers_questions():
    """HEARTBEAT flags, and what a mode needs before it is entered armed."""
    a = ap.Autopilot()
    manual_input = {n for n, m in a.modes.items() if m.has_manual_input()}
    autopilot = {n for n, m in a.modes.items() if m.is_autopilot_mode()}
    position = {n for n, m in a.modes.items() if m.requires_position()}
    velocity = {n for n, m in a.modes.items() if m.requires_velocity()}
    assert manual_input == {ap.MANUAL, ap.ACRO, ap.STEERING, ap.SIMPLE, ap.INITIALISING}
    assert autopilot == {ap.AUTO, ap.GUIDED, ap.RTL, ap.SMART_RTL, ap.LOITER, ap.FOLLOW}
    assert position == {ap.LOITER, ap.FOLLOW, ap.AUTO, ap.RTL, ap.SMART_RTL, ap.GUIDED,
                        ap.SIMPLE}
    assert velocity == {ap.ACRO, ap.STEERING}


def _ready(**kw) -> ap.Autopilot:
    a = ap.Autopilot(timeline=ap.Timeline.fast(), **kw)
    a.gps_has_fix = True
    for i in range(200):  # 4 s of the fast timeline
        a.update(i * 0.02, 0.02)
    a.out.texts.clear()
    return a


def test_enter_refusals_are_the_modes_own():
    a = _ready()
    assert a.mode == ap.MANUAL and a.home is not None
    assert not a.set_mode(ap.AUTO, 4.0)
    assert a.out.texts == [(ap.SEVERITY_NOTICE, "No Mission. Can't set AUTO."),
                           (ap.SEVERITY_WARNING, "Flight mode change failed")]
    a.out.texts.clear()
    assert not a.set_mode(42, 4.0) and a.out.texts == [(ap.SEVERITY_WARNING, "No such mode 42")]
    assert a.set_mode(ap.RTL, 4.0) and a.wp == a.home and a.current is a.modes[ap.RTL]
    a.home = None
    assert a.set_mode(ap.HOLD, 4.0)
    assert not a.set_mode(ap.RTL, 4.0) and a.mode == ap.HOLD


def test_an_unchecked_initial_mode_is_entered_as_it_is():
    """INITIAL_MODE is prepared and entered without its checks (AUTO then just stops)."""
    a = _ready(params={"INITIAL_MODE": ap.AUTO})
    assert a.mode == ap.AUTO and a.mode_name == "AUTO"


def test_guided_sub_modes_are_an_enum():
    a = _ready(boat=False)
    assert a.arm(True, 4.0) == ap.RESULT_ACCEPTED
    a.est.position_ok = True
    assert a.set_mode(ap.GUIDED, 4.0)
    g = a.guided
    assert isinstance(g, ModeGuided) and g.sub is GuidedSubMode.STOP  # a rover stops
    a.set_attitude_target(0x03, (1, 0, 0, 0), 0.2, 0.5, 4.0)
    assert g.sub is GuidedSubMode.TURN_RATE_AND_SPEED
    a.set_attitude_target(0x07, (1, 0, 0, 0), 0.0, 0.5, 4.1)
    assert g.sub is GuidedSubMode.HEADING_AND_SPEED and g.desired_speed == 2.5
    assert a.guided_reposition(5.0, 5.0, 1.5, False, 4.2) == ap.RESULT_ACCEPTED
    assert g.sub is GuidedSubMode.WP and g.speed == 1.5 and a.wp == (5.0, 5.0)
    assert a.set_mode(ap.HOLD, 4.3) and g.speed is None  # the speed ends with the mode


@pytest.mark.parametrize("table, names", [
    (GcsMavlink.MESSAGE_HANDLERS, [
        "COMMAND_LONG", "COMMAND_INT", "SET_MODE", "SET_ATTITUDE_TARGET",
        "SET_POSITION_TARGET_LOCAL_NED", "SET_POSITION_TARGET_GLOBAL_INT",
        "RC_CHANNELS_OVERRIDE", "PARAM_REQUEST_LIST", "PARAM_REQUEST_READ", "PARAM_SET",
        "REQUEST_DATA_STREAM", "MISSION_REQUEST_LIST", "MANUAL_CONTROL", "TIMESYNC",
        "FILE_TRANSFER_PROTOCOL"]),
    (GcsMavlink.COMMAND_HANDLERS, [
        M.MAV_CMD_DO_SET_MODE, M.MAV_CMD_COMPONENT_ARM_DISARM, M.MAV_CMD_DO_SET_SERVO,
        M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAV_CMD_GET_MESSAGE_INTERVAL,
        M.MAV_CMD_REQUEST_MESSAGE, M.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
        M.MAV_CMD_GET_HOME_POSITION, M.MAV_CMD_NAV_RETURN_TO_LAUNCH, M.MAV_CMD_MISSION_START,
        M.MAV_CMD_DO_CHANGE_SPEED, M.MAV_CMD_DO_REPOSITION]),
])
def test_the_dispatch_tables_cover_what_the_docs_list(table, names):
    assert sorted(map(str, table)) == sorted(map(str, names))
    assert all(callable(h) for h in table.values())


def test_every_streamed_message_has_a_builder():
    from mavhelm.sitl.gcs_mavlink import KNOWN, ORDER
    from mavhelm.sitl.telemetry import BUILDERS

    assert set(ORDER) <= set(BUILDERS) and KNOWN == set(BUILDERS)
    assert M.MAVLINK_MSG_ID_EXTENDED_SYS_STATE in BUILDERS  # on request only
