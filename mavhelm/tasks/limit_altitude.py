"""LimitAltitude: a grounding guard that fires its EventFlags when the water under the keel is
too shallow.

Spec Table 2: "Fire event flags if too close to sea bed. A Safety task requiring Altitude data.
This has saved the vehicle several times." On a boat the altitude is the echo sounder's depth
below the transducer: ``NAV_ALTITUDE``, metres above the bottom, which pNav routes from a
sensor (``Altitude = DS @ 2`` forwards a variable ``DS_ALTITUDE``). The task needs it and
starves (FinishFlags, ``<NAME>_ERROR``) when the sounder falls silent for 10 s, so a dead
sounder is reported rather than trusted.

Events follow LimitBox's rule (:class:`~mavhelm.tasks.limit_box.LimitTask`): none in the first
``IgnoreTime`` seconds after activation; then once when ``NAV_ALTITUDE`` is first below
``MinAltitude``, and every 10 s while it stays below; back above re-arms it. The value posted
on each EventFlag says how far below the limit the vehicle is. It votes on nothing, never
completes, and its TimeOut defaults to NEVER. (The original MOOS task spelled the setting
``MinimumAltitude`` and also voted elevator up at priority 0, which a boat has no use for.)
"""

from __future__ import annotations

from mavhelm.core.params import Alias, Number, Param
from mavhelm.tasks.base import NavState
from mavhelm.tasks.limit_box import LimitTask

NAV_ALTITUDE = "NAV_ALTITUDE"


class LimitAltitude(LimitTask):
    keyword = "LimitAltitude"
    summary = ("safety: fires its EventFlags when NAV_ALTITUDE (water under the keel) drops "
               "below MinAltitude, then every 10 s while below; votes nothing, never completes")
    params = (
        Param("MinAltitude", Number(0.0, 11_000.0, lo_open=True), unit="m",
              doc="least NAV_ALTITUDE (metres above the bottom) allowed", attr="min_altitude",
              aliases=(Alias("MinimumAltitude"),)),
    )
    min_altitude: float

    def needs(self) -> set[str]:
        return {NAV_ALTITUDE}

    def violations(self, nav: NavState) -> list[str]:
        altitude = nav.get(NAV_ALTITUDE)
        assert altitude is not None
        if altitude >= self.min_altitude:
            return []
        return [f"altitude {altitude:.1f} m is {self.min_altitude - altitude:.1f} m below "
                f"MinAltitude {self.min_altitude:g}"]
