"""The bridge's structure: its config comes from the iMAVLink schema alone, each incoming
message type has one handler, ``send_tunnel`` sends what another app hands it (and refuses
what MAVLink cannot carry), and no companion module reads another object's private names."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.bridge import IMAVLINK_SCHEMA, BridgeConfig, MavlinkBridge
from mavhelm.companion.bridge.config import schema_defaults
from mavhelm.companion.bridge.handlers import FROM_AUTOPILOT, TO_COMPANION
from mavhelm.companion.link import AutopilotLink
from mavhelm.core.bus import Bus
from mavhelm.core.clock import SimClock
from mavhelm.core.geodesy import Origin
from mavhelm.core.params import Number, Param, Schema

COMPANION = Path(__file__).resolve().parents[1] / "mavhelm" / "companion"


def test_every_setting_is_an_attribute_with_the_schemas_default():
    config = BridgeConfig()
    for param in IMAVLINK_SCHEMA.params:
        expected = list(param.default) if param.repeat else param.default
        assert getattr(config, param.attribute) == expected, param.name


def test_a_setting_added_to_the_schema_is_read_with_no_other_change(monkeypatch):
    """One declaration: the new Param is parsed, defaulted and refused like every other."""
    from mavhelm.companion.bridge import config as config_module
    from mavhelm.core.mission import MissionError, parse_mission

    schema = Schema("iMAVLink", (*IMAVLINK_SCHEMA.params,
                                 Param("Ballast", Number(0, 10), 2.0, "kg", "ballast")))
    monkeypatch.setattr(config_module, "IMAVLINK_SCHEMA", schema)
    assert BridgeConfig().ballast == 2.0
    block = parse_mission("ProcessConfig = iMAVLink\n{\nBallast = 4\n}\n", "b.moos")
    assert BridgeConfig.from_block(block.process("iMAVLink")).ballast == 4.0
    bad = parse_mission("ProcessConfig = iMAVLink\n{\nBallast = 40\n}\n", "b.moos")
    with pytest.raises(MissionError, match=r"^b.moos:3: Ballast must be a number in \[0, 10\]"):
        BridgeConfig.from_block(bad.process("iMAVLink"))
    assert "ballast" in schema_defaults(schema)


def test_an_unknown_keyword_is_refused():
    with pytest.raises(TypeError, match="no setting"):
        BridgeConfig(conect="tcp:127.0.0.1:1")
    with pytest.raises(AttributeError):
        _ = BridgeConfig().not_a_setting


def test_one_handler_per_message_type():
    for kind in (*FROM_AUTOPILOT, *TO_COMPANION):
        assert hasattr(mavlink, f"MAVLINK_MSG_ID_{kind}"), kind
    assert {"HEARTBEAT", "GPS_RAW_INT", "ATTITUDE", "GLOBAL_POSITION_INT", "DISTANCE_SENSOR",
            "WHEEL_DISTANCE", "SIMSTATE", "STATUSTEXT", "COMMAND_ACK"} <= set(FROM_AUTOPILOT)


class Capture:
    """A transport that keeps what is written."""

    def __init__(self) -> None:
        self.data = b""

    def open(self) -> None: ...
    def ready(self) -> bool:
        return True

    def read_into(self, buffer: memoryview) -> int:
        return 0

    def write(self, data: bytes) -> int:
        self.data += data
        return len(data)

    def close(self) -> None: ...
    def fileno(self) -> int | None:
        return None


def connected_bridge() -> tuple[MavlinkBridge, Capture]:
    transport = Capture()
    link = AutopilotLink("tcp:127.0.0.1:1", transport=transport)
    link.connect(0.0)
    bridge = MavlinkBridge(Bus(SimClock()), BridgeConfig(), Origin(56.0, -5.0), link)
    return bridge, transport


def test_send_tunnel_sends_one_tunnel_message():
    bridge, transport = connected_bridge()
    assert bridge.send_tunnel(32802, b"status", (255, 190))
    assert bridge.send_tunnel(32802, b"all")
    msgs = mavlink.MAVLink(None).parse_buffer(transport.data)
    assert [m.get_type() for m in msgs] == ["TUNNEL", "TUNNEL"]
    first, second = msgs
    assert (first.target_system, first.target_component, first.payload_type) == (255, 190,
                                                                                 32802)
    assert bytes(first.payload[:first.payload_length]) == b"status"
    assert (second.target_system, second.target_component) == (0, 0)


@pytest.mark.parametrize("payload_type, payload, target", [
    (70000, b"x", (0, 0)), (-1, b"x", (0, 0)), (1, b"x" * 129, (0, 0)), (1, b"x", (256, 0))])
def test_send_tunnel_refuses_what_mavlink_cannot_carry(payload_type, payload, target):
    bridge, transport = connected_bridge()
    bridge.bus.subscribe("test", ["MAVLINK_OUTPUT_REFUSED"])
    assert bridge.send_tunnel(payload_type, payload, target) is False
    assert transport.data == b""
    refused = bridge.bus.fetch("test")
    assert len(refused) == 1 and refused[0].string.startswith("TUNNEL not sent: ")


PYMAVLINKS_OWN = {("link.py", "_decode_plain")}
"""Functions that stand in for pymavlink's own code: the link's decoder of messages of numbers
fills in a message's frame fields (``_header``, ``_msgbuf``, ...) as pymavlink's ``decode``
does."""


def _private_reads(path: Path) -> list[str]:
    """``obj._name`` where obj is not ``self``/``cls`` (dunders aside)."""
    tree = ast.parse(path.read_text())
    exempt = {id(node) for fn in ast.walk(tree) if isinstance(fn, ast.FunctionDef)
              and (path.name, fn.name) in PYMAVLINKS_OWN for node in ast.walk(fn)}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr.startswith("_") \
                and not node.attr.startswith("__") and id(node) not in exempt \
                and not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls")):
            found.append(f"{path.name}:{node.lineno}: .{node.attr}")
    return found


def test_no_private_attribute_is_read_across_objects_in_companion():
    files = sorted(COMPANION.rglob("*.py"))
    assert [hit for f in files for hit in _private_reads(f)] == []


def test_replace_copies_with_changes():
    config = BridgeConfig(connect="tcp:127.0.0.1:5760")
    moved = config.replace(connect="udp:127.0.0.1:14550")
    assert moved.connect == "udp:127.0.0.1:14550" and config.connect == "tcp:127.0.0.1:5760"
    assert moved.streams == config.streams
    with pytest.raises(TypeError):
        config.replace(conect="x")
