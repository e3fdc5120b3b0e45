"""Issue 9: a serial GPS, heading sensor and echo sounder on ptys (``mavhelm sim``'s
instruments) feed NAV_* end to end through the companion's iSerial readers and pNav, in
lockstep over TCP, through line garbage and truncation on every port and a GPS that is
unplugged and plugged back in (its ``/dev/serial/by-id/`` style symlink vanishes and comes back
pointing at a new pty). Errors are measured against the simulator's ground truth.

The echo sounder goes in as ``SENSOR_ALTITUDE``, not ``SENSOR_DEPTH``: an iSerial block's
``SND_DEPTH`` is the *water* depth (depth below the transducer + the DPT offset), while
``SENSOR_DEPTH`` reads the vehicle's own depth below the surface (the EKF's depth = tide − Z),
so it would put a surface boat 20 m under. ``SND_ALTITUDE`` (metres above the bottom) is what
SENSOR_ALTITUDE reads; pNav passes it on as ``EKF_ALTITUDE`` (of the vehicle's origin, the
transducer's lever arm taken off) and the ``Altitude`` queue makes it ``NAV_ALTITUDE``."""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from mavhelm.companion.link import RETRY_MAX_S
from mavhelm.core.mission import parse_mission
from mavhelm.demo.harness import SimulatedRun
from mavhelm.sitl.faults import Scenario
from mavhelm.sitl.flat_earth import Origin
from mavhelm.sitl.serial_sensors import EchoSounder, HeadingSensor, NmeaGps, PtySerialPort
from tests.support.nav_sim_rig import LAT, LON, SERIAL, NavRun, mission_text

pytestmark = pytest.mark.slow

NAV = """
    X        = EKF @ 2, SGPS @ 3
    Y        = EKF @ 2, SGPS @ 3
    Heading  = HDG @ 1, EKF @ 2
    Altitude = EKF @ 2, SND @ 3
    SENSOR_XY          = SGPS -> gps ~ 1.5
    SENSOR_ORIENTATION = HDG -> compass ~ 0.5
    SENSOR_BODY_VEL    = INS -> gyro ~ 0.5
    SENSOR_ALTITUDE    = SND -> sounder @ 0,0,-0.3 ~ 0.1
    FIXEDSIDESLIP      = 0 @ 0.3
"""
"""The EKF first, the serial GPS behind it; the sounder's altitude through the filter (its
transducer 0.3 m below the waterline, the EchoSounder's draft). The autopilot's GPS is not
used: only its gyro (INS_YAW_VEL), for dead reckoning on heading while the GPS is away."""

PORTS = ("nmea_gps", "heading", "depth")
FAULTS = "".join(f"serial_garbage always port={p} prob=0.05\n"
                 f"serial_truncate always port={p} prob=0.05\n" for p in PORTS)

UNPLUG, REPLUG = 50.0, 60.0
"""Simulation seconds at which the GPS's pty is closed and its link removed (half-way up the
box's second leg, which runs north from t ≈ 40 s to t ≈ 74 s), and at which a new pty for it
appears behind the same link."""
END = 95.0
WATER_DEPTH = 20.0  # the boat model's default


def start(tmp_path: Path, link: Path, seed: int = 3, nav_lines: str = NAV
          ) -> tuple[NavRun, Scenario]:
    """The boat with the three instruments on ptys, the GPS's Port being ``link``."""
    sc = Scenario.from_text(f"seed = {seed}\n{FAULTS}", name="nav_serial")
    gps = PtySerialPort(NmeaGps(origin=Origin(LAT, LON)), sc)
    heading = PtySerialPort(HeadingSensor(), sc)
    sounder = PtySerialPort(EchoSounder(), sc)
    link.parent.mkdir(parents=True)
    link.symlink_to(gps.slave_path)
    serial = "".join(SERIAL.format(label=label, name=name, port=port, sentences=sentences)
                     for label, name, port, sentences in (
                         ("GPS", "SGPS", link, "GGA,RMC"),
                         ("Compass", "HDG", heading.slave_path, "HDT"),
                         ("Sounder", "SND", sounder.slave_path, "DPT,DBT")))
    text = mission_text(serial, nav_lines)
    mission = parse_mission(text, str(tmp_path / "nav.moos"))
    record = {f"{s}_{k}" for s in ("NAV", "EKF", "SGPS") for k in ("X", "Y")}
    record |= {f"{n}_{k}" for n in ("SGPS", "HDG", "SND")
               for k in ("OPEN", "WARNING", "DROPPED", "DROPS")}
    record |= {"NAV_X_SOURCE", "NAV_Y_SOURCE", "NAV_ALTITUDE", "NAV_ALTITUDE_SOURCE",
               "NAV_DEPTH", "EKF_ALTITUDE", "SND_ALTITUDE", "SND_DEPTH", "NAV_HEADING",
               "NAV_HEADING_SOURCE", "EKF_SIGMA_X", "EKF_SIGMA_Y", "NAV_WARNING",
               "NAVIGATION_FAILURE"}
    run = SimulatedRun.start(mission, scenario=sc, seed=seed, serial_sensors=[gps, heading,
                                                                             sounder],
                             record=record, params={"FS_EKF_ACTION": 0})
    return NavRun(run, [gps, heading, sounder]), sc


