"""The bridge asks the autopilot to stop, on its own link, the streams nothing in the companion
reads (``LinkSupervisor.stop_unread``).

The unit tests send encoded MAVLink 2 frames over UDP to a bridge on ``udpin:`` (system 1,
component 1 is the autopilot) and read back what it sends; the last test runs the bridge on
the real ArduPilot Rover SITL's SERIAL1 and checks that ArduPilot stops them; it needs
MAVHELM_ARDUPILOT and skips without.
"""

from __future__ import annotations

import time

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.bridge import BridgeConfig, MavlinkBridge
from mavhelm.companion.bridge.supervisor import STOP_RETRY_S, STOP_TRIES, STREAMED_AFTER
from mavhelm.core.bus import Bus, Message
from mavhelm.core.clock import SimClock
from tests.support.bridge_rig import ORIGIN, UdpLinkRig


class Autopilot(UdpLinkRig):
    """A bridge on ``udpin:``, and an autopilot (1/1) that sends it frames and reads what the
    bridge sends back."""

    def __init__(self) -> None:
        super().__init__()
        self.sock.setblocking(False)
        self.reader = mavlink.MAVLink(None)
        self.reader.robust_parsing = True
        self.mail: list[Message] = []

    def tick(self, *msgs: mavlink.MAVLink_message, sender: tuple[int, int] = (1, 1),
             dt: float = 0.1) -> list[mavlink.MAVLink_message]:
        """One tick ``dt`` later in which the bridge reads ``msgs`` (from ``sender``); what
        it sent the autopilot meanwhile."""
        mav = self.autopilot if sender == (1, 1) else mavlink.MAVLink(None, *sender)
        link = self.bridge.link
        expected = link.stats.bytes_read
        for msg in msgs:
            frame = msg.pack(mav)
            expected += len(frame)
            self.sock.sendto(frame, self.address)
        now = self.clock.advance(dt)
        deadline = time.monotonic() + 2.0
        self.bridge.receive(now)
        while link.stats.bytes_read < expected:
            assert time.monotonic() < deadline, "the frames never reached the bridge"
            time.sleep(0.001)
            self.bridge.receive(now)
        self.mail += self.bus.fetch("test")
        return self.sent()

    def sent(self) -> list[mavlink.MAVLink_message]:
        time.sleep(0.01)
        out: list[mavlink.MAVLink_message] = []
        while True:
            try:
                data = self.sock.recv(65536)
            except BlockingIOError:
                return out
            out += [m for m in self.reader.parse_buffer(data) or [] if m is not None]

    @staticmethod
    def heartbeat() -> mavlink.MAVLink_heartbeat_message:
        """A boat's: the link then leaves what only a sub reads unread."""
        return mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_SURFACE_BOAT, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 0, 3)

    def up(self, acknowledged: bool = True) -> None:
        """The autopilot's HEARTBEAT, and the companion's stream requests acknowledged."""
        self.tick(self.heartbeat())
        if acknowledged:
            self.tick(mavlink.MAVLink_command_ack_message(
                mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAV_RESULT_ACCEPTED))



@pytest.fixture
def autopilot():
    a = Autopilot()
    yield a
    a.close()


def raw_imu() -> mavlink.MAVLink_raw_imu_message:
    return mavlink.MAVLink_raw_imu_message(0, 1, 2, 3, 4, 5, 6, 7, 8, 9)


def meminfo() -> mavlink.MAVLink_meminfo_message:
    return mavlink.MAVLink_meminfo_message(1000, 2000)


def power_status() -> mavlink.MAVLink_power_status_message:
    return mavlink.MAVLink_power_status_message(5000, 5000, 0)


def stops(sent: list[mavlink.MAVLink_message]) -> dict[int, tuple[float, int, int]]:
    """Message id → (interval, target system, target component) of each SET_MESSAGE_INTERVAL
    that asks for a stop (−1)."""
    return {int(m.param1): (m.param2, m.target_system, m.target_component) for m in sent
            if m.get_type() == "COMMAND_LONG" and m.command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL
            and m.param2 < 0}


def test_what_the_autopilot_streams_and_nothing_reads_it_is_asked_to_stop(autopilot) -> None:
    autopilot.up()
    streamed = [raw_imu(), meminfo()] * STREAMED_AFTER
    sent = autopilot.tick(*streamed, power_status())  # POWER_STATUS heard once: not yet
    imu2 = mavlink.MAVLink_scaled_imu2_message(0, 1, 2, 3, 4, 5, 6, 7, 8, 9)
    sent += autopilot.tick(*[imu2] * STREAMED_AFTER, sender=(255, 190))  # a GCS's
    assert stops(sent) == {mavlink.MAVLINK_MSG_ID_RAW_IMU: (-1.0, 1, 1),
                           mavlink.MAVLINK_MSG_ID_MEMINFO: (-1.0, 1, 1)}
    said = [m.string for m in autopilot.mail if m.name == "MAVLINK_LINK"
            and "stop streaming" in m.string]
    assert said == ["asked the autopilot to stop streaming RAW_IMU, MEMINFO on this link: "
                    "the companion reads none of them"]
    assert autopilot.bridge.link.stats.skimmed == 3 * STREAMED_AFTER + 1  # all unread
    # what it reads is never asked to stop, however often it comes
    attitude = mavlink.MAVLink_attitude_message(0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.1)
    assert stops(autopilot.tick(*[attitude] * 5, *[power_status()] * 2)) == {
        mavlink.MAVLINK_MSG_ID_POWER_STATUS: (-1.0, 1, 1)}


