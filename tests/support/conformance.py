"""One scripted MAVLink scenario, run against the real ArduPilot Rover SITL and ``mavhelm sim``.

``run_scenario(side)`` plays the same ground-station script (system 255) and companion script
(system 254, on the second port) against either side and returns what was observed, as a flat
``{key: value}`` dict. ``compare(real, sim)`` lists the keys whose values differ beyond their
tolerance; ``accepted_differences()`` reads the keys the simulator is allowed to differ on from
``docs/sim-differences.md`` (the one place they are listed, with the reason for each).

Time is always the autopilot's (``time_boot_ms`` of its messages), so a SITL running at
``--speedup N`` and the simulator stepped in lockstep are compared on the same axis. The driver
only waits for the autopilot clock; how that clock advances is the side's business:
``sides.RealSide`` polls sockets while the real binary runs, ``sides.SimSide`` steps the
simulator.

A plain helper module (not a test module), imported by tests/test_conformance.py.
"""

from __future__ import annotations

import fnmatch
import math
import re
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pymavlink.dialects.v20 import ardupilotmega as M

from tests.support.sides import COMPANION, GCS, Side

DIFFERENCES_DOC = Path(__file__).resolve().parents[2] / "docs" / "sim-differences.md"
WALL_LIMIT_S = 120.0  # a side that stops advancing its clock fails the run

# Parameters read by name: present ones are compared by value, absent ones must stay absent.
PARAM_NAMES = (
    "SERIAL1_PROTOCOL", "SERIAL2_PROTOCOL", "TURN_RADIUS", "WP_SPEED", "CRUISE_SPEED",
    "WP_RADIUS", "ATC_STR_RAT_FF", "ATC_SPEED_P", "GUID_TIMEOUT", "SYSID_MYGCS",
    "MAV_GCS_SYSID", "SYSID_THISMAV", "MAV_SYSID", "RC_OVERRIDE_TIME", "FS_GCS_ENABLE", "FS_ACTION",
    "FRAME_CLASS", "SERVO1_FUNCTION", "SERVO3_FUNCTION", "LOIT_RADIUS", "ATC_STR_RAT_MAX",
    "ATC_ACCEL_MAX", "INITIAL_MODE", "FENCE_TYPE", "FENCE_ENABLE", "FENCE_ACTION",
    "SIM_WIND_SPD", "SIM_WIND_DIR", "SIM_WIND_T", "SIM_WAVE_ENABLE", "SIM_WAVE_AMP",
    "SIM_WAVE_DIR", "SIM_WAVE_LENGTH", "SIM_WAVE_SPEED", "NO_SUCH_PARAM",
)

# Tolerances by key pattern (first match wins); a key with none must be equal.
TOLERANCES: tuple[tuple[str, float], ...] = (
    ("text_at:*", 1.6),          # first time a boot STATUSTEXT was heard, autopilot s
    ("startup.*_at", 1.6),        # boot milestones (1 Hz messages on the real side)
    ("*.first_accepted_at", 2.1),  # retried every 1-2 s
    ("guided.timeout_after*", 0.6),
    ("failsafe.after_silence", 1.2),  # the last heartbeat was up to 1 s before the silence
    ("streams.*_hz", 0.3),
    ("rc.release_after", 0.6),
    ("rc.zero_release_after", 0.4),
    ("rc.*servo1", 40.0),         # µs: RCn/SERVOn ranges differ slightly (see the doc)
    ("param:*", 1e-4),
    ("startup.boot_text_count", 1.0),
    ("attitude.yaw_bias*", 0.5),  # degrees
    # run_turn_rate_scenario: 10 % of the real rover's figures (rate mean 14.4, settled 16.7
    # deg/s; speed mean 2.05, settled 2.47 m/s)
    ("turn.rate_mean", 1.4),
    ("turn.rate_peak", 1.7),
    ("turn.rate_settled", 1.7),
    ("turn.speed_*", 0.2),
)


