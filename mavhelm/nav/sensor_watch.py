"""Says on the console when a declared sensor is silent once the helm has gone online.

A SENSOR line names where its data come from (``SENSOR_XY = iGPS -> TheGPS``); a wrong name, an
instrument not plugged in, a stream the autopilot does not send all look the same from inside
the filters: nothing arrives and the estimate drifts on the others. The watch starts when the
helm goes online (before that, a sensor still starting up is normal) and warns once per
silence, naming the variables it is waiting for.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Final

from mavhelm.core.names import HELM_ONLINE
from mavhelm.core.params import Param, Seconds
from mavhelm.nav.sensors import SensorSpec

READS: Final = {"XY": ("X", "Y"), "ORIENTATION": ("YAW", "HEADING"), "DEPTH": ("DEPTH",),
                "ALTITUDE": ("ALTITUDE",), "BODY_VEL": ("VX_BODY", "VY_BODY", "YAW_VEL"),
                "LBL": ("TWTT_*",), "RANGE": ("RANGE_*",)}
"""The variables (after ``<source>_``) a sensor of each type reads; ``*``: any beacon id."""

SENSOR_SILENCE = Param("SENSOR_SILENCE", Seconds(3600.0), 10.0, "s",
                       "a declared sensor that gets no data for this long after the helm goes "
                       "online is said once on the console as NAV_WARNING (NEVER: not watched)",
                       attr="sensor_silence")


def _reads(spec: SensorSpec, name: str) -> bool:
    prefix = f"{spec.source}_"
    if not name.startswith(prefix):
        return False
    rest = name[len(prefix):]
    return any(rest.startswith(r[:-1]) if r.endswith("*") else rest == r
               for r in READS[spec.type])


class SensorWatch:
    """Pure logic: ``heard`` each tick's variable names, ``warnings`` at each iterate."""

    def __init__(self, sensors: Iterable[SensorSpec], silence: float | None,
                 origins: dict[str, str] | None = None) -> None:
        self.sensors = list(sensors)
        self.silence = silence
        self.origins = origins or {}
        """Sensor name → how its source was found (``iGPS is the autopilot's GPS …``)."""
        self._last: dict[str, float] = {}
        self._online_since: float | None = None
        self._warned: set[str] = set()
        self._readers: dict[str, tuple[str, ...]] = {}
        """Per variable name, the sensors that read it: found once per name."""

    def heard(self, names: Iterable[tuple[str, float | str]], now: float) -> None:
        """Variable names with their value (HELM_ONLINE's matters) that arrived this tick."""
        for name, value in names:
            if name == HELM_ONLINE:
                online = value == 1.0
                if online and self._online_since is None:
                    self._online_since = now
                elif not online:
                    self._online_since = None
                continue
            readers = self._readers.get(name)
            if readers is None:
                readers = self._readers[name] = tuple(
                    spec.name for spec in self.sensors if _reads(spec, name))
            for sensor in readers:
                self._last[sensor] = now
                self._warned.discard(sensor)

    def warnings(self, now: float) -> list[str]:
        """One line per sensor that has just become silent for ``silence`` seconds."""
        if self.silence is None or self._online_since is None:
            return []
        out = []
        for spec in self.sensors:
            since = max(self._online_since, self._last.get(spec.name, -float("inf")))
            if now - since >= self.silence and spec.name not in self._warned:
                self._warned.add(spec.name)
                wanted = ", ".join(f"{spec.source}_{r}" for r in READS[spec.type])
                origin = self.origins.get(spec.name)
                how = f"; {origin}" if origin else ""
                out.append(f"sensor {spec.name} (SENSOR_{spec.type}) has had no data for "
                           f"{self.silence:g} s with the helm online: waiting for {wanted}"
                           f"{how}")
        return out