def test_a_stream_still_coming_is_asked_again_a_few_times_then_left(autopilot) -> None:
    autopilot.up()
    asked = [len(stops(autopilot.tick(*[raw_imu()] * STREAMED_AFTER)))]
    for _ in range(2 * STOP_TRIES):  # the autopilot takes no notice
        asked.append(len(stops(autopilot.tick(autopilot.heartbeat(),
                                              *[raw_imu()] * STREAMED_AFTER,
                                              dt=STOP_RETRY_S / 2 + 0.01))))
    assert sum(asked) == STOP_TRIES
    assert asked[:4] == [1, 0, 1, 0]  # not again within STOP_RETRY_S


def test_a_protocols_periodic_requests_are_not_taken_for_streams(autopilot) -> None:
    """ArduPilot sends a TIMESYNC every few seconds and has no interval to stop it: asked,
    it would say "No ap_message for mavlink id (111)" to every ground station."""
    autopilot.up()
    timesync = mavlink.MAVLink_timesync_message(0, 123456789)
    assert not stops(autopilot.tick(*[timesync] * (STREAMED_AFTER + 2)))


def test_nothing_is_asked_before_the_companions_own_streams_are_acknowledged(
        autopilot) -> None:
    autopilot.up(acknowledged=False)
    assert not stops(autopilot.tick(*[raw_imu()] * STREAMED_AFTER))
    assert mavlink.MAVLINK_MSG_ID_RAW_IMU in stops(autopilot.tick(
        mavlink.MAVLink_command_ack_message(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
                                            mavlink.MAV_RESULT_ACCEPTED)))


def test_a_link_recorded_to_a_tlog_keeps_every_stream(autopilot) -> None:
    frames: list[bytes] = []
    autopilot.bridge.link.recorder = frames.append
    autopilot.up()
    assert not stops(autopilot.tick(*[raw_imu(), meminfo()] * 5))
    assert sum(f[7] == mavlink.MAVLINK_MSG_ID_RAW_IMU for f in frames) == 5


@pytest.mark.slow
def test_the_real_ardupilot_stops_the_streams_the_companion_asks_it_to(real_sitl) -> None:
    """ArduPilot Rover SITL, the bridge on SERIAL1 with the defaults: every message asked to
    stop stops after one request, and the link then carries nothing the companion skims."""
    from tests.support.ardupilot import RealOperator

    sitl = real_sitl(model="motorboat", speedup=5)
    clock = SimClock(0.0)
    bus = Bus(clock)
    bus.subscribe("test", ["*"])
    config = BridgeConfig(connect=f"tcp:127.0.0.1:{sitl.ports.serial1}")
    with RealOperator(sitl.ports.serial0) as op:  # SERIAL0 first: it starts the SITL's clock
        bridge = MavlinkBridge(bus, config, ORIGIN)
        link, supervisor = bridge.link, bridge.supervisor
        skimmed: list[tuple[float, int]] = []  # (wall s, message id) of each unread frame

        class Noted(dict):
            def __setitem__(self, key: tuple[int, int, int], count: int) -> None:
                skimmed.append((time.monotonic() - start, key[2]))
                super().__setitem__(key, count)

        link.mav.unread = Noted()
        try:
            start = time.monotonic()
            while True:
                wall = time.monotonic() - start
                assert wall < 40.0, f"asked {supervisor.stops}; operator {dict(op.counts)}"
                op.poll(0.02)
                clock.set(wall)
                bridge.receive(clock.now())
                bridge.send([], clock.now())
                last = max((asked for asked, _ in supervisor.stops.values()), default=None)
                if last is not None and wall - last > 2 * STOP_RETRY_S:
                    break
        finally:
            bridge.close()
        texts = op.texts()
    mail = bus.fetch("test")
    names = {mavlink.mavlink_map[i].msgname: tries for i, (_, tries) in supervisor.stops.items()}
    end = max(asked for asked, _ in supervisor.stops.values()) + STOP_RETRY_S
    late = {mavlink.mavlink_map[i].msgname for t, i in skimmed if t > end}
    said = [m.string for m in mail if m.name == "MAVLINK_LINK" and "stop streaming" in m.string]
    print(f"\n[sitl] asked to stop {names}; {len(skimmed)} frames unread in all, "
          f"{sum(t > end for t, _ in skimmed)} of {sorted(late)} after the last stop's "
          f"{STOP_RETRY_S:g} s; said {said}")
    assert {"RAW_IMU", "MEMINFO", "POWER_STATUS"} <= set(names)
    assert set(names.values()) == {1}, "an autopilot that stops a stream is asked once"
    assert late <= {"TIMESYNC"}, "nothing unread comes once the streams are stopped"
    assert not [m for m in mail if m.name == "MAVLINK_WARNING"]
    assert not [t for t in texts if "ap_message" in t], "a stop refused, said to the GCS"