# Texts said on the autopilot's own schedule (boot, EKF failsafe): compared by when they were
# first heard (text_at:...), left out of the texts heard in a scripted step's window.
BOOT_TEXT = re.compile(r"^(EKF3 |AHRS: |GPS 1: |Set HOME |Field Elevation |Barometer |INS|"
                       r"Beginning INS|ArduPilot Ready|RCInput: |Calibrating barometer|"
                       r"ArduRover V|<board id>|EKF failsafe)")
HEARTBEAT_SETTLED_S = 1.5  # a (mode, base_mode, status) held shorter is a transient of the script


def _norm_text(text: str) -> str:
    """A STATUSTEXT with build-specific parts replaced, so texts compare across builds."""
    text = re.sub(r"^ArduRover V\S+ \(.*\)$", "ArduRover V<version>", text)
    text = re.sub(r"^[0-9a-f]{32}$", "<board id>", text)
    text = re.sub(r"free=\d+", "free=<n>", text)
    return text


@dataclass
class Record:
    """What the ground station heard from the autopilot (system 1, component 1)."""

    heartbeats: list[tuple[float, int, int, int]]
    texts: list[tuple[float, int, str]]
    acks: list[tuple[float, str, int, int]]
    sys_status: list[tuple[float, int, int, int]]
    gps: list[tuple[float, int, int, int, int]]
    yaw: list[tuple[float, float, float]]  # (t, ATTITUDE yaw, last SIMSTATE yaw), radians
    servos: list[tuple[float, list[int]]]
    params: dict[str, float]
    reached: list[float]
    companion_msgs: list[tuple[float, str]]  # (t, type) of what the companion's link carried
    forwarded: list[tuple[str, int]]  # (link, sysid) of other clients' heartbeats relayed
    global_pos: tuple[float, float] | None = None  # latest GLOBAL_POSITION_INT lat, lon (degE7)
    global_seen: int = 0
    # (t, ATTITUDE yawspeed rad/s, last VFR_HUD groundspeed m/s)
    rates: list[tuple[float, float, float]] = field(default_factory=list)
    groundspeed: float = 0.0


