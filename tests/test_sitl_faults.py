"""Fault scenario files: parsing, windows, selectors, errors with file:line, seeded streams."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from mavhelm.sitl.faults import FAULT_KINDS, INSTANT_S, Fault, Scenario, ScenarioError

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "scenarios"

TEXT = """\
# a comment line
// another comment style
seed = 42
name = harbour
gps_outage from 120 to 180          # trailing comment
gps_jump at 300 dx=25 dy=-10        // trailing comment
gps_jump at 400 for 5 dx=1 dy=2
range_outlier from 0 to 600 prob=0.05 sigma=30 beacon=2
compass_bias from 50 deg=-3.5
link_drop always link=1
sensor_latency from 10 for 20 sensor=dvl delay=0.4 jitter=0.1
"""


def test_parse_every_window_form() -> None:
    s = Scenario.from_text(TEXT)
    assert s.seed == 42
    assert s.name == "harbour"
    kinds = [f.kind for f in s.faults]
    assert kinds == [
        "gps_outage",
        "gps_jump",
        "gps_jump",
        "range_outlier",
        "compass_bias",
        "link_drop",
        "sensor_latency",
    ]
    outage, jump, jump5, outlier, bias, drop, lat = s.faults
    assert (outage.start, outage.end) == (120.0, 180.0)
    assert (jump.start, jump.end) == (300.0, 300.0 + INSTANT_S)
    assert jump.params == {"dx": 25.0, "dy": -10.0}
    assert (jump5.start, jump5.end) == (400.0, 405.0)
    assert outlier.params == {"prob": 0.05, "sigma": 30.0, "beacon": "2"}
    assert bias.start == 50.0 and math.isinf(bias.end) and bias.num("deg") == -3.5
    assert drop.start == 0.0 and math.isinf(drop.end) and drop.num("link") == 1.0
    assert (lat.start, lat.end) == (10.0, 30.0)
    assert lat.params["sensor"] == "dvl" and lat.num("jitter") == pytest.approx(0.1)


def test_active_window_is_half_open() -> None:
    s = Scenario.from_text(TEXT)
    assert s.active("gps_outage", 119.999) == []
    assert len(s.active("gps_outage", 120.0)) == 1
    assert len(s.active("gps_outage", 179.999)) == 1
    assert s.active("gps_outage", 180.0) == []
    assert [f.params["dx"] for f in s.active("gps_jump", 300.5)] == [25.0]
    assert s.active("gps_jump", 301.0) == []
    assert s.active("link_drop", 1e9)  # always
    with pytest.raises(KeyError):
        s.active("gps_outag", 1.0)


def test_selector_matching_by_name_and_number() -> None:
    s = Scenario.from_text(TEXT)
    assert s.active_matching("range_outlier", 1.0, beacon=2)
    assert s.active_matching("range_outlier", 1.0, beacon="2")
    assert s.active_matching("range_outlier", 1.0, beacon="3") == []
    assert s.active_matching("link_drop", 1.0, link=1)
    assert s.active_matching("link_drop", 1.0, link=0) == []
    # a fault that names no beacon applies to every beacon
    s2 = Scenario.from_text("range_outlier always prob=1 sigma=1")
    assert s2.active_matching("range_outlier", 0.0, beacon="7")


def test_defaults_seed_zero_and_file_stem_name(tmp_path: Path) -> None:
    p = tmp_path / "quiet_day.scn"
    p.write_text("gps_outage from 1 to 2\n")
    s = Scenario.from_file(p)
    assert s.seed == 0 and s.name == "quiet_day" and len(s.faults) == 1
    assert Scenario().faults == [] and Scenario().seed == 0


def test_examples_parse() -> None:
    files = sorted(EXAMPLES.glob("*.scn"))
    assert len(files) >= 2
    for f in files:
        s = Scenario.from_file(f)
        assert s.faults, f
        serial = [x for x in s.faults if FAULT_KINDS[x.kind].side in ("serial", "both")]
        mav = [x for x in s.faults if FAULT_KINDS[x.kind].side in ("mavlink", "both")]
        assert serial and mav, f"{f} should exercise both sides"


@pytest.mark.parametrize(
    ("line", "reason"),
    [
        ("gps_outgae from 1 to 2", "unknown fault kind 'gps_outgae'"),
        ("gps_jump at 3 dx=1", "gps_jump needs dy"),
        ("gps_jump at 3 dx=1 dy=zero", "dy: 'zero' is not a number"),
        ("gps_jump at three dx=1 dy=2", "'at' time: 'three' is not a number"),
        ("gps_outlier always prob=1.5 sigma=3", "prob must be in [0, 1]"),
        ("gps_outlier always prob=0.5 sigma=-3", "sigma must be >= 0"),
        ("gps_outage from 5 to 3", "window ends (3) before it starts"),
        ("gps_outage at 5 to 6", "'at T' takes 'for D'"),
        ("gps_outage", "missing time window"),
        ("gps_outage during 5", "expected 'from', 'at' or 'always'"),
        ("gps_outage from -1 to 3", "start time must be finite and >= 0"),
        ("link_drop always speed=3", "link_drop has no parameter 'speed'"),
        ("link_drop always link", "expected key=value"),
        ("link_garbage always prob=0.1 prob=0.2", "parameter 'prob' given twice"),
        ("gps_jump at 1 dx=nan dy=0", "NaN is not allowed"),
        ("seed = 1.5", "seed must be a non-negative integer"),
        ("serial_garbage always prob=0.1", "serial_garbage needs port"),
    ],
)
def test_errors_name_file_and_line(line: str, reason: str) -> None:
    text = "# header\nseed = 1\n" + line + "\n"
    if line.startswith("seed"):
        text = "# header\n\n" + line + "\n"
    with pytest.raises(ScenarioError) as exc:
        Scenario.from_text(text, name="storm.scn")
    assert str(exc.value).startswith("storm.scn:3: "), str(exc.value)
    assert reason in str(exc.value)
    assert exc.value.line == 3 and exc.value.file == "storm.scn"


def test_duplicate_seed_and_file_errors(tmp_path: Path) -> None:
    p = tmp_path / "bad.scn"
    p.write_text("seed = 1\n\n// fine\nseed = 2\n")
    with pytest.raises(ScenarioError, match=r"bad\.scn:4: seed given twice"):
        Scenario.from_file(p)
    with pytest.raises(ScenarioError, match=r"missing\.scn:0: cannot read"):
        Scenario.from_file(tmp_path / "missing.scn")


def test_fault_num_default_and_missing() -> None:
    f = Fault("link_drop", 0.0, 1.0, {})
    assert f.num("link", -1.0) == -1.0
    with pytest.raises(KeyError):
        f.num("link")


def test_rng_streams_repeatable_independent_and_seeded() -> None:
    a, b = Scenario(seed=5), Scenario(seed=5)
    assert a.rng("gps").random(8).tolist() == b.rng("gps").random(8).tolist()
    assert a.rng("gps").random(8).tolist() != a.rng("dvl").random(8).tolist()
    assert a.rng("gps").random(8).tolist() != Scenario(seed=6).rng("gps").random(8).tolist()


def test_rng_does_not_depend_on_python_hash_seed() -> None:
    code = (
        "from mavhelm.sitl.faults import Scenario;"
        "print(Scenario(seed=9).rng('nmea_gps').integers(0, 2**62))"
    )
    outs = {
        subprocess.run(
            [sys.executable, "-c", code],
            env={"PYTHONHASHSEED": seed, "PATH": ""},
            capture_output=True,
            text=True,
            check=True,
        ).stdout
        for seed in ("1", "2")
    }
    assert len(outs) == 1 and outs.pop().strip().isdigit()
