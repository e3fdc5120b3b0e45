"""Loopback ports nobody is listening on, for a test's server or a link it points at.

The port is closed again before it is returned, so another process could take it in between;
on a test machine the kernel hands out ephemeral ports in turn, which makes that rare enough.
"""

from __future__ import annotations

import socket


def free_port(kind: socket.SocketKind = socket.SOCK_STREAM, host: str = "127.0.0.1") -> int:
    """A port the kernel just gave out for ``kind`` (TCP by default, ``socket.SOCK_DGRAM`` for
    UDP) on ``host``."""
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def free_udp_port(host: str = "127.0.0.1") -> int:
    """A free UDP port on ``host``."""
    return free_port(socket.SOCK_DGRAM, host)
