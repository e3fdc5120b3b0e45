"""Status events as the operator reads them: one English line each, and the severity a ground
station gets it with (None: console only, since the ground station hears the autopilot itself).

Text is for people; programs read the events (``status.py``) or their TUNNEL encoding.
"""

from __future__ import annotations

from collections.abc import Callable

from mavhelm.companion.status import (
    NO_SOURCE,
    Alert,
    Armed,
    AutopilotMode,
    AutopilotText,
    Event,
    Goal,
    HandedBack,
    HelmReloaded,
    HelmState,
    LinkNote,
    LinkUp,
    MissionEnded,
    NavFailure,
    NavSource,
    NavWarning,
    RemoteFlagPosted,
    SenderRefused,
    Severity,
    TaskEnded,
    TaskEvent,
    TaskStarted,
    ThirdPartyReply,
)


def _goal(e: Goal) -> str | None:
    if not e.goal:
        return None  # only who: the line comes with the goal
    return f"{e.owner} steers: {e.goal}" if e.owner else e.goal


def _nav_source(e: NavSource) -> str:
    if e.source == NO_SOURCE:
        return f"nav {e.key}: no source (none in its priority queue is fresh)"
    return f"nav {e.key} from {e.source}"


LINES: dict[type, Callable] = {
    LinkNote: lambda e: e.text,
    LinkUp: lambda e: "autopilot link up" if e.up else "autopilot link DOWN",
    AutopilotMode: lambda e: f"autopilot mode {e.mode}",
    Armed: lambda e: "autopilot armed" if e.armed else "autopilot disarmed",
    HelmState: lambda e: f"helm {e.status}",
    TaskStarted: lambda e: f"task {e.name} started",
    TaskEnded: lambda e: f"task {e.name} ended: {e.how}",
    TaskEvent: lambda e: f"task event {e.task}: {e.text}" if e.text else f"task event {e.task}",
    Goal: _goal,
    Alert: lambda e: f"{e.source}: {e.text}",
    MissionEnded: lambda e: f"MISSION ENDED ({e.task} holds the vehicle)",
    HelmReloaded: lambda e: f"helm reloaded: {e.text}",
    HandedBack: lambda e: f"vehicle handed back to the autopilot in {e.mode}",
    RemoteFlagPosted: lambda e: f"flag {e.flag} posted by the ground station",
    ThirdPartyReply: lambda e: f"third party {e.text}",
    AutopilotText: lambda e: f"autopilot says: {e.text}",
    NavSource: _nav_source,
    NavWarning: lambda e: f"NAV_WARNING: {e.text}",
    NavFailure: lambda e: f"NAVIGATION FAILURE: {e.why}",
    SenderRefused: lambda e: (f"REFUSED {e.what} from {e.sender}: {e.why} "
                              f"({e.count} refused so far)"),
}
"""Each kind of event as a line (a snapshot is not news: it has none)."""

GCS_SEVERITY: dict[type, Severity] = {
    HelmState: Severity.NOTICE,
    MissionEnded: Severity.NOTICE,
    HandedBack: Severity.NOTICE,
    HelmReloaded: Severity.NOTICE,
    RemoteFlagPosted: Severity.INFO,
    ThirdPartyReply: Severity.INFO,
    Goal: Severity.INFO,
    TaskEvent: Severity.WARNING,
    TaskStarted: Severity.INFO,
    TaskEnded: Severity.INFO,
    NavWarning: Severity.WARNING,
    NavFailure: Severity.ERROR,
    SenderRefused: Severity.WARNING,
}
"""The helm's events a ground station is told about; alerts carry their own severity. A NAV
source is console only: every queue starts without one, and the tasks' starvation (an
``_ERROR``) is what the operator must hear."""


def line(event: Event) -> str | None:
    """The event in words, or None if it is not said."""
    render = LINES.get(type(event))
    return None if render is None else render(event)


def gcs_severity(event: Event) -> Severity | None:
    """The MAV_SEVERITY the event's line goes to the ground station with, or None."""
    if isinstance(event, Alert):
        return event.severity
    return GCS_SEVERITY.get(type(event))
