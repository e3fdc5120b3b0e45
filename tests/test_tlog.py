"""Reading a MAVLink telemetry log (.tlog) back as the bus variables the bridge posts.

A synthetic log, written record by record (8-byte big-endian µs + an encoded frame), pins the
format, the mission's iMAVLink block deciding whose frames count, damage skipped and counted,
and every time stamp. A log recorded from the real ArduPilot Rover SITL (a ground station on
SERIAL0 writing every frame it hears, as MAVProxy does) checks the same on ArduPilot's own
bytes; it needs MAVHELM_ARDUPILOT and skips without.
"""

from __future__ import annotations

import math
import struct
import time
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.tlog import bus_messages_from_tlog, read_tlog
from mavhelm.core.geodesy import Origin
from mavhelm.core.mission import parse_mission

ORIGIN = Origin(56.4120, -5.4760)
MISSION = """
LatOrigin = 56.4120
LongOrigin = -5.4760
{imavlink}
"""
T0 = 1_767_225_600.0   # 2026-01-01, a recorder's Unix clock
GUIDED, ARMED = 15, 0xC1


def mission(imavlink: str = ""):
    return parse_mission(MISSION.format(imavlink=imavlink), "m.moos")


class Recorder:
    """Writes a .tlog the way MAVProxy does: each frame behind its µs time stamp."""

    def __init__(self) -> None:
        self.data = bytearray()
        self.stamps: list[float] = []

    def record(self, t: float, frame: bytes) -> None:
        self.data += struct.pack(">Q", round(t * 1e6)) + frame
        self.stamps.append(round(t * 1e6) / 1e6)

    def save(self, path: Path) -> Path:
        path.write_bytes(bytes(self.data))
        return path


def test_a_tlog_replays_into_the_bridges_variables_at_the_log_times(tmp_path) -> None:
    autopilot = mavlink.MAVLink(None, srcSystem=1, srcComponent=1)
    gcs = mavlink.MAVLink(None, srcSystem=255, srcComponent=190)
    lat, lon = ORIGIN.to_global(30.0, -40.0)
    log = Recorder()
    log.data += b"\x00\x01garbage before the first record"
    log.record(T0 + 0.0, mavlink.MAVLink_heartbeat_message(
        11, 3, ARMED, GUIDED, 4, 3).pack(autopilot))
    log.record(T0 + 0.1, mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 4, 3).pack(gcs))
    log.record(T0 + 0.2, mavlink.MAVLink_gps_raw_int_message(  # MAVLink 1, as old radios
        0, 3, round(lat * 1e7), round(lon * 1e7), 0, 100, 100, 150, 9000, 10).pack(
        autopilot, force_mavlink1=True))
    log.record(T0 + 0.3, mavlink.MAVLink_distance_sensor_message(
        300, 20, 700, 153, 0, 0, mavlink.MAV_SENSOR_ROTATION_PITCH_270, 0).pack(autopilot))
    log.record(T0 + 0.4, mavlink.MAVLink_wheel_distance_message(
        1_000_000, 2, [0.0] * 16).pack(autopilot))
    log.data += b"\xfd\x09\x00garbled write \xfe\x03"  # damage in the middle
    log.record(T0 + 0.5, mavlink.MAVLink_wheel_distance_message(
        1_500_000, 2, [1.0, 0.5] + [0.0] * 14).pack(autopilot))
    log.record(T0 + 0.6, mavlink.MAVLink_attitude_message(  # refused by the bridge
        600, 0.0, 0.0, math.nan, 0.0, 0.0, 0.0).pack(autopilot))
    unknown = bytes([0xFD, 1, 0, 0, 7, 1, 1, 0x60, 0xEA, 0x00, 42, 0x12, 0x34])  # id 60000
    log.record(T0 + 0.7, unknown)
    log.record(T0 + 0.8, mavlink.MAVLink_simstate_message(
        0.0, 0.0, math.pi / 2, 0, 0, -9.8, 0, 0, 0, round(lat * 1e7), round(lon * 1e7)).pack(
        autopilot))
    log.record(T0 + 0.9, mavlink.MAVLink_heartbeat_message(  # the GCS-system's own fake
        11, 3, 0, 4, 4, 3).pack(mavlink.MAVLink(None, srcSystem=2, srcComponent=1)))
    truncated = mavlink.MAVLink_attitude_message(900, 0, 0, 0, 0, 0, 0).pack(autopilot)
    log.data += struct.pack(">Q", round((T0 + 1.0) * 1e6)) + truncated[:10]
    path = log.save(tmp_path / "flight.tlog")

    replay = read_tlog(path, mission())
    near = {"abs": 0.01}
    assert [(m.name, m.value, round(m.time - T0, 3)) for m in replay.messages] == [
        ("AP_MODE", "GUIDED", 0.0), ("AP_ARMED", 1.0, 0.0),
        ("MAVLINK_BAD_PACKETS", 1.0, 0.0),  # the leading garbage, said with the first frame
        ("GPS_FIX", 3.0, 0.2), ("GPS_X", pytest.approx(30.0, **near), 0.2),
        ("GPS_Y", pytest.approx(-40.0, **near), 0.2), ("GPS_SPEED", 1.5, 0.2),
        ("GPS_HEADING", 90.0, 0.2),
        ("AP_ALTITUDE", 1.53, 0.3),
        ("WHEEL_VX_BODY", 1.5, 0.5),        # the first WHEEL_DISTANCE only started the clock
        ("MAVLINK_BAD_PACKETS", 2.0, 0.5),  # the garbled write
        ("MAVLINK_ERROR", "ATTITUDE: non-finite attitude", 0.6),
        ("MAVLINK_BAD_PACKETS", 3.0, 0.6),
        ("TRUTH_X", pytest.approx(30.0, **near), 0.8),
        ("TRUTH_Y", pytest.approx(-40.0, **near), 0.8),
        ("TRUTH_HEADING", pytest.approx(90.0, abs=1e-4), 0.8),
        ("MAVLINK_BAD_PACKETS", 4.0, 0.9),  # the truncated last record
    ]
    assert all(m.source == "iMAVLink" for m in replay.messages)
    assert (replay.frames, replay.bad_frames, replay.unknown_frames, replay.refused) == \
        (9, 3, 1, 1)
    assert bus_messages_from_tlog(path, mission()) == replay.messages


