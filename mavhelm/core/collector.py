"""Python's cycle collector run between two ticks, never inside one.

CPython collects when allocations pass a threshold, wherever the program is: in the
companion's 20-task tick that is about one tick in seventy, and a collection then costs
0.2–0.4 ms (the youngest objects) or about 1.5 ms (the two younger generations) — on its own
over the tick's 1 ms budget. A control loop has idle time after each tick, before it sleeps;
the collections belong there.

:class:`IdleCollector` turns the automatic collector off once the loop first says it is idle,
after moving everything built at start-up (the mission, pymavlink's dialect, numpy) into
the permanent generation (``gc.freeze``), which later full collections then skip. At each
:meth:`IdleCollector.idle` it collects the generations CPython's own thresholds say are due,
so the same garbage is collected, only at another moment. :meth:`IdleCollector.close` gives
the process its automatic collector back. A loop that never calls ``idle`` keeps the
automatic collector: nothing is left uncollected by forgetting it.

Written here because the standard library's ``gc`` offers the pieces (``disable``,
``freeze``, ``collect(generation)``, ``get_count``) but no policy for a paced loop.
"""

from __future__ import annotations

import gc
import time

_holders = 0
"""Collectors that have the automatic collector off (several companions in one test run)."""


class IdleCollector:
    """Collect garbage at the end of a tick instead of inside the next one."""

    def __init__(self) -> None:
        self.holding = False
        self.collections = [0, 0, 0]
        """Collections made, by generation."""
        self.seconds: list[float] = []
        """The time each collection took (s), for the benchmarks."""

    def idle(self) -> None:
        """The tick is over: collect what is due (at the first call, take the collection
        over from the automatic collector)."""
        global _holders
        if not self.holding:
            self.holding = True
            _holders += 1
            gc.collect()
            gc.freeze()
            gc.disable()
            return
        generation = due_generation()
        if generation is None:
            return
        start = time.perf_counter()
        gc.collect(generation)
        self.seconds.append(time.perf_counter() - start)
        self.collections[generation] += 1

    def close(self) -> None:
        """Give the automatic collector back (once the last holder closes)."""
        global _holders
        if not self.holding:
            return
        self.holding = False
        _holders -= 1
        if _holders == 0:
            gc.unfreeze()
            gc.enable()


def due_generation() -> int | None:
    """The oldest generation CPython's thresholds call for now (None: none is due).

    ``gc.get_count()`` is (allocations since the last collection of generation 0, collections
    of 0 since the last of 1, collections of 1 since the last of 2); generation ``g`` is due
    when its count passes its threshold, and a collection of ``g`` takes the younger ones
    with it."""
    counts, thresholds = gc.get_count(), gc.get_threshold()
    for generation in (2, 1, 0):
        if thresholds[generation] and counts[generation] > thresholds[generation]:
            return generation
    return None
