"""The LSQ fixes that boot the EKF (spec 2.2.9: "once a stable/repeatable stream of solutions
begins to flow from the LSQ filter they can be used to initialize the EKF").

A stream is ``BOOT_FIXES`` fixes, each within ``BOOT_AGREEMENT`` of the stream's last. One fix
off the stream is held aside rather than ending it: the next fix that agrees with the stream
carries it on and the stray is dropped; one that agrees with the stray instead starts a new
stream from the two (the vehicle was not where the old stream said). Acoustic and radio
ranges come with multipath — long ranges, a share of them now and then — and a window with
two of them can make a fix tens of metres off that still passes the LSQ's own test: on
Plaza1 with 30 % of the ranges 5–50 m long, one fix in three to one in two was such a stray,
a stray broke every stream before its third fix, and the navigator failed at 52 s on the
LSQ's median shift (spec 2.2.11) though two streams of good fixes had begun.

Pure logic: no clock, no bus.
"""

from __future__ import annotations

import math
from typing import Final

from mavhelm.nav.lsq import Fix

BOOT_FIXES: Final = 3
"""LSQ fixes in a stream, each within ``BOOT_AGREEMENT`` of the stream's last, that boot the
EKF."""
BOOT_AGREEMENT: Final = 10.0
"""m: how close a stream's consecutive fixes must be (a boat moves a few metres between
fixes)."""


class BootStream:
    """``add(fix)`` each LSQ fix while the EKF is off-line; ``ready`` is the newest fix of a
    complete stream (None until there is one); ``clear()`` when the EKF goes off-line again."""

    def __init__(self, fixes: int = BOOT_FIXES, agreement: float = BOOT_AGREEMENT) -> None:
        self.fixes = fixes
        self.agreement = agreement
        self.stream: list[Fix] = []
        self.stray: Fix | None = None
        """A fix that did not agree with the stream, held aside for one fix."""
        self.strays = 0
        """Fixes set aside as strays (the boot's decision says how many)."""

    def add(self, fix: Fix) -> None:
        if not self.stream or self._near(fix, self.stream[-1]):
            self.stream.append(fix)
            if self.stray is not None:
                self.strays += 1
        elif self.stray is not None and self._near(fix, self.stray):
            self.stream = [self.stray, fix]
        else:
            if self.stray is not None:
                self.strays += 1
            self.stray = fix
            return
        self.stray = None

    @property
    def ready(self) -> Fix | None:
        return self.stream[-1] if len(self.stream) >= self.fixes else None

    def clear(self) -> None:
        self.stream = []
        self.stray = None

    def _near(self, a: Fix, b: Fix) -> bool:
        return math.hypot(a.x - b.x, a.y - b.y) <= self.agreement
