"""``mavhelm log plot``: the same run read from its .alog and from its .tlog gives the track and
who steered, the heading drawn unwrapped, and a PNG."""

from __future__ import annotations

import numpy as np

from mavhelm.cli import main
from mavhelm.companion.log_plot import find_log, from_alog, from_tlog, nav_error, unwrapped
from mavhelm.companion.tlog_writer import TlogWriter
from mavhelm.demo.harness import SimulatedRun
from tests.support.mission import mission_text
from tests.support.web_rig import TASKS


def test_heading_is_unwrapped():
    assert np.allclose(unwrapped([350.0, 10.0, 20.0, 340.0]), [350.0, 370.0, 380.0, 340.0])
    assert np.allclose(unwrapped([-10.0, 5.0]), [350.0, 365.0])
    assert unwrapped([]).size == 0


def test_a_run_plots_from_its_alog_and_its_tlog(tmp_path, capsys):
    mission = tmp_path / "m.moos"
    mission.write_text(mission_text(TASKS, overall_timeout=600))
    alog, tlog = tmp_path / "m.alog", tmp_path / "m.tlog"
    with SimulatedRun.start(mission, alog_path=alog) as run:
        writer = TlogWriter(tlog, clock=lambda: 1.7e9 + run.clock.now())
        run.companion.bridge.link.recorder = writer.record
        run.hand_over()
        run.run_for(30.0)
        writer.close()
    a, t = from_alog(alog), from_tlog(tlog)
    assert [name for _, name in a.owners if name != "none"] == ["OutLeg", "HomeLeg"]
    assert [name for _, name in t.owners if name != "none"] == ["OutLeg", "HomeLeg"]
    assert len(a.x) > 100 and len(t.x) > 20 and max(v for _, v in t.x) > 30.0
    times, error = nav_error(a)
    assert times.size > 100 and float(np.median(error)) < 3.0
    assert find_log(tmp_path) == alog
    for log in (alog, tlog):
        out = tmp_path / f"{log.suffix[1:]}.png"
        assert main(["log", "plot", str(log), "--out", str(out)]) == 0
        assert out.stat().st_size > 20_000
    assert main(["log", "plot", str(tmp_path / "nothing")]) == 2
    assert "no such run folder" in capsys.readouterr().err
