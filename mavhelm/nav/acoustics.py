"""The original pNav's ``ProcessConfig = Acoustics`` block: its beacons, as pNav's BEACONs.

The original surveys its transponders in a block of their own::

    ProcessConfig = Acoustics
    {
        Beacon = A
        [
            POS = 0,0,-30
            TX  = CH3
            TAT = 0.125
        ]
    }

Each ``Beacon`` becomes a ``BEACON = <TX channel> @ x,y,z TAT=s`` of the pNav block: the
channel is the beacon's id in the travel-time variables (``LBL_TWTT_3``), as the original matched
replies to beacons by channel; the name (``A``) is only the original's label.
"""

from __future__ import annotations

from typing import Final

from mavhelm.core.mission import Block, Entry
from mavhelm.core.params import Number
from mavhelm.nav.ekf import Beacon
from mavhelm.nav.sensors import BEACON

BLOCK: Final = "Acoustics"
FIELDS: Final = ("POS", "TX", "TAT")


def _groups(block: Block) -> list[tuple[Entry, dict[str, Entry]]]:
    groups: list[tuple[Entry, dict[str, Entry]]] = []
    for entry in block.entries:
        key = entry.key.upper()
        if key == "BEACON":
            groups.append((entry, {}))
            continue
        if key not in FIELDS:
            raise entry.error(f"unknown setting {entry.key!r} for the Acoustics block (known: "
                              "Beacon = name, then POS, TX and TAT)")
        if not groups:
            raise entry.error(f"{entry.key} comes before any Beacon = name")
        fields = groups[-1][1]
        if key in fields:
            raise entry.error(f"{entry.key} is already set at line {fields[key].line} for "
                              f"Beacon {groups[-1][0].value}; give each setting once")
        fields[key] = entry
    return groups


def acoustic_beacons(block: Block) -> list[Beacon]:
    """The beacons of an Acoustics block; a located MissionError for anything wrong."""
    beacons: list[Beacon] = []
    for head, fields in _groups(block):
        missing = [key for key in ("POS", "TX") if key not in fields]
        if missing:
            raise head.error(f"Beacon {head.value} needs {' and '.join(missing)}")
        tx = fields["TX"]
        channel = Number(1, 999, integer=True).parse_text(
            tx.value.strip().upper().removeprefix("CH"), tx, "TX (the reply channel, CHn)")
        tat = f" TAT={fields['TAT'].value.strip()}" if "TAT" in fields else ""
        pos = fields["POS"]
        beacons.append(BEACON.kind.parse(Entry("POS", f"{int(channel)} @ {pos.value}{tat}",
                                               pos.file, pos.line)))
    names = [b.name for b in beacons]
    for i, name in enumerate(names):
        if name in names[:i]:
            raise block.error(f"two beacons reply on channel {name}")
    return beacons
