"""``mavhelm remote``: the spec's iRemote console, as a MAVLink ground station in a terminal.

"Manual control can be regained at any time by pressing space on the iRemote console" (spec
section 1). Here the helm is online exactly while the autopilot is armed in GUIDED (the
companion's ``OnlineModes``), so the console's keys are mode changes, arming and RC override
sent to the autopilot, plus RESTART_HELM to the companion:

======  ==================================================================================
key     effect
======  ==================================================================================
space   ALL STOP: autopilot to HOLD (helm offline), stick nudges released; never refused
o       toggle: GUIDED → MANUAL (helm offline), any other mode → GUIDED (helm online)
A       arm
D D     disarm (D twice within 2 s: a disarm at sea is drastic)
w / s   thrust +10 % / −10 %   (MANUAL only: RC_CHANNELS_OVERRIDE channel 3, 1500 ± f×400 µs)
a / d   rudder −10 % / +10 %   (MANUAL only: channel 1)
arrows  up/down = w/s, left/right = a/d
x       centre the sticks: release the override (0 on channels 1 and 3)
R       RESTART_HELM: COMMAND_LONG MAV_CMD_USER_1 to the companion (1:191), ACK shown
q       quit (nudges released first); Ctrl-C, SIGTERM, SIGHUP and EOF on stdin do the same
======  ==================================================================================

A key that makes no sense now (a nudge outside MANUAL or while the helm drives, arming when
armed, ...) is refused with a status line, and nothing is sent. Nudges are refreshed every 0.5 s
(well inside ArduPilot's RC_OVERRIDE_TIME) and released on ``x``, on leaving MANUAL, on losing
the autopilot's heartbeat and on quitting.

It speaks as the ground station: system 255 (ArduPilot obeys RC override only from
MAV_GCS_SYSID, 255 by default), component 190, a GCS HEARTBEAT every second, and it asks the
autopilot for all its streams at 2 Hz. What it shows comes from MAVLink alone: the autopilot's
HEARTBEAT (mode, armed), VFR_HUD, COMMAND_ACKs and STATUSTEXTs; the companion's typed status
channel (TUNNEL payload type 32802: whether the helm drives and why not, the tasks, who steers
for what, nav health), its STATUSTEXT lines (listed as text) and NAMED_VALUE_FLOATs
(NAV_X … DES_THRUST).

``state.py`` is the pure part (``RemoteState``: messages in, messages out, a clock passed in);
``view.py`` draws it as plain lines (``render``); ``terminal.py`` is the keys, the screen and
the link at the edge (``run``).
"""

from mavhelm.companion.remote.state import ModeRequest, RemoteState
from mavhelm.companion.remote.terminal import KeyReader, add_arguments, main, parse_ids, run
from mavhelm.companion.remote.view import render

__all__ = ["KeyReader", "ModeRequest", "RemoteState", "add_arguments", "main", "parse_ids",
           "render", "run"]
