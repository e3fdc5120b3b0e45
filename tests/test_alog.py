from pathlib import Path

import pytest

from mavhelm.companion.alog import AlogLogger, format_line, read_alog
from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock

START = 1763877905.25


def run_logger(path: Path) -> tuple[AlogLogger, Bus, SimClock]:
    clock = SimClock(START)
    bus = Bus(clock)
    logger = AlogLogger(bus, path, START)
    bus.subscribe(logger.name, logger.subscriptions())
    return logger, bus, clock


def tick(logger: AlogLogger, bus: Bus, clock: SimClock) -> None:
    logger.on_mail(bus.fetch(logger.name), clock.now())
    logger.iterate(clock.now())
    logger.idle()


def test_round_trip_keeps_names_sources_values_and_times(tmp_path: Path) -> None:
    path = tmp_path / "logs" / "run.alog"
    logger, bus, clock = run_logger(path)
    clock.advance(0.5)
    bus.notify("NAV_X", 12.345678, "pNav")
    bus.notify("NAV_Y", -3.0, "pNav")
    bus.notify("DEPLOY", "true", "iRemote")
    clock.advance(1.25)
    bus.notify("HELM_STATUS", "GoNorth=ON, note: a,b", "pHelm")
    bus.notify("EMPTY", "", "pHelm")
    bus.notify("GPS_X", 1e-7, "iMAVLink", time=START + 1.7)
    tick(logger, bus, clock)
    logger.close()

    got = read_alog(path)
    assert [(m.name, m.source) for m in got] == [
        ("NAV_X", "pNav"),
        ("NAV_Y", "pNav"),
        ("DEPLOY", "iRemote"),
        ("HELM_STATUS", "pHelm"),
        ("EMPTY", "pHelm"),
        ("GPS_X", "iMAVLink"),
    ]
    values = [m.value for m in got]
    assert values[0] == pytest.approx(12.345678, abs=1e-9)
    assert values[1] == -3.0 and isinstance(values[1], float)
    assert values[2:5] == ["true", "GoNorth=ON, note: a,b", ""]
    assert values[5] == pytest.approx(1e-7)
    times = [m.time for m in got]
    assert times == pytest.approx([START + 0.5] * 3 + [START + 1.75] * 2 + [START + 1.7], abs=1e-3)


def test_header_and_columns_follow_moos(tmp_path: Path) -> None:
    path = tmp_path / "run.alog"
    logger, bus, clock = run_logger(path)
    clock.advance(2.0)
    bus.notify("NAV_HEADING", 271.5, "pNav")
    tick(logger, bus, clock)
    lines = path.read_text().splitlines()
    logger.close()
    header = [line for line in lines if line.startswith("%%")]
    assert len(header) == 5
    assert header[0] == "%" * 60
    assert any(line.split()[:3] == ["%%", "LOGSTART", f"{START:.3f}"] for line in header)
    body = lines[len(header) :]
    assert body == [
        "2.000".ljust(15) + " " + "NAV_HEADING".ljust(20) + " " + "pNav".ljust(10) + " 271.5"
    ]


def test_lines_are_flushed_each_tick(tmp_path: Path) -> None:
    path = tmp_path / "run.alog"
    logger, bus, clock = run_logger(path)
    bus.notify("A", 1.0, "x")
    tick(logger, bus, clock)
    assert [m.name for m in read_alog(path)] == ["A"]
    logger.close()


def test_newlines_in_strings_stay_on_one_line() -> None:
    line = format_line(Message("MSG", "one\ntwo", 10.0, "src"), 9.0)
    assert "\n" not in line
    assert line.endswith("one two")
    assert line.startswith("1.000 ")


def test_reader_skips_junk_and_reads_moos_written_logs(tmp_path: Path) -> None:
    path = tmp_path / "moos.alog"
    path.write_text(
        "%%%%%%%%%%%%%%%%%%%%\n"
        "%% LOG FILE:       ./x.alog\n"
        "%% LOGSTART           1000.5\n"
        "not an alog row\n"
        "0.250          NAV_X                pNav       12.50000     \n"
        "3.000 DEPLOY pAutoPoke true\n"
    )
    got = read_alog(path)
    assert got == [
        Message("NAV_X", 12.5, 1000.75, "pNav"),
        Message("DEPLOY", "true", 1003.5, "pAutoPoke"),
    ]


def test_logger_subscribes_to_everything(tmp_path: Path) -> None:
    logger, bus, clock = run_logger(tmp_path / "a.alog")
    assert logger.subscriptions() == {"*"}
    assert logger.name == "pLogger"
    logger.close()
    logger.close()


def test_a_stop_while_the_lines_are_formatted_loses_nothing(tmp_path: Path,
                                                            monkeypatch) -> None:
    """SIGTERM raises KeyboardInterrupt wherever the loop is; landing in the idle time's
    formatting, it used to take the tick's lines with it (a hand-back's record missing from
    a CI run's log). They stay pending, and ``close`` writes each once."""
    import mavhelm.companion.alog as alog

    bus = Bus(SimClock(100.0))
    logger = AlogLogger(bus, tmp_path / "stop.alog")
    logger.on_mail([Message("A", 1.0, 100.1, "x"), Message("HELM_HANDBACK_DONE", "SURFACE",
                                                           100.2, "x")], 100.2)
    calls = []

    def interrupted(msg: Message, start: float) -> str:
        calls.append(msg.name)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return format_line(msg, start)

    monkeypatch.setattr(alog, "format_line", interrupted)
    with pytest.raises(KeyboardInterrupt):
        logger.idle()
    monkeypatch.setattr(alog, "format_line", format_line)
    logger.close()
    names = [m.name for m in read_alog(tmp_path / "stop.alog")]
    assert names == ["A", "HELM_HANDBACK_DONE"]