class Driver:
    """Plays the script on one side, on the autopilot's clock."""

    def __init__(self, side: Side) -> None:
        self.side = side
        self.t = 0.0  # autopilot seconds (time_boot_ms of the newest message)
        self.r = Record([], [], [], [], [], [], [], {}, [], [], [])
        self.gcs_heartbeats = True  # the GCS's heartbeat (a GCS failsafe is tested by silence)
        self._hb_due = 0.0
        self._attitude: tuple[float, float] | None = None
        self._wall0 = time.monotonic()

    # ------------------------------------------------------------------ receiving
    def pump(self) -> None:
        if time.monotonic() - self._wall0 > WALL_LIMIT_S:
            raise TimeoutError(f"scenario ran {WALL_LIMIT_S:g} s of wall time; autopilot at "
                               f"{self.t:.1f} s")
        if self.t >= self._hb_due:
            self._hb_due = self.t + 1.0
            conns = (self.side.gcs, self.side.companion) if self.gcs_heartbeats else (
                self.side.companion,)
            for conn in conns:
                conn.mav.heartbeat_send(M.MAV_TYPE_GCS, M.MAV_AUTOPILOT_INVALID, 0, 0,
                                        M.MAV_STATE_ACTIVE)
        for who, msg in self.side.pump():
            self._take(who, msg)

    def _take(self, who: str, msg: Any) -> None:
        kind = msg.get_type()
        if kind == "HEARTBEAT" and msg.get_srcSystem() in (GCS[0], COMPANION[0]):
            self.r.forwarded.append((who, msg.get_srcSystem()))
        if kind == "BAD_DATA" or (msg.get_srcSystem(), msg.get_srcComponent()) != (1, 1):
            return
        boot = getattr(msg, "time_boot_ms", None)
        if isinstance(boot, int) and boot / 1000.0 > self.t:
            self.t = boot / 1000.0
        t, r = self.t, self.r
        if kind == "COMMAND_ACK":
            r.acks.append((t, who, msg.command, msg.result))
        if who != "gcs":
            r.companion_msgs.append((t, kind))
            return
        if kind == "HEARTBEAT":
            r.heartbeats.append((t, msg.custom_mode, msg.base_mode, msg.system_status))
        elif kind == "STATUSTEXT":
            r.texts.append((t, msg.severity, _norm_text(msg.text)))
        elif kind == "SYS_STATUS":
            r.sys_status.append((t, msg.onboard_control_sensors_present,
                                 msg.onboard_control_sensors_enabled,
                                 msg.onboard_control_sensors_health))
        elif kind == "GPS_RAW_INT":
            r.gps.append((t, msg.fix_type, msg.satellites_visible, msg.eph, msg.epv))
        elif kind == "ATTITUDE":
            self._attitude = (t, msg.yaw)
            r.rates.append((t, msg.yawspeed, r.groundspeed))
        elif kind == "VFR_HUD":
            r.groundspeed = msg.groundspeed
        elif kind == "SIMSTATE" and self._attitude is not None:
            # ATTITUDE and SIMSTATE leave together (stream EXTRA1, in that order)
            if self._attitude[0] == t:
                r.yaw.append((t, self._attitude[1], msg.yaw))
            self._attitude = None
        elif kind == "SERVO_OUTPUT_RAW":
            r.servos.append((t, [getattr(msg, f"servo{i}_raw", 0) for i in range(1, 17)]))
        elif kind == "PARAM_VALUE":
            r.params[msg.param_id] = msg.param_value
        elif kind == "MISSION_ITEM_REACHED":
            r.reached.append(t)
        elif kind == "GLOBAL_POSITION_INT":
            r.global_pos = (msg.lat, msg.lon)
            r.global_seen += 1

    def until(self, t: float) -> None:
        while self.t < t:
            self.pump()

    def wait(self, pred: Callable[[], bool], max_s: float) -> bool:
        end = self.t + max_s
        while not pred():
            if self.t >= end:
                return False
            self.pump()
        return True

    # ------------------------------------------------------------------ sending
    def command(self, cmd: int, *params: float, conn: Any = None) -> int | None:
        """COMMAND_LONG to the autopilot; its ACK result (None if none within 2 s)."""
        conn = conn or self.side.gcs
        who = "gcs" if conn is self.side.gcs else "companion"
        n = len(self.r.acks)
        p = list(params) + [0.0] * (7 - len(params))
        conn.mav.command_long_send(1, 1, cmd, 0, *p)
        self.wait(lambda: any(c == cmd and w == who for _, w, c, _ in self.r.acks[n:]), 2.0)
        return next((res for _, w, c, res in self.r.acks[n:] if c == cmd and w == who), None)

    def set_mode(self, mode: int) -> int | None:
        return self.command(M.MAV_CMD_DO_SET_MODE, 1, mode)

    def mark(self) -> int:
        """A position in the texts heard, for texts_since()."""
        return len(self.r.texts)

    def texts_since(self, mark: int) -> list[str]:
        """Texts heard after mark, without the boot sequence's (compared by text_at:...)."""
        return [s for _, _, s in self.r.texts[mark:] if not BOOT_TEXT.match(s)]

    def next_heartbeat(self) -> tuple[int, int, int]:
        """(custom_mode, base_mode, system_status) of the next HEARTBEAT."""
        n = len(self.r.heartbeats)
        self.wait(lambda: len(self.r.heartbeats) > n, 3.0)
        _, mode, base, status = self.r.heartbeats[-1]
        return mode, base, status

    def servo(self, channel: int) -> int | None:
        return self.r.servos[-1][1][channel - 1] if self.r.servos else None

    def stream(self, conn: Any, period_s: float, seconds: float,
               send: Callable[[Any], None]) -> float:
        """Call send(conn) every period_s autopilot seconds for seconds; the last send time."""
        end = self.t + seconds
        last = self.t
        while self.t < end:
            send(conn)
            last = self.t
            self.until(self.t + period_s)
        return last