def test_serial_gps_heading_and_sounder_feed_nav_through_garbage_and_a_replugged_gps(
        tmp_path):
    wall = time.perf_counter()
    link = tmp_path / "dev" / "serial" / "by-id" / "usb-u-blox_GNSS_receiver-if00"
    nav, sc = start(tmp_path, link)
    run = nav.run
    try:
        run.hand_over()
        run.run_until(lambda now: now >= UNPLUG, UNPLUG + 1.0)
        # unplugged: the pty vanishes with its by-id link; the simulator stops writing to it
        old = nav.ports[0]
        run.sim.serial_sensors.remove(old)
        old.close()
        link.unlink()
        unplugged = run.clock.now()
        run.run_until(lambda now: now >= REPLUG, REPLUG - UNPLUG + 1.0)
        # plugged back in: the receiver powers up afresh (no fixes kept from before) on a new
        # pty, behind the same link
        new = PtySerialPort(NmeaGps(origin=Origin(LAT, LON)), sc)
        nav.ports.append(new)
        run.sim.serial_sensors.append(new)
        link.symlink_to(new.slave_path)
        replugged = run.clock.now()  # (the kernel may well hand out the old pts number)
        run.run_until(lambda now: now >= END, END - REPLUG + 1.0)  # nothing raised: no crash
        wall = time.perf_counter() - wall

        # the reader said the port was lost, once, and reopened it within its longest backoff
        opens = [(m.time, m.double) for m in nav.series("SGPS_OPEN")]
        assert [v for _, v in opens] == [1.0, 0.0, 1.0]
        lost_at, reopened_at = opens[1][0], opens[2][0]
        assert unplugged <= lost_at <= unplugged + 0.5
        assert replugged < reopened_at <= replugged + RETRY_MAX_S + 0.5  # backoff 1-8 s
        warnings = [(m.time, m.string) for m in nav.series("SGPS_WARNING")]
        assert len(warnings) == 1 and warnings[0][0] == lost_at
        assert f"{link} lost" in warnings[0][1]
        gps_reader = next(i for i in run.companion.plan.instruments if i.prefix == "SGPS")
        assert gps_reader.stats["opens"] == 2 and gps_reader.stats["failures"] >= 2

        # garbage and truncation on every port: lines dropped and counted, never posted
        corrupted = {}
        for name, port in (("SGPS", None), ("HDG", nav.ports[1]), ("SND", nav.ports[2])):
            ports = [nav.ports[0], new] if port is None else [port]
            corrupted[name] = sum(p.stats["garbled"] + p.stats["truncated"] for p in ports)
            dropped = nav.series(f"{name}_DROPPED")[-1].double
            drops = nav.series(f"{name}_DROPS")[-1].string
            assert "truncated=" in drops and ("garbage=" in drops or "checksum=" in drops)
            assert corrupted[name] / 2 <= dropped <= corrupted[name] + 2, (name, drops)
        assert not nav.series("HDG_WARNING") and not nav.series("SND_WARNING")

        # NAV_X/Y: the EKF on the serial GPS, before and after; dead reckoning in between
        sgps = nav.errors("SGPS")
        before = [e for _, e in nav.errors("NAV", 20.0, unplugged)]
        gap = [e for _, e in nav.errors("NAV", unplugged, reopened_at + 1.5)]
        after = [e for _, e in nav.errors("NAV", reopened_at + 10.0)]
        silent = [t for t, _ in sgps if unplugged < t <= reopened_at]
        assert not silent
        assert [t for t, _ in sgps if t > reopened_at]  # the new receiver's fixes arrive
        assert max(e for _, e in sgps) <= 4.0  # no corrupted line became a fix
        assert max(before) <= 4.0 and max(after) <= 4.0
        travelled = nav.distance_travelled(unplugged, reopened_at + 1.0)
        assert travelled > 35.0 and max(gap) <= 8.0
        nav_times = [m.time for m in nav.series("NAV_X") if m.time > 5.0]
        steps = [b - a for a, b in zip(nav_times, nav_times[1:], strict=False)]
        assert max(steps) <= 0.25  # NAV_X never went quiet
        assert [m.value for m in nav.series("NAV_X_SOURCE")][-1] == "EKF"
        assert not [m for m in nav.series("NAV_X_SOURCE") if m.time > 5.0]  # no fallback
        sigma = {m.time: m.double for m in nav.series("EKF_SIGMA_Y")}
        grew = max(s for t, s in sigma.items() if unplugged < t < reopened_at)
        assert grew > 1.5 * sigma[max(t for t in sigma if t <= unplugged)]  # and it knew
        assert not nav.series("NAVIGATION_FAILURE")

        # the heading sensor gives NAV_HEADING; the sounder NAV_ALTITUDE (m above the bottom)
        truth_heading = {round(tr.t, 1): tr.heading for tr in run.track}

        def heading_error(m, ago: float = 0.0) -> float:
            truth = truth_heading[round(m.time - ago, 1)]
            return abs((m.double - truth + 180.0) % 360.0 - 180.0)

        headings = [m for m in nav.series("NAV_HEADING") if m.time > 5.0]
        heading_errors = sorted(heading_error(m) for m in headings)
        # a line is stamped when it is read: a tick or two after its sample when the pty is
        # slow to hand it over, which in a 40 deg/s turn is 4-8 deg; what it says must be the
        # truth (0.3 deg of noise) of some moment in the 0.3 s before its stamp
        late = [min(heading_error(m, ago) for ago in (0.0, 0.1, 0.2, 0.3)) for m in headings]
        assert [m.value for m in nav.series("NAV_HEADING_SOURCE")][-1] == "HDG"
        assert len(headings) > 8 * (END - 5.0)  # 10 Hz less the dropped lines
        assert heading_errors[int(0.95 * len(heading_errors))] <= 1.0
        assert max(late) <= 1.5
        altitude = [m.double for m in nav.series("NAV_ALTITUDE")]
        assert [m.value for m in nav.series("NAV_ALTITUDE_SOURCE")][-1] == "EKF"
        assert len(altitude) > 3 * END  # a DPT and a DBT at 2 Hz, less the dropped lines
        assert all(abs(a - WATER_DEPTH) < 0.8 for a in altitude)
        assert all(abs(m.double - WATER_DEPTH) < 0.8 for m in nav.series("SND_DEPTH"))
        assert not nav.series("NAV_DEPTH")  # the water depth is not the boat's depth

        assert not [m for m in run.messages if m.name.endswith("_ERROR")]
        print(f"\nGPS unplugged at {unplugged:.1f} s, said lost at {lost_at:.1f} s, link back at "
              f"{replugged:.1f} s, reopened at {reopened_at:.1f} s")
        for n in corrupted:
            print(f"{n}: {nav.series(f'{n}_DROPPED')[-1].double:.0f} lines dropped of "
                  f"{corrupted[n]} corruptions ({nav.series(f'{n}_DROPS')[-1].string})")
        print(f"NAV error before {max(before):.2f} m, during the gap {max(gap):.2f} m "
              f"(dead reckoning over {travelled:.0f} m), after {max(after):.2f} m; serial GPS "
              f"itself {max(e for _, e in sgps):.2f} m")
        print(f"heading error p95 {heading_errors[int(0.95 * len(heading_errors))]:.2f}, max "
              f"{heading_errors[-1]:.1f} deg ({max(late):.2f} deg within 0.3 s); altitude "
              f"{min(altitude):.2f}..{max(altitude):.2f} m ({len(altitude)} values); "
              f"wall {wall:.1f} s")
    finally:
        nav.close()
