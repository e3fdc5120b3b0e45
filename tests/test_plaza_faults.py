"""pNav on Plaza1 with each fault of the library made on it, through ``mavhelm nav replay
--fault all``: the floors held on recorded data (deterministic: the faults are seeded).

Floors (issue 15): every variant ≤ 1.0 m RMS, and NAV never worse than the best of its own
sources by more than 20 %; no navigation failure. Measured (the odometer's speed scale
learned, the default since it was measured off: 0.33, 0.33, 0.40, 0.34, 0.33, 0.72 m before):
clean 0.37 m, the heading wandering 0.36 m, drifting 180° within five minutes 0.37 m (2.47 m
before the bias's drift rate was a state, 0.41 m before the odometer's yaw rate read that
drift too), the odometer's yaw rate 7.8 % short 0.36 m (2.04 m
before its scale was a state), range outliers 0.36 m, a beacon 5 m from its surveyed place
0.74 m, the beacon found
from the track at 200 s (1.06 m while the shared range delay's prior σ was 5 m, 1.71 m while
the offsets were the only evidence). The robot stands still for its first 80 s, where four
ranges fit a displaced beacon at a position 4–4.5 m out and nothing is left to check them
with (see :mod:`mavhelm.nav.survey_check`).
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mavhelm.companion.alog import AlogLogger, read_alog
from mavhelm.core.bus import Bus
from mavhelm.core.clock import SimClock
from mavhelm.core.mission import load_mission
from mavhelm.nav.faults import layout_of, with_fault

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[1]
MAT = REPO.parent / "shared" / "data" / "plaza" / "Plaza1.mat"
EXAMPLE = REPO / "examples" / "plaza"

FLOOR = 1.0
PLAZA_FAULTS = ("heading_wander", "heading_drift", "heading_scale", "heading_offset",
                "heading_jumps",
                "heading_stuck", "ranges_gap", "beacon_moved", "range_outliers", "ranges_long",
                "yaw_rate_reversed", "heading_reversed", "speed_scale")


def _converted(folder: Path) -> tuple[Path, Path]:
    """Plaza1 as an .alog and its pNav mission in ``folder``."""
    if not MAT.exists():
        pytest.skip(f"the Plaza data set is absent: {MAT}")
    alog, mission = folder / "plaza1.alog", folder / "plaza1.moos"
    done = subprocess.run([sys.executable, str(EXAMPLE / "convert.py"), str(MAT), str(alog),
                           "--mission", str(mission)], capture_output=True, text=True,
                          check=False)
    assert done.returncode == 0, done.stderr
    return alog, mission


@pytest.fixture(scope="module")
def plaza(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    return _converted(tmp_path_factory.mktemp("plaza_faults"))


@pytest.fixture(scope="module")
def report(plaza: tuple[Path, Path]) -> dict[str, str]:
    alog, mission = plaza
    done = subprocess.run([sys.executable, "-m", "mavhelm.cli", "nav", "replay", str(mission),
                           str(alog), "--fault", "all", "--no-nav-log"],
                          capture_output=True, text=True, check=False)
    print(done.stdout)
    assert done.returncode == 0, done.stdout + done.stderr
    runs = re.split(r"^== fault (\w+) ==$", done.stdout, flags=re.M)
    return {"none": runs[0], **dict(zip(runs[1::2], runs[2::2], strict=True))}


def _rms(text: str, source: str) -> float:
    found = re.search(rf"^{source}\s+position: RMS ([\d.]+) m", text, flags=re.M)
    assert found, text
    return float(found.group(1))


def test_every_fault_that_applies_is_replayed(report) -> None:
    assert set(report) == {"none", *PLAZA_FAULTS}  # no GPS on Plaza: gps_glitches is not


@pytest.mark.parametrize("fault", ["none", *PLAZA_FAULTS])
def test_floors_on_each_variant(report, fault) -> None:
    text = report[fault]
    nav = _rms(text, "NAV")
    assert "NAVIGATION FAILURE" not in text
    assert nav <= FLOOR, text
    best = min(_rms(text, "EKF"), _rms(text, "LSQ"))
    assert nav <= 1.2 * best
    assert re.search(r"^NEES \(EKF position, 2 dof\): mean [\d.]+", text, flags=re.M)
    assert re.search(r"^decisions: booted 1, reinitialised \d+", text, flags=re.M)


def test_the_navigator_says_what_it_decided_about_the_heading(report) -> None:
    # each jump told from the turns the odometer's yaw rate makes, and taken into the bias
    # (until the kicks were told, "contradicts the motion": the readings refused meanwhile)
    assert re.search(r"heading sensor \w+ jumped [-+]\d+° between two readings, faster than "
                     r"the vehicle turns", report["heading_jumps"]), report["heading_jumps"]
    # the stuck sensor is told by its value standing while the robot turns, and refused
    # until it moves (0.44 m RMS while it was refused only when the χ² gate did, 0.38 m)
    assert re.search(r"heading sensor \w+ has read [-\d.]+ rad for \d+ s while the vehicle "
                     r"turned \d+°: stuck", report["heading_stuck"]), report["heading_stuck"]
    assert "reads a new value: used again" in report["heading_stuck"]
    for fault in ("heading_wander", "heading_drift"):
        # the bias and its drift rate follow the sensor, no doubt needed: nothing re-started
        text = report[fault]
        assert "reinitialised 0," in text and "doubted" not in text
        learned = re.search(r"^learned: heading bias ([-+\d.]+) deg, drifting [-+\d.]+ deg/min",
                            text, flags=re.M)
        assert learned and abs(float(learned.group(1))) > 90.0, text  # far from the clean 0.6°
    assert "the heading bias is unobservable" in report["none"]  # the robot stands still first
    # its 12 heading decisions are its six stops and starts (truth: still, then moving)
    assert "doubted" not in report["none"] and "contradicts" not in report["none"]


def test_a_yaw_rate_or_a_heading_of_the_wrong_sense_is_told_apart_and_reported(report) -> None:
    """The odometry's yaw rate reversed: 7.76 m RMS before the rate was voted against the
    heading's turns (290 decisions, none naming the cause); found at 52.8 s, within a
    second of the robot's first turns, and taken negated: 0.42 m. Its heading reversed
    instead: 9.00 m, then 5.79 m with the rate negated to agree with it. Now the track the
    ranges fit tells which of the two turns the wrong way (at 87 s in both), and the filter
    takes neither until it does: heading reversed 0.58 m, rate reversed 0.64 m (the robot
    turns in place before it moves, with neither); 0.59 and 0.66 m with the odometer's
    speed scale learned, the default since, and held while the sense is open (0.83 m for
    the rate learning it meanwhile); 0.61 and 0.58 m once the odometer's yaw rate reads the
    drift its heading integrates; 0.60 and 0.54 m with that drift held too while the ranges
    are asked for the heading."""
    text = report["yaw_rate_reversed"]
    assert re.search(r"the yaw rate ODOM_YAW_VEL \(sensor \w+\) turns against the heading of "
                     r"sensor \w+ \(ODOM\)[^\n]*neither is taken until the motion tells which",
                     text), text
    assert re.search(r"the track the ranges fit turns with the heading of sensor \w+: the yaw "
                     r"rate ODOM_YAW_VEL \(sensor \w+\) is the one of the wrong sense", text), text
    heading = report["heading_reversed"]
    assert re.search(r"the heading of sensor \w+ turns against the track the ranges fit, the "
                     r"yaw rate ODOM_YAW_VEL \(sensor \w+\) with it: the heading is the one "
                     r"of the wrong sense, taken negated", heading), heading
    assert "turns with the heading" not in heading
    for fault, other in report.items():
        if fault not in ("yaw_rate_reversed", "heading_reversed"):
            assert "turns against" not in other and "wrong sense" not in other, fault


def test_an_odometer_off_its_wheel_size_is_learned(report) -> None:
    """``speed_scale`` (seed 1 draws the odometry's speeds 9.8 % short): the filter's speed
    scale, added at the first speed, learns it against the ranges (NAV 0.36 m RMS; 1.9 m on
    an odometer 10 % short without the state, ``tests/test_plaza.py``)."""
    rng = np.random.default_rng(1)  # the fault's own draw (mavhelm.nav.faults.speed_scale)
    drawn = float(rng.choice([-1.0, 1.0]) * rng.uniform(0.05, 0.10))
    learned = {fault: float(re.search(r"speed scale ([-+][\d.]+)", report[fault]).group(1))
               for fault in ("none", "speed_scale")}
    assert abs(learned["none"]) < 0.01
    assert "finds nothing to act on" not in report["speed_scale"]
    assert learned["speed_scale"] == pytest.approx(drawn, abs=0.015), (drawn, learned)


def test_a_heading_sensor_turned_from_the_start_is_righted_by_the_ranges(plaza, report) -> None:
    """The orientation sensor 175.5° off from the start (seed 1's draw): the robot stands
    still for 52 s, then the ranges over its first metres tell the heading (within 20° of
    the truth) and the filter restarts where they put it; meanwhile its speed scale and the
    bias's drift are held. 0.56 m RMS (seeds 1-8 0.51-0.57 m, the ranges asked every
    second; 0.55-0.63 m every two), 0.92 m when the ranges needed 15 m of travel (the answer
    at 87 s) and those states learned the turn (seeds 1-8 0.64-0.94 m)."""
    alog, mission = plaza
    block = load_mission(mission).process("pNav")
    assert block is not None
    reading = read_alog(alog)[:400]
    heading = next(m for m in reading if m.name == "ODOM_HEADING")
    turned = next(m for m in with_fault("heading_offset", reading, layout_of(block), 1)
                  if m.name == "ODOM_HEADING" and m.time == heading.time)
    offset = float(np.remainder(turned.double - heading.double + 180.0, 360.0) - 180.0)
    assert abs(offset) > 170.0  # the draw this test is about: turned right round
    text = report["heading_offset"]
    found = re.search(r"^\s+([\d.]+) s  heading: heading taken from the ranges: the orientation "
                      r"sensor reads ([-+]\d+)° off", text, flags=re.M)
    assert found, text
    assert float(found.group(1)) < 60.0  # the robot's first moves: 52 s
    # told as a yaw offset (anticlockwise): the heading's own turned the other way
    assert abs(float(np.remainder(float(found.group(2)) + offset + 180.0, 360.0) - 180.0)) < 20.0
    assert _rms(text, "NAV") <= 0.7


def test_a_beacon_off_its_survey_is_found_and_reported(report) -> None:
    text = report["beacon_moved"]
    assert "beacon 0's ranges do not fit the track" in text  # the one the fault moves
    assert set(re.findall(r"beacon (\w+)'s ranges [^\n]*off its survey", text)) == {"0"}
    for fault, text in report.items():
        if fault != "beacon_moved":
            assert "off its survey" not in text, fault
    assert re.search(r"^NAV against its best source \(\w+, RMS [\d.]+ m\): [\d.]+x",
                     report["none"], flags=re.M)


def _nees(text: str) -> tuple[float, float, float]:
    found = re.search(r"^NEES \(EKF position, 2 dof\): mean ([\d.]+) .*?, (\d+) % of ticks "
                      r"inside .*?, (\d+) % above", text, flags=re.M)
    assert found, text
    return float(found.group(1)), float(found.group(2)), float(found.group(3))


def test_the_published_uncertainty_is_not_over_confident_on_plaza(report) -> None:
    # measured: mean 0.81, 89 % inside the 95 % band, 1 % above it: a little under-confident,
    # never proud (NIS per dof: heading and odometry 0.03, ranges 0.44, whatever noise the
    # heading and odometry are declared with: the heading is the odometry's own integral)
    mean, inside, above = _nees(report["none"])
    assert mean <= 2.0 and inside >= 85 and above <= 5


OTHER_DRAWS = (("heading_jumps", 3), ("heading_jumps", 5), ("range_outliers", 5),
               ("range_outliers", 7), ("range_outliers", 34), ("heading_drift+heading_stuck", 2),
               ("heading_drift+heading_jumps", 3), ("beacon_moved", 6),
               ("heading_offset+heading_jumps", 1))


def _as_defaults(mission: Path) -> Path:
    """The mission as one written with pNav's defaults: no heading-bias state declared
    (EKF_YAW_BIAS) and no start (EKF_X, EKF_Y, EKF_SIGMA_XY): the filter boots from the LSQ
    and adds the bias state itself once under way."""
    kept = [line for line in mission.read_text().splitlines(keepends=True)
            if line.split("=")[0].strip() not in ("EKF_YAW_BIAS", "EKF_X", "EKF_Y",
                                                  "EKF_SIGMA_XY")]
    plain = mission.with_name("plaza1_defaults.moos")
    plain.write_text("".join(kept))
    return plain


DEFAULTS_DRAWS = (("heading_drift", 1), ("heading_jumps", 2))
"""Replayed with :func:`_as_defaults`'s mission."""
LOOSE_RANGE_SIGMA = 3.0
"""The ranges' σ a cautious user might declare (Plaza1's are about 0.8 m)."""


def _loosely_declared(plain: Path) -> Path:
    """:func:`_as_defaults`'s mission with the ranges' σ declared ``LOOSE_RANGE_SIGMA``."""
    text = re.sub(r"^(\s*SENSOR_RANGE\s*=.*~\s*)[\d.]+", rf"\g<1>{LOOSE_RANGE_SIGMA:g}",
                  plain.read_text(), flags=re.M)
    assert f"~ {LOOSE_RANGE_SIGMA:g}" in text
    loose = plain.with_name("plaza1_loose.moos")
    loose.write_text(text)
    return loose


UNDER_WAY = 600.0
"""s into Plaza1 where :func:`_under_way` starts its recording."""


def _write_alog(messages: list, path: Path) -> Path:
    """``messages`` written as an .alog whose log starts at the first of them."""
    logger = AlogLogger(Bus(SimClock(messages[0].time)), path, start_time=messages[0].time,
                        opened_on=0.0)
    try:
        logger.on_mail(messages, messages[-1].time)
    finally:
        logger.close()
    return path


def _from(alog: Path, seconds: float, folder: Path) -> Path:
    """Plaza1 as recorded from ``seconds`` in (the robot under way), written into folder."""
    messages = read_alog(alog)
    return _write_alog([m for m in messages if m.time >= messages[0].time + seconds],
                       folder / f"plaza1_from_{seconds:.0f}_s.alog")


def _started_at(messages: list, mission: Path, seconds: float, name: str
                ) -> tuple[Path, Path]:
    """The recording ``messages`` started ``seconds`` in (the robot under way), written
    beside the mission as ``name``.alog, and the mission with its start 5 m from the truth
    there, as the converter puts it at the log's."""
    kept = [m for m in messages if m.time >= messages[0].time + seconds]
    truth = {m.name: m.double for m in reversed(kept) if m.name in ("TRUTH_X", "TRUTH_Y")}
    started = _write_alog(kept, mission.with_name(f"{name}.alog"))
    text = re.sub(r"^(\s*EKF_X\s*=).*$", rf"\g<1> {truth['TRUTH_X'] + 3.0:.2f}",
                  mission.read_text(), flags=re.M)
    text = re.sub(r"^(\s*EKF_Y\s*=).*$", rf"\g<1> {truth['TRUTH_Y'] + 4.0:.2f}", text,
                  flags=re.M)
    moved = mission.with_name(f"{name}.moos")
    moved.write_text(text)
    return started, moved


def _under_way(alog: Path, mission: Path) -> tuple[Path, Path]:
    """Plaza1 with its heading drifting 180° within five minutes (seed 1), the recording
    started ``UNDER_WAY`` s in: the robot moving, its heading sensor then 176° off."""
    block = load_mission(mission).process("pNav")
    assert block is not None
    messages = with_fault("heading_drift", read_alog(alog), layout_of(block), 1)
    return _started_at(messages, mission, UNDER_WAY, "plaza1_under_way")


@pytest.fixture(scope="module")
def other_draws(plaza: tuple[Path, Path]) -> dict[tuple[str, int, str], str]:
    """Each of ``OTHER_DRAWS`` replayed, of ``DEFAULTS_DRAWS`` with the defaults' mission,
    the drifting heading with the ranges' σ declared loosely, and :func:`_under_way`'s
    recording as it is (``("under_way", 0, ...)``), side by side (one process each, the
    fault alone)."""
    alog, mission = plaza
    plain = _as_defaults(mission)
    jobs = [(fault, seed, mission) for fault, seed in OTHER_DRAWS]
    jobs += [(fault, seed, plain) for fault, seed in DEFAULTS_DRAWS]
    jobs += [("heading_drift", 1, _loosely_declared(plain))]
    runs = {(fault, seed, path.stem): subprocess.Popen(
        [sys.executable, "-m", "mavhelm.cli", "nav", "replay", str(path), str(alog),
         "--fault", fault, "--seed", str(seed), "--faults-only", "--no-nav-log"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for fault, seed, path in jobs}
    started, moved = _under_way(alog, mission)
    runs["under_way", 0, moved.stem] = subprocess.Popen(
        [sys.executable, "-m", "mavhelm.cli", "nav", "replay", str(moved), str(started),
         "--no-nav-log"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    reports = {}
    for (fault, seed, name), run in runs.items():
        out, err = run.communicate(timeout=600)
        assert run.returncode == 0, out + err
        reports[fault, seed, name] = out if fault == "under_way" else re.split(
            rf"^== fault {re.escape(fault)} ==$", out, flags=re.M)[1]
    return reports


@pytest.mark.parametrize("fault, seed", OTHER_DRAWS)
def test_other_draws_that_broke_the_floor_stay_under_it(other_draws, fault, seed) -> None:
    """Other draws of the faults (seed 1 above). The jumps: a kick lasting 5-20 s was taken
    as the sensor's offset from three runs made during it (1.02 and 1.74 m RMS, the bias left
    18° wrong); an offset short of turned-round must now last 25 s. The outliers: standing
    still, LSQ fixes thrown 8 m apart made 25 runs agreeing on a −78° offset (2.89 m); a run
    the odometry did not travel is no longer one. Outliers, seed 7: a range 13 m short, the
    first to its beacon, was learned as that beacon's offset and every good range after it
    refused (2.98 m); the offsets' prior now leaves each beacon only 0.5 m of its own.
    Outliers, seed 34: the very first range 16 m short, taken (the start's σ is 5 m), moved
    the filter 10 m off and taught the range scale −0.19; the ranges refused after it
    doubted the filter, whose widened position then settled 28 m off on that scale (−0.26,
    its σ 0.013) until the LSQ's disagreement re-initialised it 25 s later (3.22 m). Doubted
    so, the filter now forgets the range scale with the offsets and is re-centred on the
    LSQ's last fix (0.65 m; the scale alone 0.99 m).

    Two faults at once, the heading drifting 180° within five minutes and stuck for five
    (``mavhelm nav replay --fault heading_drift+heading_stuck``): refused while stuck, the
    sensor's bias went stale behind its drift while the filter held its heading from the
    motion; the realignment then turned that right heading by the bias's change, as if the
    filter had followed the sensor (12.5 m RMS, seeds 1 and 3 8.2 and 11.9 m). The heading
    held is now kept and the bias alone set, from the sensor's offset to it (0.50 m).
    Drifting and kicked (seed 3): a kick taken for a turn carried the position 15 m off in
    27 s while three beacons' ranges were refused, growing, so that no beacon's lock-out
    fired (1.42 m); three refused to each of two beacons now doubt the filter (0.79 m).

    A beacon 5 m off its survey (seed 1 1.06 m, seed 6 1.00 m): the robot stands still for
    its first 80 s, where four ranges fit a position, a range scale and a shared delay
    exactly; with that delay's prior σ 5 m, the fix went 4.5 m out and the delay took 6 m.
    Its σ is now 1 m (seeds 1-6: 0.61-0.80 m; with the speed scale learned 0.60-0.78 m).

    A compass turned 176° from the start and kicked 39° more 2 s before the robot first moves
    (seed 1; seed 8 alike): the kicked readings were refused, and the ranges were not asked
    for the heading for 40 s after, as a refused sensor bends the track they are fitted to.
    The robot dead-reckoned backwards, twice 10-16 m off (1.19 m RMS; seed 8 1.20 m). The
    filter's heading now stands in for each refused reading in that track: the ranges answer
    5 s into the move, as with the compass turned alone (0.61 m; seed 8 0.62 m)."""
    text = other_draws[fault, seed, "plaza1"]
    assert _rms(text, "NAV") <= FLOOR, text
    assert _rms(text, "NAV") <= 1.2 * min(_rms(text, "EKF"), _rms(text, "LSQ")), text


@pytest.mark.parametrize("fault, seed", DEFAULTS_DRAWS)
def test_heading_faults_on_a_mission_written_with_the_defaults(other_draws, fault,
                                                              seed) -> None:
    """No bias state declared and no start: the filter boots from the LSQ and adds the bias
    state once under way. The drifting heading (180° within five minutes): 10.2 m RMS, twice
    the LSQ's 5.05 m, four re-initialisations, while the added bias was a random walk alone;
    0.43 m with its drift rate (EKF_YAW_DRIFT's default) and five minutes of wander. The
    jumps: added during a 30-90° kick (seed 2, at 52 s), the bias took the kick for itself
    and the sensor, right again, was refused for minutes at a time (1.39 m); the state now
    waits for a heading reading the filter accepts (0.37 m)."""
    text = other_draws[fault, seed, "plaza1_defaults"]
    assert "EKF booted from the LSQ" in text
    assert "heading bias is estimated from now on" in text
    nav = _rms(text, "NAV")
    assert nav <= FLOOR and nav <= 1.2 * min(_rms(text, "EKF"), _rms(text, "LSQ")), text
    assert "reinitialised 0," in text


def test_ranges_declared_three_times_too_noisy(other_draws) -> None:
    """The defaults' mission with the ranges' σ declared 3 m, the heading drifting 180°
    within five minutes: the ranges, weighted as 3 m, let the drifting heading carry the
    track off (1.29 m RMS). Their χ² under a fifth of its due for window after window, their
    σ now shrinks towards what they show (0.51 m)."""
    text = other_draws["heading_drift", 1, "plaza1_loose"]
    nav = _rms(text, "NAV")
    assert nav <= FLOOR and nav <= 1.2 * min(_rms(text, "EKF"), _rms(text, "LSQ")), text


def test_a_boot_under_way_with_the_heading_turned_round_is_righted_by_the_ranges(
        other_draws) -> None:
    """Plaza1 from 600 s in, the heading drifting 180° within five minutes and 176° off
    there: the filter booted at the mission's start steered its dead reckoning backwards
    (55 m off in 20 s), was re-initialised from the LSQ twice and drifted off again, its
    heading never taken from the course made good between LSQ fixes 5 m apart (13.2 m RMS,
    p95 28.4 m, the LSQ 4.95 m). The dead-reckoned track turned to fit the ranges heard
    along it tells the sensor's offset (:mod:`mavhelm.nav.range_alignment`): righted 14 s in
    (2.4 m RMS, nearly all of it in those 14 s; p95 1.1 m)."""
    text = other_draws["under_way", 0, "plaza1_under_way"]
    assert "heading taken from the ranges: the orientation sensor reads -17" in text, text
    assert _rms(text, "NAV") <= 0.6 * _rms(text, "LSQ"), text
    found = re.search(r"^NAV\s+position: RMS [\d.]+ m, p95 ([\d.]+) m", text, flags=re.M)
    assert found and float(found.group(1)) <= 2.0, text
    assert re.search(r"^decisions: booted 1, reinitialised [01],", text, flags=re.M), text


def test_a_boot_from_the_lsq_under_way_fits_the_ranges_heard_before_it(plaza,
                                                                       tmp_path) -> None:
    """Plaza1 from 600 s in, the mission written with the defaults (no start: the filter
    boots from the LSQ 8.8 s in, the robot moving) and the heading sensor 90-180° out from
    the start (``heading_offset``). The ranges heard before the boot were left out of the
    window the ranges' heading is fitted to, which answered 10 s after the boot while the
    filter dead-reckoned backwards: 1.32 m RMS, 24 m off (seeds 2, 3: 1.38, 1.35 m). With
    them it answers 1.2 s after the boot: 0.44 m."""
    from mavhelm.nav.replay import replay

    alog, mission = plaza
    plain = _as_defaults(mission)
    block = load_mission(plain).process("pNav")
    assert block is not None
    started = _from(alog, UNDER_WAY, tmp_path)
    result = replay(block, with_fault("heading_offset", read_alog(started), layout_of(block),
                                      1))
    report = "\n".join(result.report())
    fusion = result.navigator.fusion
    assert fusion is not None
    booted = next(d.t for d in fusion.decisions if "EKF booted from the LSQ" in d.why)
    turned = next(d.t for d in fusion.decisions
                  if d.why.startswith("heading taken from the ranges"))
    assert turned - booted <= 3.0, report
    assert result.accuracy().rms <= 0.6, report


def test_ranges_refused_in_a_row_say_the_filter_is_off_while_the_lsq_disagrees(
        plaza, tmp_path) -> None:
    """Plaza1 from 800 s in, the defaults' mission (booted from the LSQ 15.8 s in, under
    way) and the heading sensor read the wrong way round (``heading_reversed``): while it is
    open which of the heading and the yaw rate turns the wrong way the filter takes neither,
    and its dead reckoning ran off. The ranges of three beacons were refused in a row from
    19 s, but the filter was not found adrift while the LSQ disagreed, its re-initialisation
    left to wait for a count of fixes that never came before the sense was told at 33.4 s:
    25 m off, 2.17 m RMS. While the sense is open, found adrift at 24.8 s and re-centred on
    the LSQ: 1.23 m. (Otherwise the LSQ's re-initialisation still comes first: spec 2.2.9's
    tests in test_nav_ekf, test_nav_safety and test_nav_sim.)"""
    from mavhelm.nav.replay import replay

    alog, mission = plaza
    block = load_mission(_as_defaults(mission)).process("pNav")
    assert block is not None
    result = replay(block, with_fault("heading_reversed", read_alog(_from(alog, 800, tmp_path)),
                                      layout_of(block), 3))
    report = "\n".join(result.report())
    fusion = result.navigator.fusion
    assert fusion is not None
    booted = next(d.t for d in fusion.decisions if "EKF booted from the LSQ" in d.why)
    adrift = [d.t - booted for d in fusion.decisions if "the filter is off, not a beacon" in d.why]
    assert adrift and adrift[0] <= 12.0, report
    assert result.accuracy().rms <= 1.5, report


def test_a_misfit_no_one_beacon_explains_is_told_to_the_operator(plaza, tmp_path) -> None:
    """Plaza1 from 800 s in (the defaults' mission), beacon 0 5 m off its survey (seed 2):
    the ranges misfit the track in review after review, but leaving out beacon 0 or beacon
    5 fits as well, so none is singled out (2.34 m RMS, NEES 45) and the operator was told
    nothing. Now a NAV_WARNING says so, naming both; the recording as it is, none."""
    from mavhelm.nav.replay import replay

    alog, mission = plaza
    block = load_mission(_as_defaults(mission)).process("pNav")
    assert block is not None
    started = read_alog(_from(alog, 800, tmp_path))
    moved = replay(block, with_fault("beacon_moved", started, layout_of(block), 2))
    told = [w for w in moved.warnings if "the ranges misfit the track" in w]
    assert told and "beacons 0, 5 fits as well" in told[0], moved.warnings
    clean = replay(block, started)
    assert not [w for w in clean.warnings if "misfit" in w], clean.warnings


@pytest.mark.parametrize(("seed", "measured"), [(1, 0.40), (2, 0.75)])
def test_a_heading_drifting_180_degrees_within_two_minutes(plaza, monkeypatch, seed,
                                                           measured) -> None:
    """``heading_drift`` made faster: 180° within two minutes, through Plaza1's 100 s without
    ranges. The odometer's yaw rate carries the drift its heading integrates; taken as the
    robot's turn it turned the heading with the sensor there while the bias held (1.89 and
    1.18 m RMS, 14 m off by the gap's end). Read as the bias's drift rate (with its noise
    3e-4 rad/s/√s for 1e-4), the measured RMS below; most of what is left is that gap, where
    the drift rate itself wanders unseen."""
    from mavhelm.nav import faults
    from mavhelm.nav.replay import replay

    alog, mission = plaza
    block = load_mission(mission).process("pNav")
    assert block is not None
    monkeypatch.setattr(faults, "DRIFT_WINDOW", 120)
    result = replay(block, with_fault("heading_drift", read_alog(alog), layout_of(block),
                                      seed))
    nav = result.accuracy().rms
    assert nav <= FLOOR, result.report()
    assert nav == pytest.approx(measured, abs=0.1)


def _half_the_ranges(alog: Path) -> list:
    """Plaza1 with half its ranges, drawn at random (the same half each time): a recording
    with sparser ranging."""
    keep = np.random.default_rng(0)
    return [m for m in read_alog(alog)
            if not m.name.startswith("UWB_RANGE_") or keep.random() < 0.5]


@pytest.mark.parametrize("seed", [1, 2])
def test_a_heading_turned_from_the_start_with_half_the_ranges(plaza, seed) -> None:
    """Plaza1 with half its ranges (drawn at random) and the heading sensor 90-180° out
    from the start: the ranges tell the turn a few metres into the run, but the still part
    of their window fits any turn alike and the right one is only 2-3 times better than
    any other at first. Believed at four times, the answer came 4 s later while the robot
    dead-reckoned backwards (0.95 and 0.88 m RMS, 15 m off); at twice, 0.70 and 0.66 m."""
    from mavhelm.nav.replay import replay

    alog, mission = plaza
    block = load_mission(mission).process("pNav")
    assert block is not None
    half = _half_the_ranges(alog)
    result = replay(block, with_fault("heading_offset", half, layout_of(block), seed))
    nav = result.accuracy().rms
    print(f"\nhalf the ranges, heading_offset seed {seed}: NAV {nav:.2f} m RMS")
    assert nav <= 0.8, result.report()


def test_without_a_heading_sensor_the_ranges_give_the_heading(plaza, tmp_path) -> None:
    """The mission without the heading sensor (odometry and ranges, the heading the yaw
    rate's integral from a start nobody knows): the filter's own heading stands in for the
    readings the ranges' window fits, and the turn found is the filter's to make. Before,
    the heading was left to the EKF's linearisation from its start (σ 180°): 0.79 m RMS,
    and with one draw of range outliers (seed 2) twelve "filter is off" decisions and a
    re-initialisation in the first three minutes, 3.59 m. Now 0.58 and 0.57 m.

    Its yaw rate of the wrong sense has nothing to turn against: the track the filter's
    heading dead-reckons fits the ranges only mirrored, and the rate is then taken negated
    (found 121 s in, after the robot's first turns; 5.85 m RMS before). The mission's
    ``EKF_YAW_BIAS = true`` gave a bias state nothing reads, on which every doubt was raised
    instead of on the heading: 3.17 m with it, 1.49 m without."""
    alog, mission = plaza
    text = "".join(line for line in mission.read_text().splitlines(keepends=True)
                   if not re.match(r"\s*(SENSOR_ORIENTATION|Heading)\s*=", line))
    blind = tmp_path / "plaza1_no_heading.moos"
    blind.write_text(text)
    done = subprocess.run([sys.executable, "-m", "mavhelm.cli", "nav", "replay", str(blind),
                           str(alog), "--fault", "range_outliers", "--fault",
                           "yaw_rate_reversed", "--seed", "2", "--no-nav-log", "--jobs", "1"],
                          capture_output=True, text=True, check=False)
    assert done.returncode == 0, done.stdout + done.stderr
    clean, faulty, reversed_ = re.split(r"^== fault \w+ ==$", done.stdout, flags=re.M)
    assert "heading taken from the ranges: with no heading sensor" in clean, clean
    assert "heading bias is unobservable" not in clean  # no sensor, no bias to speak of
    assert re.search(r"^learned: speed scale", clean, flags=re.M), clean  # no bias to print
    assert _rms(clean, "NAV") <= 0.7, clean
    assert _rms(faulty, "NAV") <= FLOOR, faulty
    assert "the rate ODOM_YAW_VEL (sensor odometry) is of the wrong sense" in reversed_
    assert _rms(reversed_, "NAV") <= 2.0, reversed_
    assert "heading bias is estimated" not in done.stdout  # no sensor: no bias state


def test_a_beacon_off_its_survey_keeps_the_blame_with_half_the_ranges(plaza) -> None:
    """Plaza1 with half its ranges and beacon 0 5 m off its survey (seed 1): beacon 0 is
    singled out at 201 s; from 1101 s a stretch where beacon 5's ranges misfit a little
    (they do on the clean recording too) moved the blame onto it for 750 s, though the fit
    without beacon 0 was still 1.4-2.7 times better than with it: 1.68 m RMS, NEES 16. The
    blame now stays while the beacon blamed still misfits: 0.74 m."""
    from mavhelm.nav.replay import replay

    alog, mission = plaza
    block = load_mission(mission).process("pNav")
    assert block is not None
    half = _half_the_ranges(alog)
    result = replay(block, with_fault("beacon_moved", half, layout_of(block), 1))
    nav = result.accuracy().rms
    print(f"\nhalf the ranges, beacon_moved seed 1: NAV {nav:.2f} m RMS")
    assert nav <= FLOOR, result.report()
    blamed = [w for w in result.warnings if "it is off its survey" in w]
    assert blamed and all("beacon 0's" in w for w in blamed), blamed


def test_a_blame_laid_before_the_bearings_turned_moves_to_the_beacon_off_its_survey(
        plaza) -> None:
    """Plaza1 with beacon 6 (not the fault's own beacon 0) 5 m off its survey, seed 2:
    beacon 5 was blamed at 123 s, 43 s after the robot first moves, and kept the blame
    though from 150 s the fits without beacon 6 were up to five times better than without
    it (leaving out any good beacon of four eases a displaced one's misfit, so beacon 5's
    absence still helped): 3.43 m RMS, NEES 111. Now beacon 6 takes the blame at 197 s:
    1.00 m, the rest of it the still start, where four ranges fit the displaced beacon."""
    from dataclasses import replace

    from mavhelm.nav.replay import replay

    alog, mission = plaza
    block = load_mission(mission).process("pNav")
    assert block is not None
    layout = layout_of(block)
    six = next(b for b in layout.beacons if b.name == "6")
    moved = replace(layout, beacons=(six, *(b for b in layout.beacons if b is not six)))
    result = replay(block, with_fault("beacon_moved", read_alog(alog), moved, 2))
    nav = result.accuracy().rms
    print(f"\nbeacon 6 moved, seed 2: NAV {nav:.2f} m RMS, NEES {result.consistency()}")
    blamed = [w for w in result.warnings if "it is off its survey" in w]
    assert blamed and "beacon 6's" in blamed[-1], blamed
    assert nav <= 1.1, result.report()
    assert result.consistency().mean <= 4.0, result.report()


@pytest.mark.parametrize("seed", [1, 6])
def test_no_beacon_is_blamed_from_a_track_the_robot_hardly_moved_along(plaza, seed) -> None:
    """Plaza1 started 300 s in, beacon 0 5 m off its survey: the robot all but still for
    its first 40 s (the track made good within 11 m of its start), where leaving out any one
    of four beacons fits a near point alike; beacon 5 was singled out at 52 s from windows
    of 11-24 m and kept the blame, the displaced beacon trusted: 2.47 and 2.41 m RMS, NEES 39
    and 36. A window whose track stays under ``MIN_TRACK`` now names no beacon."""
    from mavhelm.nav.replay import replay

    alog, mission = plaza
    block = load_mission(mission).process("pNav")
    assert block is not None
    moved = with_fault("beacon_moved", read_alog(alog), layout_of(block), seed)
    started, under_way = _started_at(moved, mission, 300.0, f"plaza1_beacon_moved_{seed}")
    block = load_mission(under_way).process("pNav")
    assert block is not None
    result = replay(block, read_alog(started))
    print(f"\nfrom 300 s, beacon 0 moved, seed {seed}: NAV {result.accuracy()}, NEES "
          f"{result.consistency()}")
    blamed = [w for w in result.warnings if "it is off its survey" in w]
    assert all("beacon 0's" in w for w in blamed), blamed
    assert result.accuracy().rms <= 2.0, result.report()


def test_a_range_gap_beside_the_recordings_own_is_navigated_through(plaza) -> None:
    """Plaza1 without ranges for 60 s from 900 s in, where its own 97 s without them begins
    (the fault's gap, moved): 157 s without a range. With the mission's LSQTimeOut at 120 s
    it was a navigation failure at 1017 s and nothing was navigated after (0.49 m RMS over
    half the run); the EKF's σ grows through the gap as its error does."""
    from mavhelm.nav.replay import replay

    alog, mission = plaza
    block = load_mission(mission).process("pNav")
    assert block is not None
    messages = read_alog(alog)
    start = messages[0].time + 900.0
    gapped = [m for m in messages
              if not (m.name.startswith("UWB_RANGE_") and start <= m.time < start + 60.0)]
    assert len(gapped) < len(messages)
    result = replay(block, gapped)
    accuracy = result.accuracy()
    print(f"\n60 s more without ranges beside Plaza1's own gap: NAV {accuracy}")
    fusion = result.navigator.fusion
    assert fusion is not None and fusion.failure is None, result.report()
    assert result.tracks["NAV"].t[-1] >= messages[-1].time - 1.0, "navigated to the end"
    assert accuracy.rms <= FLOOR, result.report()
    assert result.consistency().above <= 0.05, result.report()


def _nav_error(result) -> tuple[np.ndarray, np.ndarray]:
    """NAV's ticks and its distance from the truth at each (m)."""
    track, truth = result.tracks["NAV"], result.truth
    t = np.array(track.t)
    return t, np.hypot(np.array(track.x) - np.interp(t, truth.t, truth.x),
                       np.array(track.y) - np.interp(t, truth.t, truth.y))


def test_a_beacon_far_off_its_survey_does_not_re_initialise_the_filter_through_the_lsq(
        plaza, monkeypatch) -> None:
    """Plaza1 with beacon 0 20 m off its survey (seed 1): the track singles it out at 88 s,
    but the LSQ still solved with its ranges, disagreed with the EKF by 23 m for six fixes at
    1614 s and re-initialised it there (41.8 m off, 7.37 m RMS). The LSQ now leaves out a
    beacon held off its survey while three others remain."""
    from mavhelm.nav import faults
    from mavhelm.nav.filter_safety import REINITIALISED

    alog, mission = plaza
    monkeypatch.setattr(faults, "MOVED_BY", 20.0)
    result, fusion = _replayed(mission, alog, "beacon_moved", 1)
    print(f"\nbeacon 0 20 m off, seed 1: NAV {result.accuracy()}")
    blamed = [d for d in fusion.decisions if "it is off its survey" in d.why]
    assert blamed and "beacon 0's" in blamed[0].why, result.report()
    after = [d for d in fusion.decisions if d.t > blamed[0].t and d.kind == REINITIALISED]
    assert not after, result.report()
    t, error = _nav_error(result)
    assert error[t > blamed[0].t + 60.0].max() < 5.0, result.report()


def _replayed(mission: Path, alog: Path, fault: str, seed: int):
    """Plaza1 (``alog``) replayed with ``fault`` made on it by ``mission``'s navigator: the
    result and its fusion."""
    from mavhelm.nav.replay import replay

    block = load_mission(mission).process("pNav")
    assert block is not None
    result = replay(block, with_fault(fault, read_alog(alog), layout_of(block), seed))
    assert result.navigator.fusion is not None
    return result, result.navigator.fusion


def _with_outliers(plaza, monkeypatch, share: float, seed: int):
    """Plaza1 replayed with ``share`` of its ranges 5-50 m out (``range_outliers``)."""
    from mavhelm.nav import faults

    alog, mission = plaza
    monkeypatch.setattr(faults, "OUTLIER_SHARE", share)
    return _replayed(mission, alog, "range_outliers", seed)[0]


def test_range_outliers_refused_in_runs_do_not_say_the_filter_is_off(plaza,
                                                                      monkeypatch) -> None:
    """Plaza1 with a fifth of its ranges 5-50 m out (seed 3): outliers refused three in a row
    to two beacons, of either sign and any size (``[50.5, 25.8, -34.6]``), said the filter was
    off while it was 0.06 m from the truth; widened by the 47 m refused, it took the next
    outliers and ran 49 m off (4.18 m RMS, NEES 30). A run says the filter is off only when
    its innovations agree in sign and size."""
    result = _with_outliers(plaza, monkeypatch, 0.2, 3)
    fusion = result.navigator.fusion
    assert fusion is not None
    print(f"\na fifth of the ranges outliers, seed 3: NAV {result.accuracy()}, "
          f"NEES {result.consistency()}")
    assert not [d for d in fusion.decisions if "the filter is off" in d.why], result.report()
    assert result.accuracy().rms <= FLOOR, result.report()
    assert result.consistency().mean <= 2.0, result.report()


def test_long_ranges_refused_in_runs_do_not_say_the_filter_is_off(plaza) -> None:
    """Plaza1 with a fifth of its ranges 5-50 m long (``ranges_long``, seed 3: rays round an
    obstacle, every outlier of one sign): runs such as ``[47.2, 17.8, 45.0]`` and ``[43.6,
    9.1, 43.0]`` passed the one-sign test and said the filter was off while it was 0.2 m from
    the truth; moved to the LSQ's fix of the same outliers, 54 m off, it ran 100 m off (13.1 m
    RMS, NEES 44). The ranges refused must go on from the beacon's last accepted one as
    ranges heard along a track do."""
    alog, mission = plaza
    result, fusion = _replayed(mission, alog, "ranges_long", 3)
    print(f"\na fifth of the ranges long, seed 3: NAV {result.accuracy()}, "
          f"NEES {result.consistency()}")
    assert not [d for d in fusion.decisions if "the filter is off" in d.why], result.report()
    assert result.accuracy().rms <= FLOOR, result.report()
    assert result.accuracy().max <= 15.0, result.report()
    assert result.consistency().mean <= 2.0, result.report()


def test_a_heading_read_the_wrong_way_round_is_told_through_long_ranges(plaza) -> None:
    """Plaza1 with its heading read the wrong way round and a fifth of its ranges 5-50 m
    long (seed 1): the ranges were asked which of the heading and the yaw rate turns the
    wrong way, but every outlier counted 3 σ in both fits' χ², and the track fitted only
    1.2-1.9 times better negated: the sense was told 66 s late from the courses between the
    LSQ's fixes, meanwhile the filter ran 120 m off and was re-initialised twice (12.9 m RMS,
    NEES 47). Scored on the ranges the best fit keeps, the sense is told as the question
    opens."""
    alog, mission = plaza
    result, fusion = _replayed(mission, alog, "heading_reversed+ranges_long", 1)
    print(f"\nheading reversed, a fifth of the ranges long: NAV {result.accuracy()}, "
          f"NEES {result.consistency()}")
    told = [d.t - result.start for d in fusion.decisions if "of the wrong sense" in d.why
            and "taken negated" in d.why]
    assert told and told[0] <= 70.0, result.report()
    assert not [d for d in fusion.decisions if d.kind == "reinitialised"], result.report()
    assert result.accuracy().rms <= FLOOR, result.report()
    assert result.consistency().mean <= 2.0, result.report()


def test_a_bad_range_taken_at_the_boot_is_forgotten_with_the_scale_it_taught(
        plaza, monkeypatch) -> None:
    """Plaza1 with 15 % of its ranges 5-50 m out (seed 3): one 12 m short, taken 2.7 s in at
    the still start while the position was wide, set the range scale to −9 % and carried the
    filter 11 m off. Beacon 1's good ranges were then refused in a row and the offsets
    re-opened at 34 s, but with the scale kept the ranges put the vehicle back 11 m off (for
    500 s; 2.29 m RMS, NEES 7.5). The scale is forgotten with the offsets now."""
    result = _with_outliers(plaza, monkeypatch, 0.15, 3)
    fusion = result.navigator.fusion
    assert fusion is not None
    print(f"\n15 % of the ranges outliers, seed 3: NAV {result.accuracy()}, "
          f"NEES {result.consistency()}")
    reopened = [d.t for d in fusion.decisions if "were all refused" in d.why]
    assert reopened, result.report()
    t, error = _nav_error(result)
    after = (t > reopened[0] + 5.0) & (t < reopened[0] + 60.0)
    assert error[after].max() < 2.0, result.report()
    assert result.consistency().mean <= 3.0, result.report()


def test_a_heading_turned_from_the_ranges_moves_the_position_they_fit(plaza,
                                                                       tmp_path) -> None:
    """Plaza1 from 1000 s in (the defaults' mission, booted from the LSQ under way) with its
    heading kicked 87° as the robot moved (seed 1): the ranges' fit turned the heading by 60°
    at 93 s, just short of a restart (``ALIGN_RESET``), and left the position where the kicked
    heading had dead-reckoned it, 14-19 m off; a beacon was locked out and the LSQ's
    disagreement re-initialised the filter 33 m off (3.37 m RMS; a degree further, 61°, it
    restarted: 2.23 m). The position is now moved to where the fit puts the vehicle when it
    lies beyond ``FIT_FAR`` σ of it (2.21 m)."""
    from mavhelm.nav.filter_safety import REINITIALISED
    from mavhelm.nav.replay import replay

    alog, mission = plaza
    block = load_mission(_as_defaults(mission)).process("pNav")
    assert block is not None
    result = replay(block, with_fault("heading_jumps", read_alog(_from(alog, 1000, tmp_path)),
                                      layout_of(block), 1))
    fusion = result.navigator.fusion
    assert fusion is not None
    print(f"\nfrom 1000 s, heading kicked, seed 1: NAV {result.accuracy()}")
    moved = [d.t for d in fusion.decisions if "its position moved to" in d.why]
    assert moved, result.report()
    assert not [d for d in fusion.decisions if d.kind == REINITIALISED], result.report()
    t, error = _nav_error(result)
    assert error[(t > moved[0] + 1.0) & (t < moved[0] + 20.0)].max() < 2.0, result.report()


def test_an_odometer_read_mirrored_is_righted_by_the_ranges(plaza) -> None:
    """Plaza1 with its odometry's heading and yaw rate both of the wrong sense (a clockwise
    heading and rate given as anticlockwise, seed 1): the two agree, so no heading turns
    against the rate, and only the ranges can tell. The filter was turned and re-initialised
    by them over and over (8.02 m RMS, NEES 47, 79 m at most, the LSQ 5.05 m). The track the
    headings dead-reckon fits the ranges only mirrored: both are now taken negated (found at
    114 s, the robot's first clear turns; 1.24 m, the first two minutes 5-25 m off)."""
    alog, mission = plaza
    result, fusion = _replayed(mission, alog, "heading_reversed+yaw_rate_reversed", 1)
    print(f"\nheading and yaw rate mirrored, seed 1: NAV {result.accuracy()}, NEES "
          f"{result.consistency()}")
    found = [d.t - result.start for d in fusion.decisions if "both are of the wrong sense" in d.why]
    assert len(found) == 1 and found[0] < 200.0, result.report()
    assert fusion.reversed_headings and fusion.rate_sense.reversed, result.report()
    t, error = _nav_error(result)
    assert np.sqrt(np.mean(error[t - result.start > found[0] + 60.0] ** 2)) <= FLOOR
    assert result.accuracy().rms <= 1.5 and result.consistency().mean <= 3.0, result.report()


def test_ranges_refused_while_the_lsq_disagrees_ask_the_ranges_for_the_heading(plaza) -> None:
    """Half of Plaza1's ranges, its odometry's heading and rate both of the wrong sense
    (seed 43): from 111 s the filter ran off along a mirror image of the track (97 m at
    most), two beacons' ranges refused in a row. That says "the filter is off", but while
    the LSQ already disagrees the re-initialisation is awaited instead, and with half the
    ranges its six fixes in a row took 40 s (151 s; 12.2 m RMS, the mirror found after it).
    The ranges are now asked for the heading meanwhile: the mirror is found at 132 s, no
    re-initialisation (4.77 m)."""
    from mavhelm.nav.filter_safety import REINITIALISED
    from mavhelm.nav.replay import replay

    alog, mission = plaza
    block = load_mission(mission).process("pNav")
    assert block is not None
    result = replay(block, with_fault("heading_reversed+yaw_rate_reversed",
                                      _half_the_ranges(alog), layout_of(block), 43))
    fusion = result.navigator.fusion
    assert fusion is not None
    print(f"\nhalf the ranges, heading and rate mirrored, seed 43: NAV {result.accuracy()}")
    found = [d.t - result.start for d in fusion.decisions if "both are of the wrong sense" in d.why]
    assert found and found[0] < 140.0, result.report()
    assert not [d for d in fusion.decisions if d.kind == REINITIALISED], result.report()
    t, error = _nav_error(result)
    assert error[t - result.start > found[0] + 20.0].max() < 5.0, result.report()


def test_which_of_a_heading_and_a_rate_is_reversed_is_told_through_range_outliers(
        plaza) -> None:
    """The defaults' mission, Plaza1's odometry yaw rate reversed and 5 % of its ranges out
    (seed 2): the rate turns against the heading at 53 s and the ranges are asked which of
    the two is wrong. The outliers (each counted at most 3 σ) raised both fits' χ², and the
    track fitted the ranges 2-2.9 times better as read than negated for a minute without
    reaching the 3 times asked: told at 123 s, while the filter took neither (2.25 m RMS).
    One of the two being known wrong, 2 times now tells it: at 65 s (0.55 m)."""
    alog, mission = plaza
    result, fusion = _replayed(_as_defaults(mission), alog, "yaw_rate_reversed+range_outliers",
                               2)
    print(f"\nrate reversed, range outliers, seed 2: NAV {result.accuracy()}")
    told = [d.t - result.start for d in fusion.decisions
            if "is the one of the wrong sense, taken negated" in d.why]
    assert len(told) == 1 and told[0] < 80.0, result.report()
    assert "the heading is the one" not in " ".join(d.why for d in fusion.decisions)
    assert result.accuracy().rms <= FLOOR and result.consistency().mean <= 2.0, result.report()


def test_long_ranges_before_the_boot_do_not_fail_the_navigation(plaza, monkeypatch) -> None:
    """A third of Plaza1's ranges 5-50 m long (multipath; ``ranges_long`` at 30 %, seed 3)
    on a mission written with the defaults, which boots from the LSQ: four of its first nine
    fixes were strays 25-51 m off that passed its own test, each broke the stream of
    repeatable fixes before its third, and at 52 s the LSQ's median shift failed the
    navigation (spec 2.2.11) though five fixes lay within 2 m of each other. One stray held
    aside, the stream goes on: booted at 19 s."""
    from mavhelm.nav import faults
    from mavhelm.nav.filter_safety import BOOTED

    alog, mission = plaza
    monkeypatch.setattr(faults, "LONG_SHARE", 0.3)
    result, fusion = _replayed(_as_defaults(mission), alog, "ranges_long", 3)
    assert result.failure is None, result.report()
    boots = [d for d in fusion.decisions if d.kind == BOOTED]
    assert len(boots) == 1 and boots[0].t - result.start < 25.0, boots
    assert "1 stray fix off the stream set aside" in boots[0].why
    assert result.accuracy().rms <= FLOOR, result.report()
