"""The page's buttons as the MAVLink commands a ground station sends the companion.

An action from the web page goes the way a ground station's command does: a COMMAND_LONG
addressed to the companion, from the web console's own system and component, through the
bridge's handlers (``bridge.take``), so whatever those handlers check of a ground station's
command (who may send it) they check of the page's too. ALL STOP and hand back are DO_SET_MODE
to the companion, which asks the autopilot for the mode; restart helm is MAV_CMD_USER_1 and a
remote flag MAV_CMD_USER_2, as from MAVProxy.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.bridge.handlers import CMD_REMOTE_FLAG, CMD_RESTART_HELM
from mavhelm.companion.mode_request import ROVER_MODE_NUMBERS

WEB_COMPONENT = mavlink.MAV_COMP_ID_ONBOARD_COMPUTER2
"""The web console's component id: it runs on the companion computer, beside the companion."""

ACTIONS: dict[str, str] = {
    "allstop": "ALL STOP (HOLD)",
    "handback": "hand back to the helm (GUIDED)",
    "restart": "restart helm",
    "flag": "remote flag",
}
"""The page's actions, by the name in ``POST /api/control/<name>``."""

ALL_STOP_MODE = "HOLD"
MAX_FLAG_INDEX = 255


@dataclass(frozen=True)
class Action:
    """One action asked for from the page; ``peer`` is the browser's address."""

    name: str
    peer: str
    flag: int = 0
    """For ``flag``: which RemoteFlag line (1 = the first), as MAV_CMD_USER_2's param1."""

    @classmethod
    def parse(cls, name: str, body: dict[str, Any], peer: str) -> Action:
        """The action ``name`` with its JSON body; ValueError says what is wrong."""
        if name not in ACTIONS:
            raise ValueError(f"unknown action {name!r}")
        if name != "flag":
            return cls(name, peer)
        index = body.get("index")
        if isinstance(index, bool) or not isinstance(index, (int, float)) \
                or not math.isfinite(index) or index != int(index) \
                or not 1 <= index <= MAX_FLAG_INDEX:
            raise ValueError(f"flag needs {{\"index\": N}}, N from 1 to {MAX_FLAG_INDEX} "
                             f"(the RemoteFlag line), got {index!r}")
        return cls(name, peer, int(index))

    def describe(self) -> str:
        what = ACTIONS[self.name]
        return f"{what} {self.flag}" if self.name == "flag" else what

    def command(self, online_mode: str, target: tuple[int, int]
                ) -> mavlink.MAVLink_command_long_message:
        """The COMMAND_LONG to the companion (``target``) that does this action; hand back asks
        for ``online_mode`` (the first of the mission's OnlineModes)."""
        params = [0.0] * 7
        if self.name in ("allstop", "handback"):
            command = mavlink.MAV_CMD_DO_SET_MODE
            mode = ALL_STOP_MODE if self.name == "allstop" else online_mode
            params[:2] = [float(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED),
                          float(ROVER_MODE_NUMBERS[mode])]
        elif self.name == "restart":
            command, params[0] = CMD_RESTART_HELM, 1.0
        else:
            command, params[0] = CMD_REMOTE_FLAG, float(self.flag)
        return mavlink.MAVLink_command_long_message(target[0], target[1], command, 0, *params)


def as_heard(msg: mavlink.MAVLink_message, source: tuple[int, int]) -> mavlink.MAVLink_message:
    """``msg`` packed and parsed again as sent by ``source`` (system, component): what the
    bridge would have read off the wire from a ground station with those ids."""
    mav = mavlink.MAVLink(None, srcSystem=source[0], srcComponent=source[1])
    return mav.decode(bytearray(msg.pack(mav)))
