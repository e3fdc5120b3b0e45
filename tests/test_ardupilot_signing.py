"""Only the operator commands the boat, against the real ArduPilot Rover SITL (issue 19).

The companion (``mavhelm run``, its own process, on SERIAL1) holds the signing key in a file,
requires signed input and gives the key to the unsigned autopilot (``SetupSigning``), which
signs from then on. A signed ground station on SERIAL0 hands over; the companion drives the
demo to its end, every packet of its own that reaches the ground station signed. An unsigned
COMMAND_LONG to the companion (ArduPilot accepts unsigned on SERIAL0 and routes it on) is
refused, and so is a signed one sent again; MAVProxy with the passphrase, on SERIAL2 where
ArduPilot itself now demands signatures, takes the vehicle back and hands it over again.

Needs MAVHELM_ARDUPILOT (see tests/ardupilot.py); skips without it.
"""

from __future__ import annotations

import re
import time
from collections.abc import Callable
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.signing import passphrase_key
from tests.support.ardupilot import CompanionProcess, RealOperator
from tests.support.interop_helpers import MavproxyProcess

pytestmark = pytest.mark.slow

DEMO = Path(__file__).resolve().parent.parent / "examples" / "demo.moos"
PASSPHRASE = "only-the-operator"
KEY = passphrase_key(PASSPHRASE)
COMPANION = (1, 191)
SPEEDUP = 20
WALL_S = 60.0


class SignedOperator(RealOperator):
    """The operator's ground station on SERIAL0, signing with the key; it also keeps the
    companion's ACKs and whether each packet of the companion it hears is validly signed."""

    def __init__(self, port: int) -> None:
        super().__init__(port, heartbeat_s=1.0 / SPEEDUP)
        self.conn.setup_signing(KEY, sign_outgoing=True,
                                allow_unsigned_callback=lambda mav, msg_id: True)
        self.companion_acks: list[tuple[int, int]] = []
        self.companion_signed: list[bool] = []
        self.autopilot_signed: list[bool] = []

    def _handle(self, msg, now: float) -> None:
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        if src == COMPANION:
            self.companion_signed.append(msg.get_signed())
            if msg.get_type() == "COMMAND_ACK":
                self.companion_acks.append((msg.command, msg.result))
        elif src == (1, 1) and msg.get_type() == "HEARTBEAT":
            self.autopilot_signed.append(msg.get_signed())
        super()._handle(msg, now)

    def command_packet(self, command: int, param1: float, signed: bool = True) -> bytes:
        """A fresh COMMAND_LONG to the companion, signed or not."""
        signing = self.conn.mav.signing
        signing.sign_outgoing = signed
        try:
            return bytes(mavlink.MAVLink_command_long_message(
                *COMPANION, command, 0, param1, 0, 0, 0, 0, 0, 0).pack(self.conn.mav))
        finally:
            signing.sign_outgoing = True

    def exchange(self, packet: Callable[[], bytes], timeout_s: float = 20.0,
                 retry_s: float = 2.0) -> tuple[tuple[int, int], bytes]:
        """Send ``packet()`` until the companion answers, again every ``retry_s`` as a person
        would (at x20 under load ArduPilot may drop what it routes when a port's buffer is
        full); the answer and the bytes last sent."""
        seen = len(self.companion_acks)
        start = time.monotonic()
        while True:
            sent = packet()
            self.conn.write(sent)
            try:
                self.wait_until(lambda: len(self.companion_acks) > seen, retry_s,
                                "the companion's COMMAND_ACK")
                return self.companion_acks[seen], sent
            except TimeoutError:
                if time.monotonic() - start > timeout_s:
                    raise


def signed_demo(folder: Path) -> Path:
    """examples/demo.moos with signing required and a harmless remote flag."""
    key = folder / "signing.key"
    key.write_text(PASSPHRASE + "\n")
    key.chmod(0o600)
    text = DEMO.read_text().replace(
        "    MaxTurnRate = 45", "    MaxTurnRate = 45\n    SigningKeyFile = signing.key\n"
        "    RequireSigning = true\n    SetupSigning = true\n    RemoteFlag = Noted", 1)
    assert "SigningKeyFile" in text
    mission = folder / "signed.moos"
    mission.write_text(text)
    return mission


def test_a_signed_link_the_demo_driven_and_strangers_replays_refused(real_sitl, tmp_path):
    sitl = real_sitl(model="motorboat", speedup=SPEEDUP, params={"SIM_WIND_SPD": 0})
    op = SignedOperator(sitl.ports.serial0)
    op.request_streams(4)
    op.wait_until(lambda: op.heartbeats > 0, 10.0, "the autopilot's first HEARTBEAT")
    comp = CompanionProcess(signed_demo(tmp_path), sitl.ports.serial1, tmp_path / "logs")

    def line(fragment: str, nth: int = 1, timeout_s: float = WALL_S) -> str:
        op.wait_until(lambda: comp.find(fragment, nth) is not None or not comp.running(),
                      timeout_s, f"companion line {fragment!r}")
        hit = comp.find(fragment, nth)
        assert hit is not None, f"the companion exited:\n{comp.output()}"
        return hit[1]

    try:
        line("signing key sent to it (SETUP_SIGNING)")
        op.wait_until(lambda: any(op.autopilot_signed[-3:]) and all(op.autopilot_signed[-3:]),
                      15.0, "the autopilot's HEARTBEATs signed with the key")
        with MavproxyProcess(f"tcp:127.0.0.1:{sitl.ports.serial2}", tmp_path) as mavproxy:
            mavproxy.wait_for(r"Detected vehicle 1:1", 20)
            mavproxy.send(f"signing key {PASSPHRASE}")
            op.hand_over("GUIDED", timeout_s=WALL_S)
            line("helm ONLINE")
            line("task South started")

            # MAVProxy with the key takes the vehicle back, and hands it over again
            mavproxy.send("mode HOLD")
            line("helm offline: autopilot in HOLD")
            mavproxy.send("mode GUIDED")
            line("helm ONLINE", nth=2)

            # an unsigned command to the companion: ArduPilot routes it, the companion refuses
            user_2 = mavlink.MAV_CMD_USER_2
            ack, _ = op.exchange(lambda: op.command_packet(user_2, 1, signed=False))
            assert ack == (user_2, mavlink.MAV_RESULT_DENIED)
            refused = line("REFUSED COMMAND_LONG USER_2 from 255:190")
            assert "not signed, and RequireSigning is on" in refused
            # a signed one is obeyed; the same bytes sent again are refused
            ack, packet = op.exchange(lambda: op.command_packet(user_2, 1))
            assert ack == (user_2, mavlink.MAV_RESULT_ACCEPTED)
            line("flag Noted posted by the ground station")
            settle = time.monotonic() + 0.5     # a straggling answer to a retry comes now
            while time.monotonic() < settle:
                op.poll(0.02)
            flags = len(comp.find_all("flag Noted posted"))
            ack, _ = op.exchange(lambda: packet)
            assert ack == (user_2, mavlink.MAV_RESULT_DENIED), "a replay is refused"
            assert len(comp.find_all("flag Noted posted")) == flags

            line("MISSION ENDED", timeout_s=2 * WALL_S)
        assert op.companion_signed and all(op.companion_signed), \
            "every packet of the companion's the operator heard was validly signed"
        started = [m for m in comp.find_all("task ") if m.rstrip().endswith("started")]
        assert [re.search(r"task (\w+) started", m).group(1) for m in started][:5] == [
            "InitialDelay", "MissionClock", "South", "North", "Home"]
    finally:
        code = comp.stop()
        op.close()
    assert code == 0, comp.output()