def run_scenario(side: Side) -> dict[str, Any]:
    """The script; returns the observations as {key: value}."""
    d = Driver(side)
    obs: dict[str, Any] = {}
    gcs, comp = side.gcs, side.companion

    def streams() -> None:
        for sid, hz in ((M.MAV_DATA_STREAM_EXTRA1, 10), (M.MAV_DATA_STREAM_RC_CHANNELS, 10)):
            gcs.mav.request_data_stream_send(1, 1, sid, hz, 1)

    d.until(1.0)
    streams()
    d.until(3.0)
    streams()
    for i in range(0, len(PARAM_NAMES), 4):  # ArduPilot queues only a few requests
        for name in PARAM_NAMES[i:i + 4]:
            gcs.mav.param_request_read_send(1, 1, name.encode(), -1)
        d.until(d.t + 0.2)
    d.until(5.0)
    for name in PARAM_NAMES:
        obs[f"param:{name}"] = d.r.params.get(name)

    # arming before the pre-arm checks pass
    t0, m0 = d.t, d.mark()
    obs["arm.early.result"] = d.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    d.until(t0 + 1.0)
    obs["arm.early.texts"] = sorted(set(d.texts_since(m0)))

    # modes while disarmed
    d.until(6.0)
    obs["mode.guided_disarmed.result"] = d.set_mode(15)
    obs["mode.guided_disarmed.heartbeat"] = d.next_heartbeat()
    obs["mode.manual.result"] = d.set_mode(0)
    obs["mode.manual.heartbeat"] = d.next_heartbeat()
    t0, m0 = d.t, d.mark()
    obs["mode.unknown.result"] = d.set_mode(99)
    obs["mode.auto.result"] = d.set_mode(10)
    d.until(t0 + 1.0)
    obs["mode.refusal.texts"] = sorted(set(d.texts_since(m0)))
    comp.mav.set_mode_send(1, M.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4)  # SET_MODE: no ACK
    obs["mode.set_mode_msg.heartbeat"] = d.next_heartbeat()
    obs["mode.set_mode_msg.acks"] = sum(1 for _, w, c, _ in d.r.acks if w == "companion")
    d.set_mode(0)

    # servo outputs
    t0, m0 = d.t, d.mark()
    obs["servo.motor_output.result"] = d.command(M.MAV_CMD_DO_SET_SERVO, 1, 1700)
    obs["servo.free_output.result"] = d.command(M.MAV_CMD_DO_SET_SERVO, 9, 1700)
    d.until(t0 + 1.5)
    obs["servo.texts"] = sorted(set(d.texts_since(m0)))

    # GUIDED inputs outside GUIDED: silently ignored
    t0, m0, n_acks = d.t, d.mark(), len(d.r.acks)
    gcs.mav.set_attitude_target_send(0, 1, 1, 0x03, [1, 0, 0, 0], 0, 0, 0.3, 0.5)
    d.until(t0 + 1.0)
    obs["guided_input_in_manual.answers"] = (len(d.r.acks) - n_acks, d.texts_since(m0))

    # arming and GUIDED: retried until accepted, as an operator clicking again
    d.until(11.0)
    at, results, refusals = _until_accepted(
        d, lambda: d.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1), 90.0)
    obs["arm.first_accepted_at"] = at
    obs["arm.refusal.results"] = results
    obs["arm.refusal.texts"] = refusals
    at, results, refusals = _until_accepted(d, lambda: d.set_mode(15), 100.0)
    obs["guided.first_accepted_at"] = at
    if at is None:
        return _finish(d, obs)
    obs["guided.refusal.results"] = results
    obs["guided.refusal.texts"] = refusals
    obs["guided.heartbeat"] = d.next_heartbeat()

    # SET_ATTITUDE_TARGET turn rate + thrust, then silence: the 3 s time-out
    yaw_from = len(d.r.yaw)
    last = d.stream(comp, 0.1, 4.0, lambda c: c.mav.set_attitude_target_send(
        0, 1, 1, 0x03, [1, 0, 0, 0], 0, 0, 0.3, 0.3))
    obs["attitude.yaw_bias_turning"] = _yaw_bias(d.r.yaw[yaw_from:])
    t_text = _wait_text(d, "target not received", 6.0)
    obs["guided.timeout_text"] = _text_after(d, "target not received", last)
    obs["guided.timeout_after.attitude"] = None if t_text is None else round(t_text - last, 1)
    # thrust masked: dropped without a word
    t0, m0, n_acks = d.t, d.mark(), len(d.r.acks)
    comp.mav.set_attitude_target_send(0, 1, 1, 0x43, [1, 0, 0, 0], 0, 0, 0.3, 0.3)
    d.until(t0 + 1.0)
    obs["guided.thrust_masked.answers"] = (len(d.r.acks) - n_acks, d.texts_since(m0))

    # SET_POSITION_TARGET_LOCAL_NED velocity, then silence
    last = d.stream(comp, 0.1, 3.0, lambda c: c.mav.set_position_target_local_ned_send(
        0, 1, 1, M.MAV_FRAME_LOCAL_NED, 0xDC7, 0, 0, 0, 1.0, 0, 0, 0, 0, 0, 0, 0))
    t_text = _wait_text(d, "target not received", 6.0, since=last)
    obs["guided.timeout_after.velocity"] = None if t_text is None else round(t_text - last, 1)
    # acceleration not masked
    t0, m0 = d.t, d.mark()
    comp.mav.set_position_target_local_ned_send(0, 1, 1, M.MAV_FRAME_LOCAL_NED, 0xC07, 0, 0, 0,
                                                1.0, 0, 0, 0.5, 0, 0, 0, 0)
    d.until(t0 + 1.0)
    obs["guided.accel_texts"] = d.texts_since(m0)

    # SET_POSITION_TARGET_GLOBAL_INT position: reached once, no repeat needed
    d.until(d.t + 0.5)
    yaw_from = len(d.r.yaw)
    gps = _latest_global(d)
    if gps is not None:
        lat, lon = gps
        comp.mav.set_position_target_global_int_send(
            0, 1, 1, M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 0xDF8,
            int(lat + 20.0 / 111_320 * 1e7), int(lon), 0, 0, 0, 0, 0, 0, 0, 0, 0)
        obs["guided.position_reached"] = d.wait(lambda: bool(d.r.reached), 30.0)
    obs["attitude.yaw_bias_position"] = _yaw_bias(d.r.yaw[yaw_from:])

    # per-link streams: the companion asked for nothing but GLOBAL_POSITION_INT at 5 Hz; the
    # GCS asked for EXTRA1 (ATTITUDE ...) at 10 Hz on its own link
    obs["streams.companion.set_interval.result"] = d.command(
        M.MAV_CMD_SET_MESSAGE_INTERVAL, M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 200_000, conn=comp)
    d.until(d.t + 1.0)
    t_a, n_a = d.t, len(d.r.companion_msgs)
    d.until(t_a + 4.0)
    window = d.r.companion_msgs[n_a:]
    for kind in ("GLOBAL_POSITION_INT", "ATTITUDE", "SYS_STATUS", "HEARTBEAT"):
        obs[f"streams.companion.{kind}_hz"] = round(
            sum(1 for _, k in window if k == kind) / (d.t - t_a), 1)
    obs["links.gcs_heartbeat_seen_by_companion"] = ("companion", GCS[0]) in d.r.forwarded
    obs["links.companion_heartbeat_seen_by_gcs"] = ("gcs", COMPANION[0]) in d.r.forwarded

    # GCS failsafe: enabled, then the GCS falls silent (the companion's heartbeats do not count)
    gcs.mav.param_set_send(1, 1, b"FS_GCS_ENABLE", 1, M.MAV_PARAM_TYPE_INT8)
    d.until(d.t + 0.5)
    obs["failsafe.param_echo"] = d.r.params.get("FS_GCS_ENABLE")
    d.gcs_heartbeats = False
    t0, m0 = d.t, d.mark()
    t_text = _wait_text(d, "Failsafe", 12.0)
    obs["failsafe.after_silence"] = None if t_text is None else round(t_text - t0, 1)
    d.until(d.t + 1.5)
    obs["failsafe.texts"] = d.texts_since(m0)
    obs["failsafe.heartbeat"] = d.next_heartbeat()
    d.gcs_heartbeats = True
    m0 = d.mark()
    _wait_text(d, "GCS Failsafe Cleared", 4.0)
    d.until(d.t + 1.0)
    obs["failsafe.cleared_texts"] = d.texts_since(m0)
    obs["failsafe.cleared_heartbeat"] = d.next_heartbeat()
    gcs.mav.param_set_send(1, 1, b"FS_GCS_ENABLE", 0, M.MAV_PARAM_TYPE_INT8)
    d.until(d.t + 0.5)

    # RC override in MANUAL: only from MAV_GCS_SYSID; holds RC_OVERRIDE_TIME; 0 releases
    obs["mode.manual_armed.result"] = d.set_mode(0)
    d.until(d.t + 1.0)

    def override(ch1: int) -> Callable[[Any], None]:
        return lambda c: c.mav.rc_channels_override_send(1, 1, ch1, 65535, 1500, 65535, 65535,
                                                         65535, 65535, 65535)

    d.stream(comp, 0.2, 1.0, override(1800))
    d.until(d.t + 0.3)
    obs["rc.other_sysid.servo1"] = d.servo(1)
    last = d.stream(gcs, 0.2, 1.0, override(1800))
    d.until(d.t + 0.3)
    obs["rc.gcs.servo1"] = d.servo(1)
    d.wait(lambda: abs((d.servo(1) or 0) - 1500) < 15, 6.0)
    obs["rc.release_after"] = round(d.t - last, 1)
    d.stream(gcs, 0.2, 0.6, override(1800))
    d.until(d.t + 0.3)
    t0, m0 = d.t, d.mark()
    gcs.mav.rc_channels_override_send(1, 1, 0, 65535, 0, 65535, 65535, 65535, 65535, 65535)
    d.wait(lambda: abs((d.servo(1) or 0) - 1500) < 15, 4.0)
    obs["rc.zero_release_after"] = round(d.t - t0, 1)

    t0, m0 = d.t, d.mark()
    obs["disarm.result"] = d.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    d.until(t0 + 1.0)
    obs["disarm.heartbeat"] = d.next_heartbeat()
    return _finish(d, obs)


