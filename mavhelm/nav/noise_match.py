"""Down-weighting a channel whose readings disagree more than its noise says (spec 2.2.6).

The χ² gate refuses a reading far from the estimate, but a channel that is wrong by a few
σ all the time — a beacon a few metres from its surveyed place, a GPS noisier than declared —
passes the gate and pulls the estimate by its full weight. :class:`NoiseMatch` watches each
channel's innovations (its χ² distance per degree of freedom, 1 on average when its noise is
told right) over ``WINDOW`` readings and scales the channel's σ by the square root of their
mean when it is above ``INFLATE_AT``, and back towards 1 when it falls under ``DEFLATE_AT``:
covariance matching, one channel at a time. ``MAX_SCALE`` is the ceiling, so a channel is
down-weighted, never silenced.

The declared noise is the floor, except for a channel that may shrink (the fusion lets ranges
to a beacon): a σ declared far too large (mean under ``SHRINK_AT``) shrinks by
``SHRINK_STEP`` a window, down to ``MIN_SCALE``. Slowly, because a well-declared channel
has windows that low by chance. Not for fixes: a GPS's error wanders over minutes and the
filter follows it, so its innovations read small while its error is not. Plaza1 with the
ranges' σ declared 3 m (about 0.8 m true), the heading drifting: 1.29 -> 0.51 m RMS; declared
1 m, unchanged (0.36 m clean).

Measured on Plaza1 with one beacon 5 m from its surveyed place: 1.01 m RMS without, see the
module's test for the figure with.
"""

from __future__ import annotations

import math
from collections.abc import Hashable
from typing import Final

WINDOW: Final = 20
"""Readings of a channel a scale is judged over."""
INFLATE_AT: Final = 2.0
"""Mean χ² per degree of freedom above which the channel's σ grows."""
DEFLATE_AT: Final = 0.5
"""... and under which it shrinks back towards the declared σ."""
CLIP: Final = 25.0
"""A lone outlier (the gate's business) counts as at most this."""
MAX_SCALE: Final = 10.0
"""The most a declared σ is scaled by."""
SHRINK_AT: Final = 0.2
"""Mean χ² per degree of freedom under which a channel that may shrink goes below its
declared σ (a σ declared 2-3x too large)."""
SHRINK_STEP: Final = 0.9
"""What such a channel's scale is multiplied by each window it stays under ``SHRINK_AT``."""
MIN_SCALE: Final = 1.0 / 3.0
"""The least a declared σ is scaled by."""


class NoiseMatch:
    """``scale(channel)`` multiplies the channel's declared σ; ``observe(channel, nis)``
    after each of its readings is tested (``nis``: χ² distance per degree of freedom, with
    the scaled σ)."""

    def __init__(self) -> None:
        self._scale: dict[Hashable, float] = {}
        self._sums: dict[Hashable, tuple[float, int]] = {}

    def scale(self, channel: Hashable) -> float:
        return self._scale.get(channel, 1.0)

    def observe(self, channel: Hashable, nis: float, may_shrink: bool = False) -> None:
        total, n = self._sums.get(channel, (0.0, 0))
        total, n = total + min(nis, CLIP), n + 1
        if n < WINDOW:
            self._sums[channel] = (total, n)
            return
        self._sums[channel] = (0.0, 0)
        mean = total / n
        scale = self._scale.get(channel, 1.0)
        if mean > INFLATE_AT:
            scale = min(scale * math.sqrt(mean), MAX_SCALE)
        elif mean < DEFLATE_AT and scale > 1.0:
            scale = max(scale * math.sqrt(max(mean, 0.25)), 1.0)
        elif mean < SHRINK_AT and may_shrink:
            scale = max(scale * SHRINK_STEP, MIN_SCALE)
        self._scale[channel] = scale
