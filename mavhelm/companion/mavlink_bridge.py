"""Every public name of ``mavhelm.companion.bridge``, under the module path that code written
before the package (``remote``, ``serial_instruments``) still imports; nothing in this tree
imports it otherwise, and it goes once those imports name the package."""

from mavhelm.companion.bridge import *  # noqa: F403
from mavhelm.companion.bridge import __all__  # noqa: F401