def _until_accepted(d: Driver, send: Callable[[], int | None],
                    give_up_at: float) -> tuple[float | None, list[int], list[str]]:
    """Send (a command) once a second until accepted, as an operator clicking again: (when it
    was accepted or None, the other results, the texts heard in between)."""
    refusals: set[str] = set()
    results: set[int | None] = set()
    while True:
        t0, m0 = d.t, d.mark()
        res = send()
        if res == M.MAV_RESULT_ACCEPTED:
            accepted: float | None = round(t0, 1)
            break
        results.add(res)
        d.until(t0 + 1.0)
        refusals.update(d.texts_since(m0))
        if d.t > give_up_at:
            accepted = None
            break
    return accepted, sorted(r for r in results if r is not None), sorted(refusals)


def run_turn_rate_scenario(side: Side, rate: float = 0.3, thrust: float = 0.5,
                           seconds: float = 8.0) -> dict[str, Any]:
    """The rover turning on SET_ATTITUDE_TARGET (body yaw rate rad/s + thrust) for ``seconds``
    from rest: the yaw rate's mean, peak and settled value (the last quarter) in deg/s, and the
    mean and settled ground speed, as ATTITUDE and VFR_HUD report them."""
    d = Driver(side)
    d.until(1.0)
    for sid in (M.MAV_DATA_STREAM_EXTRA1, M.MAV_DATA_STREAM_EXTRA2):
        side.gcs.mav.request_data_stream_send(1, 1, sid, 10, 1)
    d.until(11.0)
    armed, _, _ = _until_accepted(d, lambda: d.command(M.MAV_CMD_COMPONENT_ARM_DISARM, 1), 90.0)
    guided, _, _ = _until_accepted(d, lambda: d.set_mode(15), 100.0)
    if armed is None or guided is None:
        return {"turn.engaged": False}
    start = d.t
    d.stream(side.companion, 0.1, seconds, lambda c: c.mav.set_attitude_target_send(
        0, 1, 1, 0x03, [1, 0, 0, 0], 0, 0, rate, thrust))
    rows = [(t - start, math.degrees(w), v) for t, w, v in d.r.rates if start < t <= d.t]
    if not rows:
        return {"turn.engaged": True}
    settled = [row for row in rows if row[0] >= 0.75 * seconds]
    return {
        "turn.engaged": True,
        "turn.rate_mean": round(sum(w for _, w, _ in rows) / len(rows), 2),
        "turn.rate_peak": round(max(w for _, w, _ in rows), 2),
        "turn.rate_settled": round(sum(w for _, w, _ in settled) / len(settled), 2),
        "turn.speed_mean": round(sum(v for _, _, v in rows) / len(rows), 3),
        "turn.speed_settled": round(sum(v for _, _, v in settled) / len(settled), 3),
    }


