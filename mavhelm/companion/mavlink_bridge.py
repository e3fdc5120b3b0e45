"""Names of ``mavhelm.companion.bridge`` for ``remote`` and ``serial_instruments``, whose own
imports move to the package when those modules are next changed; nothing else imports this."""

from mavhelm.companion.bridge import (
    CMD_RESTART_HELM,
    COMPANION_COMPONENT,
    FAR_FROM_ORIGIN_M,
    ROVER_MODE_NUMBERS,
    ROVER_MODES,
)

__all__ = ["CMD_RESTART_HELM", "COMPANION_COMPONENT", "FAR_FROM_ORIGIN_M",
           "ROVER_MODE_NUMBERS", "ROVER_MODES"]
