"""The link supervisor: whether the autopilot is there, whether the helm may drive, and why not.

The link is up while the connection is open and the autopilot's HEARTBEAT came within
``LinkTimeOut``; the helm is online while the link is up, the autopilot is armed in one of
``OnlineModes`` and the actuation profile has no refusal. On the way up it asks for the
streams (again every 2 s until acknowledged, and warns of any not heard after
``STREAM_GRACE_S``) and for the parameters the profile needs, and asks the autopilot to stop
the streams nothing reads (``stop_unread``).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.actuation import GCS_SYSID_PARAMS, RcOverride

if TYPE_CHECKING:
    from mavhelm.companion.bridge.facade import MavlinkBridge

STREAM_GRACE_S = 5.0
"""How long after the link comes up every requested stream must have been heard once."""
REQUEST_RETRY_S = 2.0
"""Streams and parameters not yet answered are asked for again this often."""
STOP_RETRY_S = 5.0
STOP_TRIES = 2
"""A message the autopilot still streams ``STOP_RETRY_S`` after it was asked to stop is
asked again (the request may have been lost), at most ``STOP_TRIES`` times in all: an
autopilot that refuses is left as it is (ArduPilot says so to every ground station)."""
STREAMED_AFTER = 3
"""Frames of a message heard before it is taken for a stream: an event's message (a mission
item reached) has no interval to stop."""
NOT_STREAMS = frozenset({mavlink.MAVLINK_MSG_ID_TIMESYNC, mavlink.MAVLINK_MSG_ID_PING})
"""Periodic, but requests of a protocol rather than streams: ArduPilot has no interval for
them and refuses a stop with "No ap_message for mavlink id" to every ground station (the
Rover SITL sends a TIMESYNC every few seconds)."""
STOPS_PER_TICK = 8
"""Stop requests sent in one tick at most (each is a write to the link)."""


class LinkSupervisor:
    """Decides ``link_up``, ``online`` and ``status`` once a tick, posting each change."""

    def __init__(self, bridge: MavlinkBridge) -> None:
        self.bridge = bridge
        self.link_up = False
        self.online = False
        self.status: str | None = None
        self.params_requested_at: float | None = None
        self.streams_requested_at: float | None = None
        self.up_since: float | None = None
        self.streams_checked = False
        self.bad_packets_posted = 0
        self.stops: dict[int, tuple[float, int]] = {}
        """Message id → when the autopilot was last asked to stop streaming it, how often."""

    def update(self, now: float) -> None:
        bridge = self.bridge
        state = bridge.state
        heard = state.last_heartbeat
        up = (bridge.link.connected and heard is not None
              and now - heard <= bridge.config.link_timeout)
        if up != self.link_up:
            self._link_changed(up, now)
        elif up and not state.streams_acked and self.streams_requested_at is not None \
                and now - self.streams_requested_at >= REQUEST_RETRY_S:
            self.request_streams(now)
        if up:
            self._check_streams(now)
            self.request_params(now)
            self.stop_unread(now)
        state.view.gcs_silent_s = (math.inf if state.gcs_heard_at is None
                                   else now - state.gcs_heard_at)
        refusal = bridge.actuation.refusal(state.view) if up else None
        self._decide(up, refusal)
        self.post_bad_packets()

    def _link_changed(self, up: bool, now: float) -> None:
        bridge = self.bridge
        self.link_up = up
        bridge.input.notify("AP_LINK", 1.0 if up else 0.0)
        if up:
            self.up_since = now
            bridge.state.heard = set()
            self.streams_checked = False
            self.stops = {}  # the autopilot may have restarted: its streams are its defaults
            self.request_streams(now)
            return
        bridge.state.streams_acked = False
        if bridge.state.last_heartbeat is not None:
            why = (f"no HEARTBEAT for {bridge.config.link_timeout:g} s"
                   if bridge.link.connected else "the connection dropped")
            bridge.input.notify("MAVLINK_WARNING", f"autopilot link lost: {why}")

    def _check_streams(self, now: float) -> None:
        """Once, ``STREAM_GRACE_S`` after the link came up: every stream asked for heard?"""
        if self.streams_checked or self.up_since is None \
                or now - self.up_since < STREAM_GRACE_S:
            return
        self.streams_checked = True
        bridge = self.bridge
        missing = [n for n, rate in bridge.config.streams.items()
                   if rate > 0 and n not in bridge.state.heard]
        if missing:
            bridge.input.notify("MAVLINK_WARNING", f"no {', '.join(missing)} from the "
                                f"autopilot {STREAM_GRACE_S:g} s after the link came up: "
                                "check its stream rates (SRn_* parameters)")

    def _decide(self, up: bool, refusal: str | None) -> None:
        bridge = self.bridge
        state = bridge.state
        online = (up and state.armed and state.mode in bridge.config.online_modes
                  and refusal is None)
        if online != self.online:
            self.online = online
            bridge.input.notify("HELM_ONLINE", 1.0 if online else 0.0)
            if not online and bridge.link.connected:
                bridge.actuation.release(bridge.link.mav)
        status = self.describe(up, refusal)
        if status != self.status:
            self.status = status
            bridge.input.notify("HELM_STATUS", status)

    def post_bad_packets(self) -> None:
        """``MAVLINK_BAD_PACKETS`` when the count has changed since it was last posted."""
        bridge = self.bridge
        if bridge.bad_packets != self.bad_packets_posted:
            self.bad_packets_posted = bridge.bad_packets
            bridge.input.notify("MAVLINK_BAD_PACKETS", float(bridge.bad_packets))

    def forget_autopilot(self) -> None:
        """A new connection: the parameters are asked for afresh."""
        self.params_requested_at = None

    def wanted_params(self) -> list[str]:
        """The parameters the actuation profile needs and has not heard yet."""
        bridge = self.bridge
        params = bridge.state.view.params
        actuation = bridge.actuation
        wanted = [n for n in actuation.wanted_params() if n not in params]
        if isinstance(actuation, RcOverride):
            wanted += [n for n in actuation.missing(params)
                       if n not in wanted and n not in GCS_SYSID_PARAMS]
            if any(n in params for n in GCS_SYSID_PARAMS):
                wanted = [n for n in wanted if n not in GCS_SYSID_PARAMS]
        if bridge.gate.needs_gcs_sysid:
            wanted += [n for n in GCS_SYSID_PARAMS if n not in wanted]
        return wanted

    def request_params(self, now: float) -> None:
        """Ask for the parameters the actuation profile needs; again every 2 s until known."""
        wanted = self.wanted_params()
        if not wanted or (self.params_requested_at is not None
                          and now - self.params_requested_at < REQUEST_RETRY_S):
            return
        self.params_requested_at = now
        config = self.bridge.config
        for name in wanted:
            self.bridge.link.mav.param_request_read_send(
                config.target_system, config.target_component, name.encode(), -1)

    def request_streams(self, now: float) -> None:
        """Ask for each stream at its rate; repeated every 2 s until the autopilot ACKs."""
        self.streams_requested_at = now
        config = self.bridge.config
        for name, rate in config.streams.items():
            msg_id = getattr(mavlink, f"MAVLINK_MSG_ID_{name}")
            interval_us = -1 if rate <= 0 else int(1e6 / rate)
            self.bridge.link.mav.command_long_send(
                config.target_system, config.target_component,
                mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, msg_id, interval_us, 0, 0, 0, 0, 0)

    def stop_unread(self, now: float) -> None:
        """Ask the autopilot to stop, on this link only (``SET_MESSAGE_INTERVAL`` −1), each
        message it streams that the companion never reads, once heard ``STREAMED_AFTER``
        times (``AutopilotLink``'s parser counts them; with a ``.tlog`` recording the link it
        keeps them all and counts none): a default ArduPilot link streams some 25 messages,
        16 of them read by no one here, which cost the link's bandwidth (their framing in the
        tick is a few µs). Only once the streams the companion asked for are acknowledged (any
        ``SET_MESSAGE_INTERVAL`` ACK counts as theirs), and said on ``MAVLINK_LINK``."""
        bridge = self.bridge
        heard = bridge.link.mav.unread
        if not heard or not bridge.state.streams_acked:
            return
        config = bridge.config
        target = (config.target_system, config.target_component)
        asked: list[str] = []
        for key, count in sorted(heard.items()):
            system, component, msg_id = key
            last = self.stops.get(msg_id)
            if (system, component) != target or msg_id in NOT_STREAMS or (
                    last is not None and (now - last[0] < STOP_RETRY_S
                                          or last[1] >= STOP_TRIES)):
                del heard[key]  # another sender's, or asked: counted afresh
                continue
            if count < STREAMED_AFTER:
                continue
            if len(asked) == STOPS_PER_TICK:
                break
            del heard[key]
            self.stops[msg_id] = (now, 1 if last is None else last[1] + 1)
            bridge.link.mav.command_long_send(
                config.target_system, config.target_component,
                mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, msg_id, -1, 0, 0, 0, 0, 0)
            entry = mavlink.mavlink_map.get(msg_id)
            asked.append(entry.msgname if entry is not None else str(msg_id))
        if asked:
            bridge.input.notify("MAVLINK_LINK", f"asked the autopilot to stop streaming "
                                f"{', '.join(asked)} on this link: the companion reads none "
                                "of them")

    def describe(self, up: bool, refusal: str | None = None) -> str:
        """Whether the helm may drive, and if not, the one reason an operator can act on."""
        bridge = self.bridge
        state = bridge.state
        modes = ", ".join(bridge.config.online_modes)
        if self.online:
            return f"ONLINE: autopilot armed in {state.mode}"
        if not up:
            return self._why_down()
        no_fix = ("; its EKF has no position yet, so ArduPilot will refuse GUIDED"
                  if state.ekf_position_ok is False and "GUIDED" in bridge.config.online_modes
                  else "")
        if not state.armed:
            return (f"offline: autopilot disarmed (arm it and select {modes} to hand over)"
                    + no_fix)
        if state.mode not in bridge.config.online_modes:
            return f"offline: autopilot in {state.mode}; select {modes} to hand over" + no_fix
        return f"offline: {refusal}"

    def _why_down(self) -> str:
        bridge = self.bridge
        if not bridge.link.connected:
            return f"offline: no connection to the autopilot at {bridge.link.url}"
        if bridge.state.last_heartbeat is None:
            return "offline: connected, waiting for the autopilot's HEARTBEAT"
        return f"offline: no HEARTBEAT from the autopilot for {bridge.config.link_timeout:g} s"