def _wait_text(d: Driver, fragment: str, max_s: float, since: float | None = None) -> float | None:
    t0 = d.t if since is None else since

    def hit() -> float | None:
        return next((t for t, _, s in d.r.texts if t >= t0 and fragment in s), None)

    d.wait(lambda: hit() is not None, max_s)
    return hit()


def _text_after(d: Driver, fragment: str, since: float) -> str | None:
    return next((s for t, _, s in d.r.texts if t >= since and fragment in s), None)


def _latest_global(d: Driver) -> tuple[float, float] | None:
    """Where the vehicle is, from a requested GLOBAL_POSITION_INT (degE7)."""
    n = d.r.global_seen
    d.side.gcs.mav.command_long_send(1, 1, M.MAV_CMD_REQUEST_MESSAGE, 0,
                                     M.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 0, 0, 0, 0, 0, 0)
    d.wait(lambda: d.r.global_seen > n, 2.0)
    return d.r.global_pos if d.r.global_seen > n else None


def _yaw_bias(rows: list[tuple[float, float, float]]) -> float | None:
    """Mean ATTITUDE − SIMSTATE yaw in degrees (wrapped), or None without samples."""
    if not rows:
        return None
    diffs = [math.degrees((a - s + math.pi) % (2 * math.pi) - math.pi) for _, a, s in rows]
    return round(sum(diffs) / len(diffs), 2)


