"""The real ArduSub SITL for tests: the binary named by ``MAVHELM_ARDUSUB``.

Built like ``ardupilot.py``'s Rover rig and sharing it (``RealSitl``, ``RealOperator``,
``CompanionProcess``): ``start_sub(tmp_dir, ...)`` starts ``ardusub --model vectored`` with its
stock ``params/sub.parm``; ``SubOperator`` is a ground station that reads and sets ArduSub's
modes (GUIDED 4, ALT_HOLD 2, SURFACE 9, MANUAL 19). Tests skip when the variable is unset and
fail when it is set but wrong, as for Rover.

A plain helper module (not a test module), imported by the tests that use it.
"""

from __future__ import annotations

import os
from pathlib import Path

from pymavlink import mavutil

from tests.support.ardupilot import RealOperator, RealSitl

ARDUSUB_ENV = "MAVHELM_ARDUSUB"
SKIP_REASON = f"real ArduSub SITL not configured: set {ARDUSUB_ENV}=../shared/ardupilot/ardusub"


class ArduSubConfigError(RuntimeError):
    """MAVHELM_ARDUSUB is set but does not name a runnable binary."""


def ardusub_binary() -> Path | None:
    """The binary named by MAVHELM_ARDUSUB, None when unset; raises when set but wrong."""
    value = os.environ.get(ARDUSUB_ENV, "").strip()
    if not value:
        return None
    path = Path(value).expanduser()
    if not path.is_absolute():
        path = Path.cwd() / path
    path = path.resolve()
    if not path.is_file() or not os.access(path, os.X_OK):
        raise ArduSubConfigError(f"{ARDUSUB_ENV}={value!r}: {path} is not an executable file; "
                                 "unset it to skip the ArduSub tests")
    return path


def start_sub(tmp_dir: Path, *, speedup: float = 10,
              params: dict[str, float] | None = None) -> RealSitl:
    """ArduSub's vectored frame (a BlueROV2) with its stock parameters, started."""
    binary = ardusub_binary()
    if binary is None:
        raise ArduSubConfigError(SKIP_REASON)
    return RealSitl(tmp_dir, binary=binary, model="vectored", defaults=["sub.parm"],
                    speedup=speedup, params=params).start()


class SubOperator(RealOperator):
    """A ground station on SERIAL0 that speaks ArduSub's mode numbers."""

    def __init__(self, port: int, **kwargs: object) -> None:
        super().__init__(port, **kwargs)  # type: ignore[arg-type]
        self.mode_names = dict(mavutil.mode_mapping_sub)
