"""Benchmark: how the motorboat brakes under its autopilot, real ArduPilot SITL against mavhelm.

Runs the script of tests/support/braking.py (armed in GUIDED, straight at 1.6 then 4 m/s on a
refreshed velocity target; each stopped by the 3 s GUIDED time-out and by HOLD) on the real SITL
(``--model motorboat``, stock ``--defaults``, calm, ``--speedup 10``) and on ``mavhelm sim
--model motorboat`` with the same files, and prints the figures side by side: speed at the
stop and 1 s / 3 s after, time to 0.3 m/s and to < 0.1 m/s, time until it stays stopped, the
astern overshoot, the lowest throttle servo. The simulator's ``--model motorboat`` starts, as the
real SITL, from ArduPilot's own parameter defaults (autopilot.ARDUPILOT_DEFAULTS) with the files
on top; ``--own-gains`` runs it with the controller gains tuned to mavhelm's own hulls instead.
Times are autopilot seconds. Figures only; asserts nothing. Needs MAVHELM_ARDUPILOT (the
ardurover SITL binary) for the real column; without it, says so, prints the simulator's figures
and exits 0.

Run: ``MAVHELM_ARDUPILOT=../shared/ardupilot/ardurover .venv/bin/python
-m benchmarks.bench_braking``.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

from mavhelm.sitl.autopilot import ARDUPILOT_DEFAULTS, default_params
from tests.support.ardupilot import SKIP_REASON, RealSitl, ardupilot_binary
from tests.support.braking import (
    CALM,
    HOME,
    print_table,
    run_braking,
    sim_rig,
    write_stock_parms,
)
from tests.support.sides import RealSide, SimSide

ROOT = Path(__file__).resolve().parent.parent
SPEEDUP = 10
# the controller terms as autopilot.default_params tunes them to mavhelm's own rudder boat
OWN_GAINS = {k: v for k, v in default_params(boat=True, skid=False).items()
             if k in ARDUPILOT_DEFAULTS and k.startswith("ATC_")}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--own-gains", action="store_true",
                        help="the ATC_ gains of mavhelm's own hulls, not ArduPilot's defaults")
    args = parser.parse_args(argv)
    binary = ardupilot_binary()
    with tempfile.TemporaryDirectory(prefix="mavhelm-bench-braking-") as tmp:
        params_dir = (binary.parent / "params" if binary is not None
                      else write_stock_parms(Path(tmp) / "parm"))
        t = time.monotonic()
        rig = sim_rig(params_dir, **(OWN_GAINS if args.own_gains else {}))
        try:
            sim = run_braking(SimSide(rig, 0.02, companion=False))
        finally:
            rig.close()
        print(f"mavhelm sim: {time.monotonic() - t:.1f} s wall", flush=True)
        real = None
        if binary is None:
            print(f"bench_braking: {SKIP_REASON}; simulator only")
        else:
            t = time.monotonic()
            with RealSitl(Path(tmp) / "real", model="motorboat", speedup=SPEEDUP, home=HOME,
                          params=CALM, binary=binary) as sitl:
                side = RealSide(sitl, companion=False)
                try:
                    real = run_braking(side)
                finally:
                    side.close()
            print(f"real SITL (--speedup {SPEEDUP}): {time.monotonic() - t:.1f} s wall")
    print_table(real, sim)
    return 0


if __name__ == "__main__":
    sys.exit(main())
