"""Bus variable names that more than one layer speaks: what pNav publishes and the helm reads,
what the link posts and the helm obeys. One spelling, so a typo cannot split a conversation."""

from __future__ import annotations

from typing import Final

NAV_X: Final = "NAV_X"
NAV_Y: Final = "NAV_Y"
NAV_YAW: Final = "NAV_YAW"
NAV_HEADING: Final = "NAV_HEADING"
NAV_DEPTH: Final = "NAV_DEPTH"
"""Metres below the sea surface, positive down (depth = tide − Z, spec 2.3.1)."""
NAV_PITCH: Final = "NAV_PITCH"
"""Radians, positive nose up."""
NO_SOURCE: Final = "NONE"
"""Value of ``NAV_<K>_SOURCE`` when every source in that key's priority queue has timed out."""

HELM_ONLINE: Final = "HELM_ONLINE"
"""1 while the helm may actuate (link up, autopilot armed in an online mode), else 0."""

MAIN_ACTUATORS: Final = ("RUDDER", "THRUST", "ELEVATOR")


def source_variable(name: str) -> str:
    """Where pNav declares which source feeds a NAV variable (``NAV_X`` → ``NAV_X_SOURCE``)."""
    return f"{name}_SOURCE"


def desired(actuator: str) -> str:
    """The helm's output variable for an actuator (``RUDDER`` → ``DESIRED_RUDDER``)."""
    return f"DESIRED_{actuator}"

NAVIGATION_FAILURE: Final = "NAVIGATION_FAILURE"
"""pNav's reason, posted once, when its filters go off-line for good (spec 2.2.11)."""
END_MISSION: Final = "EndMission"
"""Posted to end the mission (spec 2.2.11): it starts every EndMission task of the helm."""

POSTED_FAMILIES: Final = (
    "GPS", "INS", "AP", "NAV", "DESIRED", "HELM", "MAVLINK", "TASK", "EKF", "LSQ", "WHEEL",
    "TRUTH", "NAVIGATION", "MISSION", "THIRDPARTY", "RESTART",
)
"""Prefixes of the variable families the apps post (``<FAMILY>_*``): the MAVLink bridge's
(GPS, INS, AP, WHEEL, TRUTH, MAVLINK), pNav's and its filters' (NAV, EKF, LSQ, NAVIGATION),
the helm's (DESIRED, HELM, TASK, MISSION) and the requests it hears (THIRDPARTY, RESTART).
A source of its own (an
iSerial instrument) named after one would post into it, and pNav would route those variables
as the filters' or the bridge's."""


def posted_family(name: str) -> str | None:
    """The family whose ``<FAMILY>_*`` variables ``<name>_*`` would collide with, if any."""
    upper = name.upper()
    for family in POSTED_FAMILIES:
        if upper == family or upper.startswith(family + "_"):
            return family
    return None
