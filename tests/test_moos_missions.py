"""Missions written the MOOS way (issue 16, section 1): the boilerplate and other processes'
blocks are accepted and said once, the original keywords are honoured or refused with why,
SENSOR sources name MOOS processes, and `mavhelm convert` says what each line maps to."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from mavhelm.companion.companion import Companion, Plan
from mavhelm.companion.console import BusEvents
from mavhelm.companion.moos import NOTE_VARIABLE, convert, mission_notes
from mavhelm.companion.status import Alert, Severity
from mavhelm.core.bus import Message
from mavhelm.core.clock import SimClock
from mavhelm.core.mission import MissionError, load_mission, parse_mission
from mavhelm.nav.sensor_channel import LSQ_REJECTION, RejectionRule
from mavhelm.nav.sensor_watch import SensorWatch
from mavhelm.nav.sensors import SensorSpec

ROOT = Path(__file__).resolve().parents[1]
MOOS = ROOT / "examples" / "moos"
FILES = sorted(MOOS.glob("*.moos"))


def _plan(text: str, tmp_path: Path) -> Plan:
    path = tmp_path / "m.moos"
    path.write_text(text)
    return Plan.from_mission(path, SimClock())


def _with(lines: str, where: str = "pNav") -> str:
    """The tasks example with ``lines`` added at the top of block ``where``."""
    text = (MOOS / "tasks.moos").read_text()
    head = f"ProcessConfig = {where}\n{{\n"
    assert head in text
    return text.replace(head, head + lines + "\n", 1)


def test_there_is_one_example_per_block_kind():
    assert [f.name for f in FILES] == ["mission.moos", "pnav.moos", "tasks.moos"]


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_every_moos_example_loads_as_it_is(path):
    plan = Plan.from_mission(path, SimClock())
    assert plan.helm.tasks


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_convert_says_what_every_line_maps_to(path):
    mission = load_mission(path)
    lines = convert(mission)
    said = {int(line.split(":")[1]) for line in lines}
    for number, raw in enumerate(path.read_text().splitlines(), start=1):
        text = raw.split("//")[0].strip()
        if text and text not in ("{", "}", "[", "]"):
            assert number in said, f"{path.name}:{number} {text!r} is not converted"
    assert not [line for line in lines if "REFUSED" in line]


def test_the_boilerplate_is_said_once_with_why():
    notes = mission_notes(load_mission(MOOS / "mission.moos"))
    text = "\n".join(notes)
    for key in ("ServerHost", "ServerPort", "Community", "Simulator", "MOOSTimeWarp",
                "pNav AppTick", "pHelm CommsTick"):
        assert text.count(key) == 1, key
    assert "ServerHost, ServerPort, pLogger CommsTick, pNav CommsTick, pHelm CommsTick: " \
           "no MOOSDB: mavhelm runs its own bus inside one process" in notes
    assert any(n.startswith("ProcessConfig = ANTLER (line 17): not run;") for n in notes)
    assert any(n.startswith("ProcessConfig = iGPS (line 40): not run;") for n in notes)
    assert "pHelm AppTick" not in text, "pHelm's AppTick is its own setting, honoured"


def test_the_notes_reach_the_console_once_as_notices():
    lines: list[str] = []
    companion = Companion.build(MOOS / "mission.moos", SimClock(), echo=lines.append)
    companion.bus.subscribe("test", {NOTE_VARIABLE})
    for t in (0.1, 0.2, 0.3):
        companion.tick(t)
        companion.idle()
    posted = [m.string for m in companion.bus.fetch("test")]
    companion.close()
    assert posted == mission_notes(companion.mission)
    for note in posted:
        assert sum(line.endswith(f"{NOTE_VARIABLE}: {note}") for line in lines) == 1, note


def test_a_moos_key_mavhelm_cannot_honour_is_refused_with_why(tmp_path):
    text = _with("    USETOPDOWN = TRUE")
    with pytest.raises(MissionError) as err:
        _plan(text, tmp_path)
    assert err.value.reason == ("USETOPDOWN is not supported by mavhelm: mavhelm has no "
                                "top-down calibration engine")
    text = _with("    PIDLOGPATH = /tmp", "pHelm")
    with pytest.raises(MissionError) as err:
        _plan(text, tmp_path)
    assert err.value.reason.startswith("PIDLOGPATH is not supported by mavhelm: a task's "
                                       "LOGPID = true posts")


def test_an_unknown_key_is_still_refused_with_its_line(tmp_path):
    text = _with("    UseTopDownn = TRUE")
    with pytest.raises(MissionError) as err:
        _plan(text, tmp_path)
    assert err.value.line == 16
    assert err.value.reason.startswith("unknown setting 'UseTopDownn' for pNav")
    assert "USETOPDOWN" not in err.value.reason, "a refused key is not offered as known"


def test_two_spellings_of_one_setting_must_agree(tmp_path):
    plan = _plan(_with("    EKF_SIGMA_XX = 12\n    EKF_SIGMA_YY = 12\n"
                       "    SENSOR_XY = iGPS -> g @ 0,0,0"), tmp_path)
    assert plan.navigator.fusion is not None
    assert plan.navigator.fusion.config.ekf.sigma_xy == 12.0
    with pytest.raises(MissionError) as err:
        _plan(_with("    EKF_SIGMA_XX = 12\n    EKF_SIGMA_YY = 20"), tmp_path)
    assert err.value.line == 17
    assert err.value.reason == ("EKF_SIGMA_YY disagrees with EKF_SIGMA_XX at line 16: both set "
                                "EKF_SIGMA_XY, which mavhelm holds once; give them one value")


def test_original_task_keywords_set_mavhelms_settings():
    plan = Plan.from_mission(MOOS / "tasks.moos", SimClock())
    assert plan.helm.task("Line").p2[:2] == (150.0, 50.0)
    assert plan.helm.task("Circle").sides == 6
    assert plan.helm.task("Shallows").min_altitude == 2.0
    assert plan.helm.task("SteerDrive").heading_tolerance == 10.0


def test_sensor_sources_name_moos_processes():
    plan = Plan.from_mission(MOOS / "pnav.moos", SimClock())
    subs = plan.navigator.subscriptions()
    assert {"GPS_X", "GPS_Y", "INS_YAW", "LBL_TWTT_1"} <= subs
    assert not any(s.startswith(("IGPS_", "ICOMPASS_", "ISERIAL")) for s in subs)
    assert plan.navigator.always_read == {"LBL_TWTT_1"}


def test_lsq_rejection_reads_the_original_syntax():
    block = parse_mission("X = 1\nProcessConfig = pNav\n{\n"
                          "  LSQ_REJECTION = TheAvtrak : History = 5, Fail = 0.001\n"
                          "  LSQ_REJECTION = TheAvtrak @ 5, 0.001\n}\n", "m.moos")
    a, b = (LSQ_REJECTION.kind.parse(e) for e in block.processes["pNav"].entries)
    assert a == b == RejectionRule("TheAvtrak", 5, 0.001)
    bad = parse_mission("ProcessConfig = pNav\n{\n  LSQ_REJECTION = T : History = 5\n}\n",
                        "m.moos").processes["pNav"].entries[0]
    with pytest.raises(MissionError):
        LSQ_REJECTION.kind.parse(bad)


def test_the_acoustics_block_gives_pnav_its_beacons_by_reply_channel():
    plan = Plan.from_mission(MOOS / "pnav.moos", SimClock())
    assert plan.navigator.fusion is not None
    beacons = {b.name: (b.x, b.y, b.z, b.turnaround) for b in plan.navigator.fusion.config.beacons}
    assert beacons == {"1": (0.0, 200.0, -30.0, 0.125), "2": (200.0, 0.0, -30.0, 0.125),
                       "3": (0.0, 0.0, -30.0, 0.125)}


@pytest.mark.parametrize(("body", "line", "reason"), [
    ("  POS = 0,0,-30\n", 3, "POS comes before any Beacon = name"),
    ("  Beacon = A\n  [\n  POS = 0,0,-30\n  ]\n", 3, "Beacon A needs TX"),
    ("  Beacon = A\n  [\n  POS = 0,0,-30\n  TX = CHX\n  ]\n", 6,
     "TX (the reply channel, CHn) expects a whole number in [1, 999], got 'X'"),
    ("  Beacon = A\n  [\n  POS = 0,0,-30\n  TX = CH1\n  Depth = 3\n  ]\n", 7,
     "unknown setting 'Depth' for the Acoustics block (known: Beacon = name, then POS, TX and "
     "TAT)"),
])
def test_a_wrong_acoustics_block_is_refused_where_it_is(tmp_path, body, line, reason):
    text = (MOOS / "pnav.moos").read_text()
    start = text.index("ProcessConfig = Acoustics")
    end = text.index("ProcessConfig = pNav")
    text = text[:start] + "ProcessConfig = Acoustics\n{\n" + body + "}\n\n" + text[end:]
    offset = text[:start].count("\n")
    with pytest.raises(MissionError) as err:
        _plan(text, tmp_path)
    assert (err.value.line - offset, err.value.reason) == (line, reason)


def test_a_bracket_outside_the_acoustics_block_is_refused(tmp_path):
    with pytest.raises(MissionError) as err:
        _plan(_with("    ["), tmp_path)
    assert err.value.line == 16
    assert err.value.reason.startswith("a '[' line belongs only in the Acoustics block")


def test_global_log_path_is_where_the_logs_go_without_a_logdir(tmp_path):
    from mavhelm.companion.alog import log_dir

    text = "GlobalLogPath = /data/moos\n" + (MOOS / "tasks.moos").read_text()
    assert log_dir(parse_mission(text, str(tmp_path / "m.moos"))) == "/data/moos"
    text += "ProcessConfig = pLogger\n{\n  PATH = /data/here\n}\n"
    assert log_dir(parse_mission(text, str(tmp_path / "m.moos"))) == "/data/here"


def _spec(name: str = "TheGPS") -> SensorSpec:
    return SensorSpec("XY", "GPS", name)


def test_a_silent_sensor_warns_once_after_the_helm_goes_online():
    watch = SensorWatch([_spec()], 10.0, {"TheGPS": "iGPS is the autopilot's GPS"})
    assert watch.warnings(100.0) == [], "offline: nothing said"
    watch.heard([("HELM_ONLINE", 1.0)], 5.0)
    assert watch.warnings(14.9) == []
    [line] = watch.warnings(15.0)
    assert line == ("sensor TheGPS (SENSOR_XY) has had no data for 10 s with the helm online: "
                    "waiting for GPS_X, GPS_Y; iGPS is the autopilot's GPS")
    assert watch.warnings(30.0) == [], "said once"
    watch.heard([("GPS_X", 1.0)], 31.0)
    assert watch.warnings(40.0) == []
    assert len(watch.warnings(41.0)) == 1, "silent again"


def test_a_sensor_with_data_or_a_watch_set_to_never_stays_quiet():
    watch = SensorWatch([_spec()], 10.0)
    watch.heard([("HELM_ONLINE", 1.0), ("GPS_Y", 3.0)], 0.0)
    for t in range(1, 30):
        watch.heard([("GPS_X", 1.0)], float(t))
        assert watch.warnings(float(t)) == []
    never = SensorWatch([_spec()], None)
    never.heard([("HELM_ONLINE", 1.0)], 0.0)
    assert never.warnings(1e6) == []


def test_the_navigator_posts_the_silence_as_a_nav_warning():
    plan = Plan.from_mission(MOOS / "mission.moos", SimClock())
    nav, bus = plan.navigator, plan.bus
    bus.subscribe("test", {"NAV_WARNING"})
    bus.subscribe(nav.name, nav.subscriptions())
    bus.notify("HELM_ONLINE", 1.0, "iMAVLink")
    nav.on_mail(bus.fetch(nav.name), 0.0)
    nav.iterate(0.0)
    nav.iterate(10.0)
    warnings = [m.string for m in bus.fetch("test")]
    assert any(w.startswith("sensor TheGPS (SENSOR_XY) has had no data for 10 s") and
               "iGPS is the autopilot's GPS over MAVLink" in w for w in warnings), warnings


def test_mavhelm_convert_prints_the_mapping_and_whether_it_loads():
    out = subprocess.run([sys.executable, "-m", "mavhelm.cli", "convert",
                          str(MOOS / "pnav.moos")], capture_output=True, text=True,
                         cwd=ROOT, timeout=60)
    assert out.returncode == 0, out.stderr
    assert "SV = 1498 -> honoured as LBL_SOUND_SPEED (m/s)" in out.stdout
    assert "note: pNav AppTick: every app of mavhelm ticks together" in out.stdout
    assert out.stdout.rstrip().endswith("pnav.moos: loads as it is")


def test_a_note_is_a_notice_on_the_status_channel():
    event = BusEvents().of(Message(NOTE_VARIABLE, "x: y", 0.0, "mavhelm"))
    assert event == Alert(NOTE_VARIABLE, "x: y", Severity.NOTICE)


@pytest.mark.slow
def test_the_moos_mission_flies_in_the_demo_unchanged():
    from mavhelm.demo.harness import SimulatedRun

    flags = ("Go", "ToLine", "ToOrbit", "ToPattern", "EndMission")
    with SimulatedRun.start(MOOS / "mission.moos",
                            record={*flags, "TASK_ENDED", "MISSION_ENDED", "NAV_WARNING",
                                    NOTE_VARIABLE}) as run:
        assert run.run_mission(max_time=900.0), "EndMission never went active"
        ended = dict(m.string.split(":") for m in run.values("TASK_ENDED"))
        assert ended == {"InitialDelay": "timeout", "FirstMark": "complete",
                         "Leg": "complete", "Circle": "complete", "Home": "complete"}, ended
        assert run.values("MISSION_ENDED")[0].string == "AllStop"
        assert len(run.values(NOTE_VARIABLE)) == len(mission_notes(load_mission(
            MOOS / "mission.moos")))
        silent = [m.string for m in run.values("NAV_WARNING") if "has had no data" in m.string]
        assert silent == [], "iGPS and iCompass reach the filter"


def test_an_original_task_type_mavhelm_lacks_is_refused_with_why(tmp_path):
    text = (MOOS / "tasks.moos").read_text().replace(
        "    Task = Timer\n", "    Task = SeabedTrack\n    {\n        Altitude = 5\n    }\n\n"
        "    Task = Timer\n", 1)
    with pytest.raises(MissionError) as err:
        _plan(text, tmp_path)
    assert err.value.reason == ("task type SeabedTrack is not supported by mavhelm: holding an "
                                "altitude above the seabed is not supported; LimitAltitude "
                                "watches it")


def test_ekf_tide_as_the_original_wrote_it_is_refused_with_the_difference(tmp_path):
    with pytest.raises(MissionError) as err:
        _plan(_with("    EKF_TIDE = 1.5"), tmp_path)
    assert err.value.reason.startswith("EKF_TIDE expects true or false, got 1.5: in the "
                                       "original pNav EKF_TIDE is the start tide in metres")


def test_mavhelm_convert_says_why_a_mission_would_be_refused(tmp_path):
    path = tmp_path / "m.moos"
    path.write_text(_with("    USETOPDOWN = TRUE"))
    out = subprocess.run([sys.executable, "-m", "mavhelm.cli", "convert", str(path)],
                         capture_output=True, text=True, cwd=ROOT, timeout=60)
    assert out.returncode == 1, out.stderr
    assert (f"{path}:16: USETOPDOWN = TRUE -> REFUSED: USETOPDOWN is not supported by mavhelm: "
            "mavhelm has no top-down calibration engine") in out.stdout
    assert out.stdout.rstrip().endswith(f"mavhelm would refuse this mission: {path}:16: "
                                        "USETOPDOWN is not supported by mavhelm: mavhelm has no "
                                        "top-down calibration engine")


@pytest.mark.slow
def test_the_demo_says_what_it_does_not_use(tmp_path):
    from mavhelm.demo import run_demo

    lines: list[str] = []
    result = run_demo(MOOS / "mission.moos", tmp_path, echo=lines.append)
    assert result.ended
    notes = mission_notes(load_mission(MOOS / "mission.moos"))
    assert [line for line in lines if line.startswith("  not used: ")] == [
        f"  not used: {note}" for note in notes]
