"""Every setting safe at its extremes: paths, file-name stems, instrument names, noises and σ.

Each class is refused at load with ``file:line: reason``, or handled at run time with a
message that names the setting (never a traceback, never the wrong cause).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mavhelm import cli
from mavhelm.companion.companion import Companion, Plan
from mavhelm.core.bus import Bus
from mavhelm.core.clock import SimClock
from mavhelm.core.errors import SettingError
from mavhelm.core.mission import MissionError, parse_mission
from mavhelm.core.names import POSTED_FAMILIES
from mavhelm.nav.ekf import EKF, Beacon, EKFConfig, Position, Range
from mavhelm.nav.fusion import Fusion, FusionConfig, Start
from mavhelm.nav.navigator import NAV_SCHEMA, Navigator
from mavhelm.nav.sensors import NOISE_MIN, SENSOR_TYPES, SensorSpec
from mavhelm.nav.settings import EKF_GATE, EKF_SIGMA_XY

DEMO = (Path(__file__).resolve().parents[1] / "examples" / "demo.moos").read_text()


def mission(tmp_path: Path, extra: str = "", pnav: str = "", name: str = "m.moos") -> Path:
    """The demo with ``extra`` blocks appended and ``pnav`` lines at the top of its pNav."""
    text = DEMO.replace("ProcessConfig = pNav\n{\n", f"ProcessConfig = pNav\n{{\n{pnav}", 1)
    path = tmp_path / name
    path.write_text(text + extra)
    return path


def refusal(path: Path) -> str:
    with pytest.raises(MissionError) as err:
        Plan.from_mission(path, SimClock())
    assert str(err.value).startswith(f"{path}:{err.value.line}: ") and err.value.line > 0
    return err.value.reason


def pnav_line(path: Path, key: str) -> int:
    return next(i for i, line in enumerate(path.read_text().splitlines(), 1)
                if line.strip().startswith(key))


# ---------------------------------------------------------------------------- paths and stems

FOLDERS = ["/dev/null", "/dev/null/logs", "{file}", "{file}/below", "a\x00b", "x" * 300,
           "a\x1bb"]


@pytest.mark.parametrize("folder", FOLDERS)
def test_a_log_folder_that_is_a_file_a_device_or_nonsense_is_refused_at_load(folder, tmp_path):
    existing = tmp_path / "a_file"
    existing.write_text("")
    folder = folder.format(file=existing)
    for extra, pnav, key in (
            (f"\nProcessConfig = pLogger\n{{\n    LogDir = {folder}\n}}\n", "", "LogDir"),
            ("", f"    NAV_LOG_PATH = {folder}\n", "NAV_LOG_PATH")):
        path = mission(tmp_path, extra, pnav)
        reason = refusal(path)
        assert reason.startswith(key), reason
        assert "\x00" not in reason and "\x1b" not in reason


def test_a_log_folder_that_does_not_exist_yet_is_accepted(tmp_path):
    path = mission(tmp_path, "", f"    NAV_LOG_PATH = {tmp_path / 'new' / 'logs'}\n")
    Plan.from_mission(path, SimClock())


@pytest.mark.parametrize("stem", ["x" * 201, "a b", "..", "a/b", ""])
def test_a_nav_log_stem_that_cannot_be_a_file_name_is_refused(stem, tmp_path):
    path = mission(tmp_path, "", f"    NAV_LOG_STEM = {stem}\n")
    assert refusal(path).startswith("NAV_LOG_STEM")


def test_the_longest_stem_leaves_room_for_the_time_stamp_and_suffix(tmp_path):
    from mavhelm.companion.navlog import NavLogFiles

    logs = NavLogFiles(tmp_path, "x" * 200, timestamp=True, opened_on=0.0)
    logs.olog(["0 a"])
    logs.close()
    assert logs.olog_path.exists()


def test_every_path_setting_of_every_schema_is_a_path_kind():
    from mavhelm.companion.alog import LOGGER_SCHEMA
    from mavhelm.core.params import FileStem, PathName
    from mavhelm.tasks.helm import HELM_SCHEMA

    kinds = {p.name: type(p.kind) for s in (LOGGER_SCHEMA, NAV_SCHEMA, HELM_SCHEMA)
             for p in s.params}
    assert kinds["LogDir"] is PathName and kinds["NAV_LOG_PATH"] is PathName
    assert kinds["TaskFile"] is PathName and kinds["NAV_LOG_STEM"] is FileStem


def test_a_log_that_cannot_be_opened_at_run_time_names_its_setting(tmp_path):
    blocker = tmp_path / "blocker"
    blocker.write_text("")
    path = mission(tmp_path)
    with pytest.raises(SettingError, match=r"pLogger LogDir"):
        Companion.build(path, SimClock(), alog_path=blocker / "m.alog")


def test_mavhelm_run_says_which_log_cannot_open_not_the_autopilot_link(tmp_path, capsys):
    blocker = tmp_path / "blocker"
    blocker.write_text("")
    path = mission(tmp_path)
    code = cli.main(["run", str(path), "--log-dir", str(blocker / "logs"),
                     "--connect", "tcp:127.0.0.1:9"])
    err = capsys.readouterr().err
    assert code == 2
    assert "--log-dir" in err and "autopilot link" not in err and "Traceback" not in err


# ---------------------------------------------------------------------------- instrument names

def instrument(name: str) -> str:
    return (f"\nProcessConfig = iSerial_X\n{{\n    Name = {name}\n    Port = /dev/ttyUSB9\n"
            "    Sentences = GGA\n}\n")


@pytest.mark.parametrize("name", [*POSTED_FAMILIES, "ekf", "Wheel", "NAV_X", "EKF_SIGMA"])
def test_an_instrument_named_after_a_posted_family_is_refused(name, tmp_path):
    path = mission(tmp_path, instrument(name))
    reason = refusal(path)
    assert reason.startswith(f"Name = {name}: ") and "posted by another app" in reason


def test_an_instrument_with_a_name_of_its_own_loads(tmp_path):
    plan = Plan.from_mission(mission(tmp_path, instrument("SGPS")), SimClock())
    assert [i.prefix for i in plan.instruments] == ["SGPS"]


# ---------------------------------------------------------------------------- noise and σ

@pytest.mark.parametrize("kind", SENSOR_TYPES)
def test_a_sensor_noise_below_its_physical_minimum_is_refused(kind, tmp_path):
    beacon = "    BEACON = 1 @ 0,50,0\n" if kind in ("LBL", "RANGE") else ""
    lowest = NOISE_MIN[kind][0]
    ok = mission(tmp_path, "", f"    SENSOR_{kind} = S -> s ~ {lowest}\n{beacon}", "ok.moos")
    Plan.from_mission(ok, SimClock())
    path = mission(tmp_path, "", f"    SENSOR_{kind} = S -> s ~ 1e-12\n{beacon}")
    assert refusal(path).startswith(f"SENSOR_{kind} noise must be a number in [{lowest:g}, ")


@pytest.mark.parametrize("line", ["FIXEDDEPTH = 0 @ 1e-12", "FIXEDHEADING = 0 @ 1e-9",
                                  "FIXEDTIDE = 0 @ 0", "FIXEDSIDESLIP = 0 @ 1e-6",
                                  "EKF_SIGMA_XY = 1e-9", "EKF_SIGMA_HEADING = 1e-9",
                                  "EKF_SIGMA_Z = 1e-9"])
def test_a_fixed_or_start_sigma_below_its_physical_minimum_is_refused(line, tmp_path):
    path = mission(tmp_path, "", f"    SENSOR_XY = GPS -> gps\n    {line}\n")
    assert refusal(path).startswith(line.split()[0])


def test_the_reported_tiny_gps_noise_beside_ranges_is_refused_where_it_is(tmp_path):
    pnav = ("    SENSOR_XY = GPS -> gps ~ 1e-12\n    SENSOR_RANGE = RNG -> uwb ~ 0.3\n"
            "    BEACON = 1 @ 0,50,0\n")
    path = mission(tmp_path, "", pnav)
    with pytest.raises(MissionError) as err:
        Plan.from_mission(path, SimClock())
    assert err.value.line == pnav_line(path, "SENSOR_XY")


def test_the_filter_survives_an_observation_far_finer_than_its_prior():
    """Below the declared minimums (a config built in code): no exception, a re-initialisation
    and a warning each time the covariance breaks, and never a non-finite estimate."""
    ekf = EKF(0.0, 0.0, 0.0, beacons=[Beacon("1", 50, 0), Beacon("2", 0, 50)])
    for k in range(40):
        t = 0.5 * k
        ekf.advance(t)
        ekf.update([Position(t, 1.0, 2.0, 1e-12), Range(t, "1", 49.0), Range(t, "2", 48.0)])
        e = ekf.estimate()
        assert all(math.isfinite(v) for v in (e.x, e.y, e.sigma_x, e.sigma_y, e.sigma_yaw))
        assert (np.diag(ekf.P) >= 0).all()
    assert ekf.recoveries > 0
    assert any("re-initialised" in w for w in ekf.warnings)


def test_a_numerical_failure_in_the_filter_restarts_it_and_never_escapes_the_tick():
    fusion = Fusion(FusionConfig(start=Start(0.0, 0.0)))
    fusion.step(0.0)
    assert fusion.ekf is not None

    def broken(*_args, **_kwargs):
        raise np.linalg.LinAlgError("Singular matrix")

    fusion.ekf.advance = broken  # type: ignore[method-assign]
    assert fusion.step(1.0) is None
    assert any("numerical failure" in w for w in fusion.warnings)
    assert fusion.step(2.0) is not None  # booted again from the start


def test_the_navigator_ticks_through_a_sensor_claiming_zero_noise():
    """A navigator built in code with a sensor the parser would refuse (1e-12 m GPS beside a
    range sensor): every tick completes and nothing non-finite is posted."""
    bus = Bus(SimClock(0.0))
    text = ("ProcessConfig = pNav\n{\n X = EKF @ 2\n Y = EKF @ 2\n"
            " SENSOR_XY = GPS -> gps\n SENSOR_RANGE = RNG -> uwb ~ 0.3\n"
            " BEACON = 1 @ 50,0,0\n BEACON = 2 @ 0,50,0\n BEACON = 3 @ -50,0,0\n}\n")
    nav = Navigator.from_mission(bus, parse_mission(text, "t.moos"))
    assert nav.reader is not None
    nav.reader.sensors[0] = SensorSpec("XY", "GPS", "gps", noise=(1e-12,))
    nav.reader.__init__(nav.reader.sensors, nav.reader.beacons.values())
    bus.subscribe(nav.name, nav.subscriptions())
    bus.subscribe("listener", ["*"])
    for k in range(60):
        now = 0.5 * k
        bus.clock.set(now)  # type: ignore[attr-defined]
        bus.notify("GPS_X", 1.0 + 0.01 * k, "iMAVLink", now)
        bus.notify("GPS_Y", 2.0, "iMAVLink", now)
        for b, (bx, by) in (("1", (50, 0)), ("2", (0, 50)), ("3", (-50, 0))):
            bus.notify(f"RNG_RANGE_{b}", math.hypot(bx - 1.0, by - 2.0), "iSerial", now)
        nav.on_mail(bus.fetch(nav.name), now)
        nav.iterate(now)
        for m in bus.fetch("listener"):
            if m.is_double:
                assert math.isfinite(m.double), m


# ---------------------------------------------------------------------------- one declaration

def test_a_config_built_in_code_is_held_to_the_declared_ranges():
    with pytest.raises(ValueError, match="EKF_GATE"):
        EKFConfig(gate_probability=0.6)  # inside the old second check (0.5, 1), not declared
    with pytest.raises(ValueError, match="EKF_SIGMA_XY"):
        EKFConfig(sigma_xy=1e-6)
    assert EKFConfig().gate_probability == EKF_GATE.default
    assert EKFConfig().sigma_xy == EKF_SIGMA_XY.default
    assert math.isclose(EKFConfig().sigma_yaw, math.radians(90.0))
    with pytest.raises(ValueError, match="LSQ_WINDOW"):
        FusionConfig(lsq_window=0.1)


def test_every_ekf_key_the_nav_docstrings_name_is_a_setting():
    import re

    import mavhelm.nav.ekf as ekf_module

    known = {p.name for p in NAV_SCHEMA.params}
    texts = (ekf_module.__doc__ or "") + (EKFConfig.__doc__ or "")
    named = set(re.findall(r"\bEKF_[A-Z_]*[A-Z]\b", texts))
    assert named and named <= known, named - known
