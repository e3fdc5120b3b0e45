"""Serial instruments end to end: ``mavhelm sim --sensors`` serves a NMEA GPS and heading on
pseudo-terminals, ``mavhelm run`` reads them through iSerial blocks, and pNav routes them into
NAV_* ahead of the autopilot's own (spec 2.1), all as separate processes on the wall clock."""

from __future__ import annotations

import signal
import sys
import time

import pytest

from mavhelm.companion.alog import read_alog
from tests.support.interop_helpers import SimProcess
from tests.support.mission import block, mission_text
from tests.support.processes import ConsoleProcess
from tests.support.waiting import wait_for

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
        comp = ConsoleProcess([sys.executable, "-m", "mavhelm.cli", "run", str(mission),
                               "--log-dir", str(logs)])
        try:
            # the companion's start-up takes seconds on a loaded machine: wait until pNav has
            # taken both instruments, then give them a few seconds (GPS 1 Hz, compass 10 Hz)
            wait_for(lambda: comp.find("nav X from SGPS") and comp.find("nav HEADING from HDG"),
                     60.0, "pNav taking the serial GPS and compass", comp.output)
            time.sleep(4.0)
        finally:
            code = comp.stop(signal.SIGTERM, grace_s=30.0)
        assert code == 0, comp.output()
    log = read_alog(next(logs.glob("*.alog")))
    sources = {m.name: m.string for m in log if m.name.endswith("_SOURCE")}
    assert sources["NAV_X_SOURCE"] == "SGPS" and sources["NAV_HEADING_SOURCE"] == "HDG"
    x = [m.double for m in log if m.name == "NAV_X"]
    heading = [m.double for m in log if m.name == "NAV_HEADING"]
    assert len(x) >= 3 and all(abs(v) < 10.0 for v in x), "at home, within GPS noise"
    assert len(heading) >= 20 and all(abs(h - 90.0) < 5.0 for h in heading)
    assert any(m.name == "SGPS_X" and m.source.startswith("iSerial") for m in log)
