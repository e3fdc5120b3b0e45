"""Serial instruments end to end: ``mavhelm sim --sensors`` serves a NMEA GPS and heading on
pseudo-terminals, ``mavhelm run`` reads them through iSerial blocks, and pNav routes them into
NAV_* ahead of the autopilot's own (spec 2.1), all as separate processes on the wall clock."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest

from mavhelm.companion.alog import read_alog
from tests.support.interop_helpers import SimProcess
from tests.support.mission import block, mission_text

pytestmark = pytest.mark.slow

def serial_mission(port: int, gps: str, heading: str) -> str:
    """No tasks: pNav on the serial GPS and compass, the autopilot's as fall-backs."""
    serial = block("iSerial_GPS", {"Name": "SGPS", "Port": gps, "Sentences": "GGA,RMC"})
    compass = block("iSerial_Compass", {"Name": "HDG", "Port": heading, "Sentences": "HDT"})
    return mission_text(origin=(50.1, -4.2), imavlink={"Connect": f"tcp:127.0.0.1:{port}"},
                        blocks=serial + "\n" + compass, overall_timeout=600,
                        nav={"X": "SGPS @ 3, GPS @ 2", "Y": "SGPS @ 3, GPS @ 2",
                             "Heading": "HDG @ 1, INS @ 1"})


def test_serial_gps_and_heading_feed_nav_through_mavhelm_run(tmp_path):
    with SimProcess("--fast-start", "--sensors", "--home", "50.1,-4.2,90") as sim:
        paths = sim.sensor_paths("nmea_gps", "heading")
        mission = tmp_path / "serial.moos"
        mission.write_text(serial_mission(sim.ports[1], paths["nmea_gps"], paths["heading"]))
        logs = tmp_path / "logs"
        proc = subprocess.Popen([sys.executable, "-m", "mavhelm.cli", "run", str(mission),
                                 "--log-dir", str(logs)], stdout=subprocess.PIPE,
                                stderr=subprocess.STDOUT, text=True)
        try:
            time.sleep(6.0)  # the GPS speaks at 1 Hz, the compass at 10 Hz
        finally:
            proc.send_signal(signal.SIGTERM)
            out, _ = proc.communicate(timeout=30)
        assert proc.returncode == 0, out
    log = read_alog(next(logs.glob("*.alog")))
    sources = {m.name: m.string for m in log if m.name.endswith("_SOURCE")}
    assert sources["NAV_X_SOURCE"] == "SGPS" and sources["NAV_HEADING_SOURCE"] == "HDG"
    x = [m.double for m in log if m.name == "NAV_X"]
    heading = [m.double for m in log if m.name == "NAV_HEADING"]
    assert len(x) >= 3 and all(abs(v) < 10.0 for v in x), "at home, within GPS noise"
    assert len(heading) >= 20 and all(abs(h - 90.0) < 5.0 for h in heading)
    assert any(m.name == "SGPS_X" and m.source.startswith("iSerial") for m in log)