def _finish(d: Driver, obs: dict[str, Any]) -> dict[str, Any]:
    """Start-up and whole-run observations from the record."""
    r = d.r
    # system_status / mode sequence of the start-up (until the first arming)
    runs: list[list[Any]] = []  # [first t, last t, state]
    for t, mode, base, status in r.heartbeats:
        if runs and runs[-1][2] == (mode, base, status):
            runs[-1][1] = t
        else:
            runs.append([t, t, (mode, base, status)])
    seq: list[tuple[int, int, int]] = []
    for i, (t_first, _, state) in enumerate(runs):
        t_next = runs[i + 1][0] if i + 1 < len(runs) else math.inf
        settled = i == 0 or t_next - t_first >= HEARTBEAT_SETTLED_S
        if settled and state not in seq[-1:]:
            seq.append(state)
    obs["heartbeats.sequence"] = seq
    obs["startup.manual_at"] = next((round(t, 1) for t, m, _, _ in r.heartbeats if m == 0), None)
    obs["startup.gps_fix_at"] = next((round(t, 1) for t, f, *_ in r.gps if f >= 3), None)
    obs["startup.prearm_healthy_at"] = next(
        (round(t, 1) for t, _, _, h in r.sys_status if h & M.MAV_SYS_STATUS_PREARM_CHECK), None)
    if r.sys_status:
        t, present, enabled, health = r.sys_status[-1]
        obs["sys_status.present"] = hex(present)
        obs["sys_status.enabled"] = hex(enabled)
        obs["sys_status.health"] = hex(health)
    first = next((row for row in r.sys_status if row[0] >= 2.0), None)
    if first is not None:
        obs["sys_status.early_health"] = hex(first[3])
    if r.gps:
        _, fix, sats, eph, epv = r.gps[-1]
        obs["gps.fix_type"], obs["gps.satellites"] = fix, sats
        obs["gps.eph"], obs["gps.epv"] = eph, epv
    boot = [s for t, _, s in r.texts
            if t < 45.0 and BOOT_TEXT.match(s) and not s.startswith("EKF failsafe")]
    obs["startup.boot_text_count"] = len(boot)
    for t, _, s in r.texts:
        # the boot sequence's texts by autopilot time; the script's by being heard at all, as
        # their timing is observed by the step that causes them (failsafe.after_silence,
        # guided.timeout_after, ...): an absolute time late in the script carries every
        # earlier step's waiting (CI once saw both sides' last texts 1.9 s apart for that)
        if BOOT_TEXT.match(s):
            obs.setdefault(f"text_at:{s}", round(t, 1))
        else:
            obs[f"text_heard:{s}"] = True
    return obs


