"""The fault library on a simulator run with truth: a boat patrolling its box on GPS,
compass, gyro and three radio beacons in ``mavhelm sim`` (the real path, recorded to an
.alog), then ``mavhelm nav replay --fault`` over that recording: each fault's NAV error,
NEES and decisions, with the issue's floor — NAV never worse than the best of its own sources
by more than 20 % — and a GPS with 2 m of noise and 30–60 m glitches kept within 2 m.

Measured (NAV RMS; the GPS alone 0.55 m): none 0.34, heading wandering to 180° 0.35 (the
mission declares no bias state: 9.46 m before a doubt down-weighted the heading, 0.64 with
down-weighting alone, which left the compass a share of the heading growing with its bias;
a doubt now adds the bias state, at 104 s; 0.70 m when only the 20-reading look back doubted
it, at 135 s), drifting 180° within five minutes 0.35, heading jumps 0.34, stuck 0.35, 60 s
without ranges 0.35, range outliers 0.34, GPS glitches 0.39,
a beacon 5 m from its surveyed place 0.57 (0.84 m, NEES 20, before the beacon watch: against
the GPS as declared, σ 2 m, the 0.8 m it was off was no disagreement at all; the beacon's
learned range offset, unlike the other beacons', is), 0.48 m with the beacons' shared delay's
prior σ 1 m instead of 5 m (the beacon found at 52 s instead of 70 s; the other variants
0.28-0.31 m either way). The gyro's yaw rate reversed: found at 6.2 s and negated, 0.29 m
(0.62 m when it was only left out, the heading it had dragged for 6 s kept; before that, a
gyro with nothing left of it restarted the filter 266 times); now neither the gyro nor the
compass is taken until the courses made good tell which turns the wrong way (48 s): 0.30 m,
and the compass reversed instead 0.30 m."""

from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from tests.support.nav_sim_rig import RANGES as RADIO_RANGES
from tests.support.nav_sim_rig import start

pytestmark = pytest.mark.slow

RANGES = RADIO_RANGES + "    LSQTimeOut = NEVER\n"
"""The simulator tests' GPS + compass + gyro + radio ranges, every position from the EKF
(the GPS queue source would otherwise pass the faulted fixes straight to NAV)."""


def _replayed(lines: str, folder: Path, seconds: float, *replay_args: str,
              **rig: Any) -> str:
    """The box patrol with these pNav ``lines`` (every position from the EKF) run in the
    simulator for ``seconds`` and recorded, then ``mavhelm nav replay`` over the recording
    with ``replay_args``: its report."""
    nav = lines.replace("GPS @ 2, EKF @ 2", "EKF @ 2")
    run = start(nav, tmp_path=folder, logs=True, **rig)
    try:
        run.run.hand_over()
        run.run.run_for(seconds)
    finally:
        run.close()
    mission = folder / "replay.moos"
    mission.write_text("ProcessConfig = pNav\n{\n" + nav + "}\n")
    done = subprocess.run([sys.executable, "-m", "mavhelm.cli", "nav", "replay", str(mission),
                           str(folder / "nav.alog"), "--no-nav-log", *replay_args],
                          capture_output=True, text=True, check=False)
    print(done.stdout)
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


@pytest.fixture(scope="module")
def report(tmp_path_factory: pytest.TempPathFactory) -> dict[str, str]:
    text = _replayed(RANGES, tmp_path_factory.mktemp("sim_faults"), 400.0, "--fault", "all",
                     ranging="radio", dvl=False)
    runs = re.split(r"^== fault (\w+) ==$", text, flags=re.M)
    return {"none": runs[0], **dict(zip(runs[1::2], runs[2::2], strict=True))}


def _score(text: str, source: str) -> tuple[float, float]:
    found = re.search(rf"^{source}\s+position: RMS ([\d.]+) m, p95 [\d.]+ m, max ([\d.]+) m",
                      text, flags=re.M)
    assert found, text
    return float(found.group(1)), float(found.group(2))


MISSED: dict[str, float] = {}
"""Variants that miss the 20 % floor today, with the RMS (m) they are held to instead."""


def test_each_fault_on_a_simulator_run(report) -> None:
    assert {"none", "heading_wander", "heading_drift", "heading_offset", "heading_jumps",
            "heading_stuck",
            "ranges_gap", "beacon_moved", "range_outliers", "ranges_long", "gps_glitches",
            "yaw_rate_reversed", "heading_reversed", "speed_scale"} == set(report)
    # the gyro is this mission's only body-velocity sensor: no speed to scale, and it is said
    assert [f for f, text in report.items() if "finds nothing to act on" in text] == \
        ["speed_scale"]
    for fault, text in report.items():
        nav, _ = _score(text, "NAV")
        best = min(_score(text, s)[0] for s in ("EKF", "LSQ", "GPS")
                   if re.search(rf"^{s}\s+position", text, flags=re.M))
        assert "NAVIGATION FAILURE" not in text, fault
        if fault in MISSED:
            assert nav <= MISSED[fault], (fault, text)
            continue
        assert nav <= 1.2 * best or math.isclose(nav, best, abs_tol=0.05), (fault, text)
        assert re.search(r"^NEES \(EKF position, 2 dof\): mean", text, flags=re.M)


