"""``mavhelm request``: a guest scientist's third-party request, sent over MAVLink.

The request (``ThirdPartyRequest``) travels in a TUNNEL message of payload type
``TUNNEL_PAYLOAD_TYPE`` addressed to the companion (system 1, component 191 by default),
through the autopilot, which routes it like any addressed message; the helm's answer comes
back the same way to the guest's own system and component.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.link import AutopilotLink
from mavhelm.core.thirdparty import MAX_LENGTH, TUNNEL_PAYLOAD_TYPE

GUEST_COMPONENT = mavlink.MAV_COMP_ID_USER1


def send_request(link: AutopilotLink, text: str, target: tuple[int, int], wait_s: float,
                 clock: Callable[[], float] = time.monotonic) -> str | None:
    """Send ``text`` once the link is up; return the helm's reply, or None if none came."""
    payload = text.encode("utf-8")
    if len(payload) > MAX_LENGTH:
        raise ValueError(f"request longer than {MAX_LENGTH} bytes")
    start = clock()
    sent = False
    while clock() - start < wait_s:
        now = clock()
        for msg in link.poll(now):
            if (msg.get_type() == "TUNNEL" and msg.payload_type == TUNNEL_PAYLOAD_TYPE
                    and (msg.get_srcSystem(), msg.get_srcComponent()) == target):
                length = max(0, min(int(msg.payload_length), len(msg.payload)))
                return bytes(msg.payload[:length]).decode("utf-8", "replace")
        if link.connected and not sent:
            link.mav.heartbeat_send(mavlink.MAV_TYPE_ONBOARD_CONTROLLER,
                                    mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE)
            link.mav.tunnel_send(target[0], target[1], TUNNEL_PAYLOAD_TYPE, len(payload),
                                 payload.ljust(MAX_LENGTH, b"\0"))
            sent = True
        time.sleep(0.02)
    return None
