"""The one wait of the test rigs: poll until something holds, or fail saying what was awaited.

Every wait in a test has a deadline (wall seconds) and fails with what it waited for and what
it saw instead, so a hang becomes a readable failure. ``pause`` is what to do between tries:
sleep (the default), or poll a connection so that the state being waited on can change.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")


def wait_for(pred: Callable[[], T | None], timeout: float, what: str,
             seen: Callable[[], object] | None = None, *,
             pause: Callable[[], object] | None = None, period: float = 0.05,
             error: type[Exception] = AssertionError) -> T:
    """Call ``pred()`` until it returns something truthy and return that; after ``timeout``
    wall seconds raise ``error`` naming ``what`` and, if given, ``seen()``. Between tries call
    ``pause()``, or sleep ``period`` seconds."""
    deadline = time.monotonic() + timeout
    while True:
        value = pred()
        if value:
            return value
        if time.monotonic() >= deadline:
            extra = f"; last seen: {seen()}" if seen is not None else ""
            raise error(f"timed out after {timeout:g} s waiting for {what}{extra}")
        if pause is not None:
            pause()
        else:
            time.sleep(period)
