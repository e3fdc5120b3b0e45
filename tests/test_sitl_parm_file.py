"""ArduPilot ``.parm`` files as ``--defaults`` reads them: the stock SITL files, the accepted
spellings, and every refusal at file:line."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from mavhelm.sitl.parm_file import (
    ParmFileError,
    parse_parm,
    read_defaults,
    read_parm_file,
    split_defaults,
)


def _stock_dir() -> Path | None:
    """ArduPilot's stock Rover SITL parameter files: beside the SITL binary named by
    MAVHELM_ARDUPILOT, or in ../shared/ardupilot/params next to the checkout."""
    binary = os.environ.get("MAVHELM_ARDUPILOT", "").strip()
    candidates = [Path(binary).expanduser().resolve().parent / "params"] if binary else []
    candidates.append(Path(__file__).resolve().parents[2] / "shared" / "ardupilot" / "params")
    return next((c for c in candidates if (c / "rover.parm").is_file()), None)


STOCK = _stock_dir()
needs_stock = pytest.mark.skipif(STOCK is None, reason="ArduPilot's stock .parm files not "
                                 "found (../shared/ardupilot/params)")


@needs_stock
def test_stock_rover_parm_reads_strictly():
    assert STOCK is not None
    got = read_parm_file(STOCK / "rover.parm")
    assert got.values["WP_SPEED"] == 5.0 and got.values["CRUISE_SPEED"] == 5.0
    assert got.values["ATC_STR_RAT_FF"] == 0.75 and got.values["SIM_PIN_MASK"] == 127.0
    assert got.values["INS_ACCSCAL_X"] == pytest.approx(1.001)
    assert got.skipped == [] and len(got.values) == 36   # 37 lines, one a comment
    assert got.origin["WP_SPEED"].endswith("rover.parm:36")


@needs_stock
def test_stock_motorboat_parm_has_a_line_arduPilot_skips():
    assert STOCK is not None
    path = STOCK / "motorboat.parm"
    with pytest.raises(ParmFileError) as err:
        read_parm_file(path)
    assert err.value.path == str(path) and err.value.line == 2
    assert str(err.value) == f"{path}:2: 'SIM_TIDE_0.5' has no value (expected 'NAME value')"
    lenient = read_parm_file(path, strict=False)      # what the firmware does: skip the line
    assert lenient.values == {"FRAME_CLASS": 2.0, "SIM_WIND_SPD": 3.0, "SIM_WIND_T": 1.0,
                              "SIM_WAVE_ENABLE": 1.0}
    assert [(e.line, e.reason) for e in lenient.skipped] == [
        (2, "'SIM_TIDE_0.5' has no value (expected 'NAME value')")]


@needs_stock
def test_stock_defaults_chain_later_files_override():
    assert STOCK is not None
    chain = ",".join(str(STOCK / n) for n in ("rover.parm", "motorboat.parm", "rover-skid.parm"))
    got = read_defaults(chain, strict=False)
    assert got.values["WP_SPEED"] == 3.0                # rover-skid.parm over rover.parm's 5
    assert got.values["CRUISE_THROTTLE"] == 75.0
    assert got.values["SERVO1_FUNCTION"] == 73.0 and got.values["SERVO3_FUNCTION"] == 74.0
    assert got.values["FRAME_CLASS"] == 2.0 and got.values["ATC_SPEED_P"] == 0.1
    assert got.origin["WP_SPEED"].endswith("rover-skid.parm:6")
    assert len(got.skipped) == 1
    rover_only = read_defaults([STOCK / "rover.parm"])
    assert rover_only.values["WP_SPEED"] == 5.0 and "FRAME_CLASS" not in rover_only.values


def test_every_spelling_arduPilot_reads():
    text = ("# a comment line\n"
            "\n"
            "WP_SPEED 2\n"
            "CRUISE_SPEED,3.5\n"
            "WP_RADIUS\t4\n"
            "ATC_SPEED_P=0.2\n"
            "  SIM_WIND_SPD ,  -1e-1   # trailing comment\n"
            "SYSID_THISMAV 7 @READONLY\r\n"
            "   \t\n")
    got = parse_parm(text, "x.parm")
    assert got.values == {"WP_SPEED": 2.0, "CRUISE_SPEED": 3.5, "WP_RADIUS": 4.0,
                          "ATC_SPEED_P": 0.2, "SIM_WIND_SPD": -0.1, "SYSID_THISMAV": 7.0}
    assert got.readonly == {"SYSID_THISMAV"}
    assert got.origin["CRUISE_SPEED"] == "x.parm:4"


@pytest.mark.parametrize(("line", "reason"), [
    ("WP_SPEED", "'WP_SPEED' has no value (expected 'NAME value')"),
    ("WP_SPEED fast", "WP_SPEED: value 'fast' is not a finite number"),
    ("WP_SPEED nan", "WP_SPEED: value 'nan' is not a finite number"),
    ("WP_SPEED inf", "WP_SPEED: value 'inf' is not a finite number"),
    ("WP_SPEED 1e999", "WP_SPEED: value '1e999' is not a finite number"),
    ("WP_SPEED 2 3", "WP_SPEED: unexpected '3' after the value (only @READONLY may follow)"),
    ("WP_SPEED 2 @readonly", "WP_SPEED: unexpected '@readonly' after the value "
                             "(only @READONLY may follow)"),
    ("ABCDEFGHIJKLMNOPQ 1", "parameter name 'ABCDEFGHIJKLMNOPQ' is longer than 16 characters"),
    ("wp_speed 2", "'wp_speed' is not a parameter name (capital letters, digits and '_', "
                   "starting with a letter)"),
    ("1WP 2", "'1WP' is not a parameter name (capital letters, digits and '_', "
              "starting with a letter)"),
    ("WP-SPEED 2", "'WP-SPEED' is not a parameter name (capital letters, digits and '_', "
                   "starting with a letter)"),
])
def test_bad_lines_refused_at_file_and_line(line, reason):
    text = f"# header\nWP_RADIUS 2\n{line}\n"
    with pytest.raises(ParmFileError) as err:
        parse_parm(text, "bad.parm")
    assert isinstance(err.value, ValueError)
    assert (err.value.path, err.value.line, err.value.reason) == ("bad.parm", 3, reason)
    assert str(err.value) == f"bad.parm:3: {reason}"
    lenient = parse_parm(text, "bad.parm", strict=False)
    assert lenient.values == {"WP_RADIUS": 2.0} and len(lenient.skipped) == 1


def test_a_name_set_twice_in_one_file_is_refused():
    with pytest.raises(ParmFileError, match=r"^d\.parm:4: WP_SPEED is set twice in this file "
                                            r"\(first at line 2\)$"):
        parse_parm("# x\nWP_SPEED 1\nWP_RADIUS 2\nWP_SPEED 3\n", "d.parm")


def test_files_that_cannot_be_read_are_refused_even_leniently(tmp_path):
    missing = tmp_path / "nope.parm"
    with pytest.raises(ParmFileError, match=r"nope\.parm: no such file$") as err:
        read_parm_file(missing, strict=False)
    assert err.value.line is None
    with pytest.raises(ParmFileError, match="not a regular file"):
        read_parm_file(tmp_path, strict=False)
    binary = tmp_path / "bin.parm"
    binary.write_bytes(b"WP_SPEED 2\nSIM\x00X 1\n")
    with pytest.raises(ParmFileError, match=r"bin\.parm:2: not text \(NUL byte\)"):
        read_parm_file(binary, strict=False)
    latin = tmp_path / "latin.parm"
    latin.write_bytes(b"WP_SPEED 2\n\n# caf\xe9\n")
    with pytest.raises(ParmFileError, match=r"latin\.parm:3: not text \(invalid UTF-8\)"):
        read_parm_file(latin)


def test_defaults_list_order_and_empty_names(tmp_path):
    a, b = tmp_path / "a.parm", tmp_path / "b.parm"
    a.write_text("WP_SPEED 1\nWP_RADIUS 2\n")
    b.write_text("WP_SPEED 4\n")
    got = read_defaults(f"{a},{b}")
    assert got.values == {"WP_SPEED": 4.0, "WP_RADIUS": 2.0}
    assert read_defaults(f"{b},{a}").values["WP_SPEED"] == 1.0
    assert split_defaults(f" {a} , {b} ") == [str(a), str(b)]
    for spec in ("", f"{a},", f",{a}", f"{a},,{b}"):
        with pytest.raises(ParmFileError, match="empty file name in the --defaults list"):
            read_defaults(spec)
    b.write_text("WP_SPEED 4\nWP_RADIUS\n")
    with pytest.raises(ParmFileError, match=r"b\.parm:2: 'WP_RADIUS' has no value"):
        read_defaults([a, b])
