"""The companion's MAVLink traffic as a .tlog that pymavlink's ``mavutil`` and
``mavlogdump.py`` read: both directions, time-stamped, and a failing disk never stops it."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from pymavlink import mavutil

from mavhelm.companion.companion import Companion
from mavhelm.companion.tlog_writer import TlogWriter
from mavhelm.core.clock import SimClock
from mavhelm.demo.harness import SimulatedRun
from tests.support.mission import mission_text
from tests.support.web_rig import TASKS

MAVLOGDUMP = Path(sys.executable).parent / "mavlogdump.py"


def test_a_run_tlog_opens_in_mavutil_and_mavlogdump(tmp_path):
    mission = tmp_path / "m.moos"
    mission.write_text(mission_text(TASKS, overall_timeout=600))
    tlog = tmp_path / "m.tlog"
    with SimulatedRun.start(mission) as run:
        writer = TlogWriter(tlog, clock=lambda: 1.7e9 + run.clock.now())
        run.companion.bridge.link.recorder = writer.record
        run.hand_over()
        run.run_for(10.0)
        writer.close()
    log = mavutil.mavlink_connection(str(tlog), dialect="ardupilotmega")
    seen: dict[tuple[int, int, str], int] = {}
    stamps = []
    while (msg := log.recv_match()) is not None:
        key = (msg.get_srcSystem(), msg.get_srcComponent(), msg.get_type())
        seen[key] = seen.get(key, 0) + 1
        stamps.append(msg._timestamp)
    assert seen.get((1, 1, "HEARTBEAT")) and seen.get((1, 1, "GLOBAL_POSITION_INT"))
    assert seen.get((1, 191, "HEARTBEAT")) and seen.get((1, 191, "SET_ATTITUDE_TARGET"))
    assert seen.get((1, 191, "NAMED_VALUE_FLOAT")) and seen.get((1, 191, "TUNNEL"))
    assert stamps == sorted(stamps) and 1.7e9 < stamps[0] < stamps[-1] < 1.7e9 + 200
    dump = subprocess.run([sys.executable, str(MAVLOGDUMP), "--types", "HEARTBEAT", str(tlog)],
                          capture_output=True, text=True, timeout=60)
    assert dump.returncode == 0, dump.stderr
    assert dump.stdout.count("HEARTBEAT") >= 10


def test_a_failing_disk_ends_the_recording_not_the_companion(tmp_path):
    said: list[str] = []
    writer = TlogWriter(tmp_path / "x.tlog", on_error=said.append)
    writer._file.close()  # as if the disk had gone
    writer.record(b"\xfd" + bytes(11))
    writer.record(b"\xfd" + bytes(11))
    assert writer.failed and len(said) == 1 and "stopped" in said[0]


def test_the_companion_records_its_link_where_asked(tmp_path):
    mission = tmp_path / "m.moos"
    mission.write_text(mission_text(TASKS, imavlink={"Connect": "tcp:127.0.0.1:9"}))
    companion = Companion.build(mission, SimClock(0.0), tlog_path=tmp_path / "m.tlog")
    try:
        assert companion.bridge.link.recorder == companion.tlog.record
        assert (tmp_path / "m.tlog").exists()
    finally:
        companion.close()


def test_the_companions_tlog_is_stamped_on_its_own_clock(tmp_path):
    """Beside a SITL faster than real time the companion runs on the autopilot's clock; its
    .tlog must carry that clock's stamps, as its .alog does, or a replay runs slow by the
    speed-up (a real SITL noise run at x10 replayed from wall stamps: NAV 43.9 m RMS)."""
    mission = tmp_path / "m.moos"
    mission.write_text(mission_text(TASKS, imavlink={"Connect": "tcp:127.0.0.1:9"}))
    clock = SimClock(1.7e9)
    companion = Companion.build(mission, clock, tlog_path=tmp_path / "m.tlog")
    try:
        companion.tlog.record(b"\xfd" + bytes(11))
        clock.advance(100.0)
        companion.tlog.record(b"\xfd" + bytes(11))
    finally:
        companion.close()
    data = (tmp_path / "m.tlog").read_bytes()
    stamps = [int.from_bytes(data[k:k + 8], "big") / 1e6 for k in (0, 20)]
    assert stamps == [1.7e9, 1.7e9 + 100.0]