def test_the_missions_imavlink_block_says_which_system_is_the_autopilot(tmp_path) -> None:
    log = Recorder()
    for t, system in ((T0, 1), (T0 + 1.0, 2)):
        frame = mavlink.MAVLink_distance_sensor_message(
            0, 20, 700, 100 * system, 0, 0, mavlink.MAV_SENSOR_ROTATION_NONE, 0)
        log.record(t, frame.pack(mavlink.MAVLink(None, srcSystem=system, srcComponent=1)))
    path = log.save(tmp_path / "two.tlog")
    assert [(m.name, m.value, m.time) for m in bus_messages_from_tlog(path, mission())] == \
        [("AP_DISTANCE_0", 1.0, T0)]
    other = mission("ProcessConfig = iMAVLink\n{\n  TargetSystem = 2\n}\n")
    assert [(m.name, m.value, m.time) for m in bus_messages_from_tlog(path, other)] == \
        [("AP_DISTANCE_0", 2.0, T0 + 1.0)]


def test_an_empty_or_all_garbage_file_gives_nothing_but_the_count(tmp_path) -> None:
    empty = tmp_path / "empty.tlog"
    empty.write_bytes(b"")
    assert read_tlog(empty, mission()).messages == []
    junk = tmp_path / "junk.tlog"
    junk.write_bytes(bytes(range(256)) * 4)
    replay = read_tlog(junk, mission())
    assert (replay.frames, replay.bad_frames) == (0, 1)
    assert [(m.name, m.value) for m in replay.messages] == [("MAVLINK_BAD_PACKETS", 1.0)]


@pytest.mark.slow
def test_a_tlog_recorded_from_the_real_sitl(real_sitl, tmp_path) -> None:
    from tests.support.ardupilot import GCS_COMPONENT_ID, GCS_SYSTEM_ID, RealOperator

    sitl = real_sitl(model="rover", speedup=10,
                     params={"RNGFND1_TYPE": 100, "RNGFND1_ORIENT": 25})
    log = Recorder()
    down: list[float] = []   # the record stamps of the downward DISTANCE_SENSORs
    with RealOperator(sitl.ports.serial0, heartbeat_s=0.1) as op:
        op.conn.mav = mavlink.MAVLink(op.conn, srcSystem=GCS_SYSTEM_ID,
                                      srcComponent=GCS_COMPONENT_ID)
        op.conn.mav.robust_parsing = True
        op.request_streams(4)
        op.command(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_DISTANCE_SENSOR,
                   250_000)
        start = time.monotonic()
        positioned = 0  # GLOBAL_POSITION_INTs since the EKF said it has a position (~41 s)
        while positioned < 10 or len(down) < 20:
            assert time.monotonic() - start < 30.0, (dict(op.counts), op.texts()[-5:])
            for msg in op.poll(0.02):
                kind = msg.get_type()
                if kind == "BAD_DATA":  # the SITL's banner on SERIAL0: no recorder keeps it
                    continue
                log.record(time.time(), msg.get_msgbuf())
                if kind == "DISTANCE_SENSOR" and msg.orientation == 25:
                    down.append(log.stamps[-1])
                elif kind == "EKF_STATUS_REPORT" and msg.flags & mavlink.EKF_POS_HORIZ_ABS:
                    positioned = max(positioned, 1)
                elif kind == "GLOBAL_POSITION_INT" and positioned:
                    positioned += 1
    path = log.save(tmp_path / "sitl.tlog")

    replay = read_tlog(path, mission())
    print(f"\n[tlog] {len(log.stamps)} records, {path.stat().st_size} bytes: {replay.frames} "
          f"frames, {replay.unknown_frames} unknown, {replay.bad_frames} bad")
    assert replay.bad_frames == 0 and replay.refused == 0
    assert replay.frames + replay.unknown_frames == len(log.stamps)
    times = [m.time for m in replay.messages]
    assert times == sorted(times) and set(times) <= set(log.stamps)

    def posted(name: str) -> list[tuple[float, float]]:
        return [(m.time, float(m.value)) for m in replay.messages if m.name == name]

    assert [t for t, _ in posted("AP_ALTITUDE")] == down
    assert {v for _, v in posted("AP_ALTITUDE")} == {1.0}
    for name in ("GPS_X", "GPS_Y", "AP_X", "AP_Y", "TRUTH_X", "TRUTH_Y"):
        values = [v for _, v in posted(name)]
        assert values and all(abs(v) < 5.0 for v in values), name  # parked at the origin
    for name in ("INS_HEADING", "TRUTH_HEADING"):
        values = [v for _, v in posted(name)]
        assert values and all(abs(v - 90.0) < 5.0 for v in values), name  # --home heading 90
    modes = [m.value for m in replay.messages if m.name == "AP_MODE"]
    assert set(modes) <= {"INITIALISING", "MANUAL"} and modes[-1] == "MANUAL"
