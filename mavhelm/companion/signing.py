"""MAVLink 2 message signing: the key, its file, and a link set up to sign.

On a radio anyone can send MAVLink; a signed packet carries a SHA-256 signature over the
packet, a secret key and a 48-bit timestamp, so only a holder of the key can make one, and
pymavlink refuses one whose timestamp is not newer than the last from the same (link id,
system, component): a recorded packet sent again is not signed any more. The key is derived
from a passphrase as MAVProxy's ``signing setup PASSPHRASE`` does (SHA-256 of it), so the
operator's MAVProxy and the companion share one passphrase. The key lives in a file of its
own, readable by its owner alone (refused otherwise, as ssh refuses a private key others can
read), never in the mission and never in a log.
"""

from __future__ import annotations

import hashlib
import os
import stat
import time
import types
from pathlib import Path

from pymavlink.dialects.v20 import ardupilotmega as mavlink

EPOCH_2015 = 1420070400
"""The signing timestamp counts from 2015-01-01 00:00 UTC ..."""
TICKS_PER_S = 100_000
"""... in units of 10 µs."""
KEY_FILE_MAX = 4096
LINK_ID = 191
"""The companion's signing link id: one stream (link id, system, component) per sender."""


class KeyFileError(ValueError):
    """A key file that cannot be used; the message says why (never what is in it)."""


def signing_timestamp(unix_s: float | None = None) -> int:
    """Now (or ``unix_s``) as a signing timestamp."""
    now = time.time() if unix_s is None else unix_s
    return int((max(now, EPOCH_2015) - EPOCH_2015) * TICKS_PER_S)


def passphrase_key(passphrase: str) -> bytes:
    """The 32-byte key of a passphrase, as MAVProxy derives it."""
    return hashlib.sha256(passphrase.encode("ascii")).digest()


def read_key(path: str | Path) -> bytes:
    """The key from a file holding one passphrase (one word of printable ASCII, the word
    MAVProxy's ``signing setup`` takes). KeyFileError if it is not a regular file, is
    readable or writable by group or others, or does not hold exactly one such word."""
    path = Path(path).expanduser()
    try:
        info = os.stat(path)
    except OSError as exc:
        raise KeyFileError(f"signing key file {path}: {exc.strerror or exc}") from None
    if not stat.S_ISREG(info.st_mode):
        raise KeyFileError(f"signing key file {path} is not a regular file")
    if info.st_mode & 0o077:
        raise KeyFileError(f"signing key file {path} is accessible by group or others "
                           f"(mode {stat.S_IMODE(info.st_mode):04o}): chmod 600 it")
    if info.st_size > KEY_FILE_MAX:
        raise KeyFileError(f"signing key file {path} is larger than {KEY_FILE_MAX} bytes")
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise KeyFileError(f"signing key file {path}: {exc.strerror or exc}") from None
    words = data.split()
    if len(words) != 1 or not all(33 <= b < 127 for b in words[0]):
        raise KeyFileError(f"signing key file {path} must hold one passphrase: one word of "
                           "printable ASCII")
    return passphrase_key(words[0].decode("ascii"))


def signature(msg: mavlink.MAVLink_message) -> str:
    """How a received packet is signed: "valid" (with our key, and newer than the last from its
    stream), "other" (a signature that is not valid: another key, or a replay; or we hold no
    key) or "none" (unsigned)."""
    if msg.get_signed():
        return "valid"
    header = msg.get_header()
    flags = getattr(header, "incompat_flags", 0) if header is not None else 0
    return "other" if flags & mavlink.MAVLINK_IFLAG_SIGNED else "none"


def _accept_for_checking(mav: mavlink.MAVLink, msg_id: int) -> bool:
    """pymavlink passes unsigned (and badly signed) packets on, marked unsigned: whether one
    is obeyed is the sender check's decision, which answers a refused command."""
    return True


NEW_STREAM_SLACK = 6_000_000
"""A new stream's first timestamp may be this much (one minute) behind ours (the spec's rule)."""


def check_signature(mav: mavlink.MAVLink, msgbuf: bytearray, src_system: int,
                    src_component: int) -> bool:
    """pymavlink's ``MAVLink.check_signature`` with the signature checked before the stream's
    timestamp is advanced, as the MAVLink C library does: pymavlink advances it first, so one
    forged packet with a far-future timestamp would make every genuine packet of that sender
    look like a replay from then on."""
    signing = mav.signing
    assert signing.secret_key is not None
    digest = hashlib.sha256(signing.secret_key + bytes(msgbuf[:-6])).digest()[:6]
    if digest != bytes(msgbuf[-6:]):
        return False
    link_id = msgbuf[-13]
    timestamp = int.from_bytes(bytes(msgbuf[-12:-6]), "little")
    stream = (link_id, src_system, src_component)
    last = signing.stream_timestamps.get(stream)
    if last is not None and timestamp <= last:
        return False  # a replay, or out of order
    if last is None and timestamp + NEW_STREAM_SLACK < signing.timestamp:
        return False  # a new stream far in the past: a recording
    signing.stream_timestamps[stream] = timestamp
    signing.timestamp = max(signing.timestamp, timestamp)
    return True


def enable_signing(mav: mavlink.MAVLink, key: bytes, link_id: int = LINK_ID) -> None:
    """Sign everything ``mav`` sends with ``key``, and check the signatures of what it reads
    (``msg.get_signed()``); the timestamp starts at the wall clock's."""
    mav.check_signature = types.MethodType(check_signature, mav)  # type: ignore[method-assign]
    mav.signing.secret_key = key
    mav.signing.sign_outgoing = True
    mav.signing.allow_unsigned_callback = _accept_for_checking
    mav.signing.link_id = link_id
    keep_time(mav)


def keep_time(mav: mavlink.MAVLink, unix_s: float | None = None) -> None:
    """Never let the signing timestamp fall behind the wall clock: it advances by one per
    packet sent, and an autopilot refuses a new stream more than a minute behind its own."""
    if mav.signing.secret_key is not None:
        mav.signing.timestamp = max(mav.signing.timestamp, signing_timestamp(unix_s))


def send_setup_signing(mav: mavlink.MAVLink, target: tuple[int, int], key: bytes) -> None:
    """SETUP_SIGNING to the autopilot: it stores the key and signs from then on (what
    MAVProxy's ``signing setup`` sends)."""
    mav.setup_signing_send(target[0], target[1], list(key), signing_timestamp())