@dataclass(frozen=True)
class Difference:
    key: str
    real: Any
    sim: Any

    def __str__(self) -> str:
        return f"{self.key}: real {self.real!r}, sim {self.sim!r}"


def tolerance(key: str) -> float | None:
    return next((tol for pat, tol in TOLERANCES if fnmatch.fnmatchcase(key, pat)), None)


def _same(a: Any, b: Any, tol: float | None) -> bool:
    if isinstance(a, bool) or isinstance(b, bool):
        return type(a) is type(b) and a == b
    if tol is None:
        return a == b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return abs(a - b) <= tol + 1e-9 * max(abs(a), abs(b))
    return a == b


def compare(real: dict[str, Any], sim: dict[str, Any]) -> list[Difference]:
    """Every key whose values differ beyond its tolerance (a key missing on one side is None)."""
    out = []
    for key in sorted(set(real) | set(sim)):
        a, b = real.get(key), sim.get(key)
        if not _same(a, b, tolerance(key)):
            out.append(Difference(key, a, b))
    return out


def accepted_differences(path: Path = DIFFERENCES_DOC) -> dict[str, str]:
    """{key pattern: reason} from the table rows of docs/sim-differences.md whose first cell is
    a `backticked` key (fnmatch patterns allowed)."""
    rows: dict[str, str] = {}
    for line in path.read_text().splitlines():
        m = re.match(r"^\|\s*`([^`]+)`\s*\|(.*)\|\s*$", line)
        if m:
            rows[m.group(1)] = m.group(2).split("|")[-1].strip()
    return rows


def unaccepted(diffs: list[Difference], accepted: dict[str, str]) -> list[Difference]:
    return [d for d in diffs if not any(fnmatch.fnmatchcase(d.key, p) for p in accepted)]
