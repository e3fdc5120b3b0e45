"""``mavhelm remote``'s screen: a ``RemoteState`` drawn as plain lines, no terminal codes."""

from __future__ import annotations

from mavhelm.companion.remote.state import (
    COMPANION_TIMEOUT_S,
    STEER_CHANNEL,
    THROTTLE_CHANNEL,
    VALUE_STALE_S,
    RemoteState,
)

KEY_HELP = ("keys: space ALL STOP (HOLD)   o GUIDED<->MANUAL   A arm   D D disarm   q quit",
            "      w/s thrust +/-   a/d rudder -/+ (MANUAL)   x centre   R restart helm")


def _age(now: float, then: float | None) -> str:
    if then is None:
        return "never"
    return f"{max(0.0, now - then):.0f} s ago"


def _link(s: RemoteState) -> str:
    if s.link_up:
        return "LINK UP"
    if not s.connected:
        return "NOT CONNECTED"
    if s.last_heartbeat is None:
        return "LINK DOWN (connected, no HEARTBEAT)"
    return f"LINK DOWN (no HEARTBEAT for {s.now - s.last_heartbeat:.0f} s)"


def _autopilot(s: RemoteState) -> list[str]:
    ap = f"autopilot  {_link(s)}"
    if s.mode is not None:
        ap += f"   mode {s.mode}   {'ARMED' if s.armed else 'disarmed'}"
    if s.mode_request is not None:
        ap += f"   (asking for {s.mode_request.mode})"
    lines = [ap]
    if s.vfr is not None and s.vfr_at is not None and s.now - s.vfr_at <= VALUE_STALE_S:
        speed, heading, throttle = s.vfr
        lines.append(f"           speed {speed:.2f} m/s   heading {heading:.0f} deg   "
                     f"throttle {throttle} %")
    return lines


def _helm(s: RemoteState) -> list[str]:
    """The companion's state, as its typed status channel told it."""
    heard = s.companion_heard
    if heard is None:
        return [f"helm       (no companion heard at {s.companion[0]}:{s.companion[1]})"]
    h = s.helm_status
    stale = "" if s.now - heard <= COMPANION_TIMEOUT_S else \
        f"   [companion silent for {s.now - heard:.0f} s]"
    lines = [f"helm       {s.helm or '(no status yet)'}{stale}",
             f"tasks      {', '.join(h.tasks) if h.tasks else '-'}"]
    if h.goal:
        lines.append(f"goal       {h.owner} steers: {h.goal}" if h.owner else
                     f"goal       {h.goal}")
    if h.nav_failure is not None:
        lines.append(f"nav        NAVIGATION FAILURE: {h.nav_failure}")
    elif h.nav_lost:
        lines.append(f"nav        lost (no source): {', '.join(h.nav_lost)}")
    if h.refused:
        lines.append(f"refused    {h.refused} command{'s' if h.refused != 1 else ''} from "
                     "senders not allowed or not signed")
    if s.mission_ended:
        lines.append(f"           {s.mission_ended}")
    return lines


def _values(s: RemoteState) -> list[str]:
    v = s.values
    if not v:
        return []

    def num(name: str, fmt: str) -> str:
        """The value as ``fmt`` (``.1f``, ``+.0f``), never as ``-0.0``."""
        if name not in v:
            return "-"
        return format(round(v[name][0], int(fmt[-2])) + 0.0, fmt)

    newest = max(t for _, t in v.values())
    driving = "" if s.helm_online() else "   (the helm's last, not driving)"
    return [f"nav        x {num('NAV_X', '.1f')} m   y {num('NAV_Y', '.1f')} m   "
            f"heading {num('NAV_HDG', '.0f')} deg   speed {num('NAV_SPEED', '.2f')} "
            f"m/s   ({_age(s.now, newest)})",
            f"desired    rudder {num('DES_RUDDER', '+.1f')}   "
            f"thrust {num('DES_THRUST', '+.1f')}{driving}"]


def _sticks(s: RemoteState) -> str:
    if not (s.thrust or s.rudder):
        return "sticks     centred (no override)"
    return (f"sticks     thrust {s.thrust:+d} %  rudder {s.rudder:+d} %   (RC override ch"
            f"{THROTTLE_CHANNEL} {s.pwm(s.thrust)}, ch{STEER_CHANNEL} {s.pwm(s.rudder)})")


def _texts(s: RemoteState, room: int | None) -> list[str]:
    texts = list(s.texts)
    if room is not None:
        texts = texts[-max(1, room):]
    if not texts:
        return ["(no messages yet)"]
    return [f"{max(0.0, s.now - at):5.0f}s  {source:<5} {text}" for at, source, text in texts]


def render(state: RemoteState, width: int = 100, height: int | None = None) -> list[str]:
    """The console as plain lines, each at most ``width`` characters."""
    s = state
    rule = "-" * max(0, width)
    lines = [f"mavhelm remote  {s.url}  as GCS {s.sysid}:{s.compid}", rule]
    lines += _autopilot(s) + _helm(s) + _values(s)
    lines += [_sticks(s), rule]
    lines += [f"> {text}" for _, text in s.notes]
    lines.append(rule)
    room = None if height is None else height - len(lines) - 1 - len(KEY_HELP)
    lines += _texts(s, room)
    lines += [rule, *KEY_HELP]
    return [line[:width] for line in lines]
