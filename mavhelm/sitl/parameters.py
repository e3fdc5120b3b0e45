"""The autopilot's parameter table as MAVLink sees it (AP_Param through GCS_Param.cpp): each
name's wire type, its PARAM_VALUE (with count and index in the sorted table) and the rounding a
PARAM_SET gets on an integer parameter."""

from __future__ import annotations

from collections.abc import MutableMapping
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as M

# parameters ArduPilot holds as AP_Int8 whose value looks like a float in the table
INT8_PARAMS = {"SIM_WIND_T", "SIM_WAVE_ENABLE"}
# name fragments of parameters held as floats even when their value is whole
_FLOAT_HINTS = ("SPEED", "TIME", "RADIUS", "ATC_", "WP_", "CRUISE", "LOIT_", "SIM_", "GAIN",
                "ACCEL", "TURN_RATE", "MARGIN")


class ParameterTable:
    """Names, types and PARAM_VALUE messages over the autopilot's own ``params`` dict (shared,
    so the autopilot sees a set at once). The name list is fixed at start, as ArduPilot's."""

    def __init__(self, params: MutableMapping[str, float]) -> None:
        self.params = params
        self.names = sorted(params)
        self._index = {n: i for i, n in enumerate(self.names)}

    def __contains__(self, name: object) -> bool:
        return name in self.params

    def type_of(self, name: str) -> int:
        """MAV_PARAM_TYPE: INT8 for the few AP_Int8, REAL32 for floats, else INT16."""
        v = self.params[name]
        if name in INT8_PARAMS:
            return M.MAV_PARAM_TYPE_INT8
        float_like = not float(v).is_integer() or any(k in name for k in _FLOAT_HINTS)
        return M.MAV_PARAM_TYPE_REAL32 if float_like else M.MAV_PARAM_TYPE_INT16

    def value_message(self, name: str) -> Any:
        """PARAM_VALUE for one name (index 65535 for a name added after start)."""
        idx = self._index.get(name, 65535)
        return M.MAVLink_param_value_message(name.encode(), float(self.params[name]),
                                             self.type_of(name), len(self.names), idx)

    def name_at(self, index: int) -> str | None:
        return self.names[index] if 0 <= index < len(self.names) else None

    def set(self, name: str, value: float) -> float | None:
        """Store a PARAM_SET (integers rounded); the stored value, or None for an unknown name
        (ArduPilot then answers nothing)."""
        if name not in self.params:
            return None
        if self.type_of(name) != M.MAV_PARAM_TYPE_REAL32:
            value = float(int(round(value)))
        self.params[name] = float(value)
        return float(value)