def test_a_wandering_compass_gets_the_bias_state_the_mission_did_not_declare(report) -> None:
    text = report["heading_wander"]
    assert "heading bias is estimated from now on" in text
    learned = re.search(r"^learned: heading bias ([+-][\d.]+) deg", text, flags=re.M)
    assert learned and abs(float(learned.group(1))) > 90.0  # measured +177.07 (the fault 177.5)


def test_a_heading_or_a_gyro_of_the_wrong_sense_is_told_by_the_courses_made_good(report) -> None:
    """The gyro (the only body velocity) gives no track to fit the ranges to, so the courses
    made good between the fixes tell which one turns the wrong way (compass reversed: 1.65 m
    RMS with the gyro negated to agree with it, 0.30 m now, told at 48 s)."""
    told = r"the courses made good between fixes"
    assert re.search(rf"the heading of sensor compass turns against {told}, the yaw rate "
                     r"INS_YAW_VEL \(sensor gyro\) with it", report["heading_reversed"])
    assert re.search(rf"{told} turn with the heading of sensor compass: the yaw rate "
                     r"INS_YAW_VEL \(sensor gyro\) is the one of the wrong sense",
                     report["yaw_rate_reversed"])


def test_a_clean_run_doubts_no_heading(report) -> None:
    """The start from rest (the filter's speed trailing the boat's by 1-2.5 m at 5-10 s) is
    not a heading fault: 'heading 3' at 6.9 s before the watch waited for a course. What it
    says of the heading is only that its bias is estimated once the boat is under way."""
    said = re.findall(r"^ +[\d.]+ s  heading: (.*)$", report["none"], flags=re.M)
    assert said and any("estimated from now on" in why for why in said), report["none"]
    assert not any("doubted" in why or "contradicts" in why for why in said), said


def test_a_gps_with_2_m_noise_and_glitches_is_held_within_2_m(report) -> None:
    rms, worst = _score(report["gps_glitches"], "NAV")
    gps_rms, gps_worst = _score(report["gps_glitches"], "GPS")
    assert rms <= 2.0 and worst < gps_worst


def test_the_published_uncertainty_is_honest_on_the_simulator_run(report) -> None:
    found = re.search(r"^NEES \(EKF position, 2 dof\): mean ([\d.]+) .*?, (\d+) % of ticks "
                      r"inside .*?, (\d+) % above", report["none"], flags=re.M)
    assert found
    mean, inside, above = (float(g) for g in found.groups())
    # measured: mean 1.56 (2 when honest), 95 % of ticks inside the 95 % band, 2 % above (with
    # EKF_TIME_SIGMA's 0.1 s of lateness; 2.34, 93 %, 4 % without)
    assert 1.0 <= mean <= 3.0 and inside >= 88 and above <= 8


def test_a_compass_out_from_the_start_on_gps_dvl_and_gyro_is_realigned_to_its_offset(
        tmp_path) -> None:
    """The box patrol on GPS, compass, DVL and gyro (no ranges), every position from the
    EKF, its compass 113° out from the start (``heading_offset`` seed 3): the GPS fixes,
    refused in a row as the filter steers its dead reckoning by the compass, say the filter
    is off, and the courses made good then turn the heading at the sensor's own offset
    from their first three runs. Before, the runs had to last 25 s, and their corrections
    (each against the bias the filter held then, while it learned 40-odd degrees of it from
    the GPS) were added to the bias now, which counted that twice: 16.8 m RMS over 300 s
    (taken at 35 s, 3.5 m with the offset counted once)."""
    from tests.support.nav_sim_rig import DEAD_RECKONING

    text = _replayed(DEAD_RECKONING, tmp_path, 300.0, "--fault", "heading_offset",
                     "--faults-only", "--seed", "3", dvl=True)
    taken = re.search(r"^ +([\d.]+) s  heading: heading taken from the motion: the "
                      r"orientation sensor reads ([+-]\d+)° off the course", text, flags=re.M)
    assert taken and abs(int(taken.group(2)) + 113) <= 3, text
    assert float(taken.group(1)) < 20.0, text
    nav_rms, _ = _score(text, "NAV")
    assert nav_rms <= 1.5, text
