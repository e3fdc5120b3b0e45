"""The navigator (pNav): sensors in, the ``NAV_*`` family out (spec section 2)."""

from mavhelm.nav.navigator import Navigator
from mavhelm.nav.priority_queue import DEFAULT_TIMEOUT, PriorityQueue, Source

__all__ = ["DEFAULT_TIMEOUT", "Navigator", "PriorityQueue", "Source"]
