"""Run mavhelm's pNav over a converted Plaza log and score it against the ground truth.

Usage: ``python examples/plaza/run.py PLAZA.moos PLAZA.alog [--boot] [--drift DEG_PER_MIN]``

The mission and the log are the ones ``convert.py`` writes; this is ``mavhelm nav replay``
with two experiments added: ``--boot`` removes the start from the mission, so the LSQ must
boot the filter from the ranges; ``--drift`` makes the heading readings drift slowly away
from the truth (the heading-bias state must follow it). Nothing is tuned to the data set.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from dataclasses import dataclass
from pathlib import Path

from mavhelm.companion.alog import read_alog
from mavhelm.core.bus import Message
from mavhelm.core.mission import Block, load_mission
from mavhelm.nav.replay import Accuracy, ReplayResult, replay

START_KEYS = {"EKF_X", "EKF_Y", "EKF_SIGMA_XY"}


@dataclass
class Result:
    replay: ReplayResult
    accuracy: Accuracy
    seconds: float

    def summary(self) -> str:
        return "\n  ".join([*self.replay.report(), f"replay {self.seconds:.1f} s"])


def load(mission: str | Path, alog: str | Path) -> tuple[Block, list[Message]]:
    block = load_mission(mission).process("pNav")
    assert block is not None, "the mission has no pNav block"
    return block, read_alog(alog)


def drift_heading(messages: list[Message], deg_per_min: float) -> list[Message]:
    """The heading readings (``ODOM_HEADING``) drifting away from the truth."""
    t0 = messages[0].time
    return [m._replace(value=(m.double + deg_per_min * (m.time - t0) / 60.0) % 360.0)
            if m.name == "ODOM_HEADING" else m for m in messages]


def run(block: Block, messages: list[Message], *, boot: bool = False,
        drift: float = 0.0) -> Result:
    if boot:
        block = dataclasses.replace(block, entries=[e for e in block.entries
                                                    if e.key.upper() not in START_KEYS])
    if drift:
        messages = drift_heading(messages, drift)
    clock = time.perf_counter()
    result = replay(block, messages)
    seconds = time.perf_counter() - clock
    return Result(result, result.accuracy("NAV"), seconds)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument("mission")
    parser.add_argument("alog")
    parser.add_argument("--boot", action="store_true", help="no start: boot from the LSQ")
    parser.add_argument("--drift", type=float, default=0.0,
                        help="drift the heading readings by this many degrees a minute")
    args = parser.parse_args(argv)
    result = run(*load(args.mission, args.alog), boot=args.boot, drift=args.drift)
    print(result.summary())
    return 0 if result.replay.failure is None else 1


if __name__ == "__main__":
    sys.exit(main())
