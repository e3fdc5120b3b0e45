"""The rc_override profile and servo outputs against the real ArduPilot Rover SITL.

The same features as tests/test_e2e_rc_override.py (built-in simulator), here with ``mavhelm run
MISSION --connect tcp:...SERIAL1 --clock autopilot`` next to the real binary, a ground station
(``RealOperator``, system 255) on SERIAL0 arming the boat and working the engage switch: an RC
override of channel 7 only (every other channel 65535, "leave alone"), refreshed well inside
RC_OVERRIDE_TIME. What ArduPilot makes of the companion's commands is read back from the
autopilot itself (RC_CHANNELS, SERVO_OUTPUT_RAW, SIMSTATE ground truth, all stamped with its
``time_boot_ms``); what the companion did, from its console and .alog. Timing assertions are in
autopilot seconds; wall-clock bounds only guard against a hang. Measured figures are printed
(run with ``-s``).

Needs MAVHELM_ARDUPILOT (see tests/support/ardupilot.py); skips without it.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.core.bus import Message
from tests.support.ardupilot import (
    GCS_COMPONENT_ID,
    GCS_SYSTEM_ID,
    CompanionProcess,
    RealOperator,
    wait_autopilot,
    wait_watching,
)
from tests.support.ardupilot import wait_line as wait_line_read
from tests.support.mission import mission_text

# real_sitl: fixture in conftest.py

pytestmark = pytest.mark.slow

SPEEDUP = 10
"""Not faster: a loaded machine's stall of the companion lasts speed-up times longer in
autopilot seconds, and the override must be in effect 1 autopilot s after the switch."""
STREAM_HZ = 2                # the operator's telemetry (SIMSTATE truth), autopilot hertz
RC_HZ = 10                   # RC_CHANNELS and SERVO_OUTPUT_RAW to the operator, autopilot hertz
SWITCH_REFRESH_MS = 250      # the operator's RC7 override is resent this often (autopilot ms)
RC_OVERRIDE_TIME_S = 3.0     # ArduPilot's default
HOME = (56.4120, -5.4760, 0.0, 0.0)   # facing north: the helm must turn the boat to 90
CALM = {"SIM_WIND_SPD": 0, "SIM_WAVE_ENABLE": 0}   # "does not move" means it, no drift
ENGAGE_CH = 7
SWITCH_HIGH, SWITCH_LOW = 1900, 1100
HAND_OVER_WALL_S = 60.0      # "it did not hang" guards, wall seconds
EVENT_WALL_S = 30.0

# The heading gains in rc_mission: under rc_override RUDDER/MAXRUDDER is the steering servo's
# whole throw, with no turn-rate limit and no ArduPilot rate loop (unlike guided, where full
# rudder is MaxTurnRate). The SITL motorboat at 60 % throttle then turns at a few hundred deg/s
# at full steering, and YAW_PID_KP 0.5 / KD 0.2 limit-cycle bang-bang between 1000
# and 2000 us, the heading swinging about 0..190 deg (measured); KP 0.2, KD 0 turns the boat
# from north and settles on 89 deg within about 2 s. The gains are the mission's, as a user's.
def rc_mission(sysid: int) -> str:
    """East on rc_override, the companion as MAVLink system ``sysid``."""
    return mission_text("""
        Task = ConstantHeading
        {
            Name = East
            Heading = 90
            Thrust = 60
            TimeOut = NEVER
        }""", imavlink={"Actuation": "rc_override", "SystemID": sysid, "EngageChannel": 7},
        helm={"YAW_PID_KP": 0.2, "YAW_PID_KD": 0})


def servo_mission(output: int) -> str:
    """A winch held at 50 % on servo ``output``."""
    return mission_text("""
        Task = SetActuator
        {
            Name = Winch
            Actuator = WINCH
            Value = 50
            TimeOut = NEVER
        }""", imavlink={"Servo": f"WINCH@{output}:1100-1900"})


# -- the ground station -------------------------------------------------------------------------

class Operator(RealOperator):
    """``RealOperator`` with an RC switch and a MAVLink 2 parser.

    ``hold_switch(ch, pwm)`` overrides RC channel ``ch`` only (the others 65535: ArduPilot
    leaves them alone) and ``poll()`` resends it every ``SWITCH_REFRESH_MS`` of autopilot time,
    far inside RC_OVERRIDE_TIME, as a ground station's joystick would. It also keeps every
    RC_CHANNELS and SERVO_OUTPUT_RAW with its autopilot time. The parser is MAVLink 2's
    (mavutil's default is 1's): SERVO_OUTPUT_RAW's servo9_raw is an extension field."""

    def __init__(self, port: int, speedup: float = 1.0) -> None:
        super().__init__(port, heartbeat_s=1.0 / speedup)
        self.conn.mav = mavlink.MAVLink(self.conn, srcSystem=GCS_SYSTEM_ID,
                                        srcComponent=GCS_COMPONENT_ID)
        self.conn.mav.robust_parsing = True
        self.rc: list[tuple[int, tuple[int, ...]]] = []      # boot ms, chan1..chan8
        self.servos: list[tuple[int, tuple[int, ...]]] = []  # boot ms, servo1..servo16_raw
        self.switch: tuple[int, int] | None = None
        self.switch_sent: list[tuple[int | None, int]] = []  # boot ms when sent, pwm

    def hold_switch(self, channel: int, pwm: int) -> int | None:
        """Hold RC ``channel`` at ``pwm`` from now on; returns the autopilot ms it was sent."""
        self.switch = (channel, pwm)
        self._send_switch()
        return self.boot_ms

    def _send_switch(self) -> None:
        assert self.switch is not None
        channel, pwm = self.switch
        values = [65535] * 18
        values[channel - 1] = pwm
        self.conn.mav.rc_channels_override_send(self.target_system, self.target_component,
                                                *values)
        self.switch_sent.append((self.boot_ms, pwm))

    def poll(self, timeout_s: float = 0.0) -> list:
        if self.switch is not None and self.boot_ms is not None:
            last = self.switch_sent[-1][0] if self.switch_sent else None
            if last is None or self.boot_ms - last >= SWITCH_REFRESH_MS:
                self._send_switch()
        return super().poll(timeout_s)

    def _handle(self, msg, now: float) -> None:
        super()._handle(msg, now)
        if msg.get_type() == "BAD_DATA" or (msg.get_srcSystem(), msg.get_srcComponent()) != (
                self.target_system, self.target_component):
            return
        if msg.get_type() == "RC_CHANNELS":
            self.rc.append((msg.time_boot_ms,
                            tuple(getattr(msg, f"chan{i}_raw") for i in range(1, 9))))
        elif msg.get_type() == "SERVO_OUTPUT_RAW" and msg.port == 0:
            self.servos.append((msg.time_usec // 1000,
                                tuple(getattr(msg, f"servo{i}_raw") for i in range(1, 17))))

    def refresh_gaps_ms(self, since_ms: int) -> list[int]:
        """Autopilot ms between the switch overrides sent since ``since_ms``."""
        times = [t for t, _ in self.switch_sent if t is not None and t >= since_ms]
        return [b - a for a, b in zip(times, times[1:], strict=False)]


def start_operator(sitl) -> Operator:
    op = Operator(sitl.ports.serial0, sitl.speedup)
    op.wait_first_heartbeat(STREAM_HZ)
    op.request_interval("RC_CHANNELS", RC_HZ)       # asked before it runs, this is ignored
    op.request_interval("SERVO_OUTPUT_RAW", RC_HZ)
    return op


# -- the companion process ----------------------------------------------------------------------

def companion(text: str, port: int, folder: Path) -> CompanionProcess:
    """The mission written to ``folder`` and ``mavhelm run`` started on it."""
    folder.mkdir(parents=True, exist_ok=True)
    mission = folder / "mission.moos"
    mission.write_text(text)
    return CompanionProcess(mission, port, folder / "logs")


def wait_line(op: Operator, comp: CompanionProcess, fragment: str, nth: int = 1) -> int:
    """Wait for the companion's ``nth`` console line containing ``fragment``; returns the
    operator's autopilot ms when it was seen."""
    wait_line_read(op, comp, fragment, nth, EVENT_WALL_S)
    assert op.boot_ms is not None
    return op.boot_ms


# -- reading what happened ----------------------------------------------------------------------

def named(log: list[Message], name: str) -> list[Message]:
    return [m for m in log if m.name == name]


def truth(op: Operator, since_ms: int, until_ms: float = math.inf):
    """SIMSTATE ground truth between two autopilot times as (autopilot s, north m, east m,
    yaw deg), north/east from the first SIMSTATE the operator heard (flat earth)."""
    lat0, lng0 = op.simstates[0][2], op.simstates[0][3]
    k = math.radians(1e-7) * 6_371_000.0
    coslat = math.cos(math.radians(lat0 * 1e-7))
    return [(boot / 1000.0, (lat - lat0) * k, (lng - lng0) * k * coslat,
             math.degrees(yaw) % 360.0)
            for _, boot, lat, lng, yaw in op.simstates
            if boot is not None and since_ms <= boot <= until_ms]


def travelled(track) -> float:
    """Straight-line distance from the first to the last sample, metres."""
    return math.hypot(track[-1][1] - track[0][1], track[-1][2] - track[0][2])


def speed(track) -> float:
    """Mean speed over the track's ends, m/s."""
    return travelled(track) / max(1e-6, track[-1][0] - track[0][0])


def angle_off(a: float, b: float) -> float:
    return abs((a - b + 180.0) % 360.0 - 180.0)


def rc_between(op: Operator, since_ms: float, until_ms: float = math.inf):
    return [(t, ch) for t, ch in op.rc if since_ms <= t <= until_ms]


# -- the tests ----------------------------------------------------------------------------------

def test_rc_override_drives_in_manual_on_the_switch_and_releases_at_once(real_sitl,
                                                                         tmp_path) -> None:
    sitl = real_sitl(model="motorboat", speedup=SPEEDUP, home=HOME, params=CALM)
    t_wall = time.monotonic()
    with start_operator(sitl) as op:
        sitl.wait_listening(sitl.ports.serial1)
        comp = companion(rc_mission(GCS_SYSTEM_ID), sitl.ports.serial1,
                                tmp_path / "companion")
        try:
            wait_line(op, comp, "helm offline: autopilot disarmed")
            op.hand_over("MANUAL", timeout_s=HAND_OVER_WALL_S, retry_s=1.0 / sitl.speedup)
            low_seen = wait_line(op, comp, "helm offline: engage switch RC7 is low")
            wait_autopilot(op, comp, 3.0)
            raised = op.hold_switch(ENGAGE_CH, SWITCH_HIGH)
            assert raised is not None
            engaged = wait_line(op, comp, "helm ONLINE: autopilot armed in MANUAL")
            wait_autopilot(op, comp, 15.0)
            dropped = op.hold_switch(ENGAGE_CH, SWITCH_LOW)
            assert dropped is not None
            off_seen = wait_line(op, comp, "helm offline: engage switch RC7 is low", nth=2)
            wait_autopilot(op, comp, 5.0)
            end = op.boot_ms
        finally:
            code = comp.stop()
    wall_s = time.monotonic() - t_wall
    log = comp.alog()

    # the radio, as ArduPilot read it before anything was overridden
    radio = rc_between(op, 0, raised)[-1][1]
    idle_rc = rc_between(op, low_seen, raised)
    idle = truth(op, op.handed_over_boot_ms or low_seen, raised)
    # engaged: what the companion sent and what ArduPilot obeyed
    online = named(log, "HELM_ONLINE")
    throttle_cmds = sorted({int(m.double) for m in named(log, "AP_CMD_RC_THROTTLE")})
    steer_cmds = [int(m.double) for m in named(log, "AP_CMD_RC_STEER")]
    sw_high = next(t for t, ch in op.rc if t >= raised and ch[ENGAGE_CH - 1] >= 1800)
    driven_rc = rc_between(op, sw_high + 1000, dropped)
    rc3_driven = sorted({ch[2] for _, ch in driven_rc})
    rc1_driven = [ch[0] for _, ch in driven_rc]
    driven = truth(op, sw_high, dropped)
    last_5s = truth(op, dropped - 5000, dropped)
    course = math.degrees(math.atan2(last_5s[-1][2] - last_5s[0][2],
                                     last_5s[-1][1] - last_5s[0][1])) % 360.0
    yaw_end = driven[-1][3]
    # the switch drops: when ArduPilot saw it, and when ch1/ch3 were the radio's again
    sw_low = next(t for t, ch in op.rc if t >= dropped and ch[ENGAGE_CH - 1] < 1800)
    released = next((t for t, ch in op.rc if t >= sw_low
                      and ch[0] == radio[0] and ch[2] == radio[2]), None)
    after_rc = rc_between(op, sw_low + 1000, end)
    speed_before = speed(truth(op, dropped - 2000, dropped))
    speed_after = speed(truth(op, sw_low + 3000, sw_low + 5000))
    off_msgs = [m for m in online if m.value == 0.0 and m.time > online[0].time]
    statuses = [m.string for m in named(log, "HELM_STATUS")]
    cmds_after_off = [m for m in named(log, "AP_CMD_RC_THROTTLE")
                      if off_msgs and m.time > off_msgs[0].time]
    gaps = op.refresh_gaps_ms(raised)
    print(f"\n[rc_override] -I {sitl.instance} x{sitl.speedup:g}, {wall_s:.1f} s wall; radio "
          f"ch1..8 {radio}; MAV_GCS_SYSID 255, companion 255:191")
    print(f"[rc_override] switch low {(raised - low_seen) / 1000:.1f} autopilot s after the "
          f"'RC7 is low' line: truth moved {travelled(idle):.2f} m, RC ch1/ch3 seen "
          f"{sorted({(ch[0], ch[2]) for _, ch in idle_rc})}")
    print(f"[rc_override] RC7 high sent at {raised / 1000:.2f} s, ArduPilot read it at "
          f"{sw_high / 1000:.2f} s, companion ONLINE line by {engaged / 1000:.2f} s; operator "
          f"refresh gaps max {max(gaps)} ms (autopilot)")
    print(f"[rc_override] driven {(dropped - sw_high) / 1000:.1f} autopilot s: "
          f"{travelled(driven):.1f} m, course over the last 5 s {course:.0f} deg, yaw at the "
          f"drop {yaw_end:.0f} deg (started facing {HOME[3]:g}); AP_CMD_RC_THROTTLE {throttle_cmds}"
          f", RC_CHANNELS ch3 {rc3_driven}; AP_CMD_RC_STEER {min(steer_cmds)}..{max(steer_cmds)},"
          f" RC ch1 {min(rc1_driven)}..{max(rc1_driven)}")
    print(f"[rc_override] RC7 low sent at {dropped / 1000:.2f} s, ArduPilot read it at "
          f"{sw_low / 1000:.2f} s; ch1/ch3 back to the radio at "
          f"{(released or math.nan) / 1000:.2f} s (+{((released or math.nan) - sw_low):.0f} ms; "
          f"RC_OVERRIDE_TIME {RC_OVERRIDE_TIME_S:g} s); offline line by {off_seen / 1000:.2f} s; "
          f"speed {speed_before:.2f} m/s before, {speed_after:.2f} m/s 3-5 s after")
    print(f"[rc_override] HELM_STATUS: {statuses}")

    assert code == 0, comp.output()
    # offline, and nothing moved, while the switch was low
    assert "offline: engage switch RC7 is low (1000 < 1800)" in statuses, statuses
    assert travelled(idle) < 1.0, idle
    assert all((ch[0], ch[2]) == (radio[0], radio[2]) for _, ch in idle_rc)
    assert (radio[0], radio[2]) == (1500, 1500)
    assert online and online[0].value == 1.0, "HELM_ONLINE 1 first, on the switch"
    first_cmd = named(log, "AP_CMD_RC_THROTTLE")[0]
    assert first_cmd.time >= online[0].time, "nothing overridden before the switch"
    # the switch refreshed inside RC_OVERRIDE_TIME, so the override never lapsed (the test's
    # own refreshes: a loaded machine stalled them 1.6 autopilot s at x10 once, in CI)
    assert max(gaps) < RC_OVERRIDE_TIME_S * 1000, gaps
    # engaged: ArduPilot obeyed the companion's override, the boat went east
    assert throttle_cmds == [1800], "60 % of RC3 1000..1500..2000"
    assert rc3_driven == throttle_cmds, "RC_CHANNELS ch3 is the companion's override"
    assert min(steer_cmds) <= min(rc1_driven) and max(rc1_driven) <= max(steer_cmds)
    assert travelled(driven) > 10.0
    assert angle_off(course, 90.0) < 20.0, course
    assert angle_off(yaw_end, 90.0) < 20.0, yaw_end
    # the switch drops: offline, released at once (not after RC_OVERRIDE_TIME), slowing down
    assert off_msgs, "HELM_ONLINE 0 after the switch dropped"
    assert statuses[-1] == "offline: engage switch RC7 is low (1100 < 1800)", statuses
    assert not cmds_after_off, "no override after going offline"
    assert released is not None and released - sw_low <= 1000, (sw_low, released)
    assert all((ch[0], ch[2]) == (radio[0], radio[2]) for _, ch in after_rc)
    assert speed_after < 0.5 * speed_before


def test_rc_override_refuses_a_mav_gcs_sysid_mismatch(real_sitl, tmp_path) -> None:
    sitl = real_sitl(model="motorboat", speedup=SPEEDUP, home=HOME, params=CALM)
    t_wall = time.monotonic()
    with start_operator(sitl) as op:
        sitl.wait_listening(sitl.ports.serial1)
        comp = companion(rc_mission(1), sitl.ports.serial1,
                                tmp_path / "companion")
        try:
            wait_line(op, comp, "helm offline: autopilot disarmed")
            raised = op.hold_switch(ENGAGE_CH, SWITCH_HIGH)    # the switch is up all along
            op.hand_over("MANUAL", timeout_s=HAND_OVER_WALL_S, retry_s=1.0 / sitl.speedup)
            seen = wait_line(op, comp, "helm offline: MAV_GCS_SYSID is 255")
            end = wait_autopilot(op, comp, 3.0)
        finally:
            code = comp.stop()
    wall_s = time.monotonic() - t_wall
    log = comp.alog()
    assert raised is not None
    radio_before = rc_between(op, 0, raised)[-1][1]
    armed_rc = rc_between(op, seen, end)
    track = truth(op, op.handed_over_boot_ms or seen, end)
    lines = comp.find_all("MAV_GCS_SYSID")
    print(f"\n[rc_override] mismatch: x{sitl.speedup:g}, {wall_s:.1f} s wall; console "
          f"{lines}; RC ch1/ch3/ch7 while armed {sorted({(c[0], c[2], c[6]) for _, c in armed_rc})}"
          f"; truth moved {travelled(track):.2f} m in {(end - track[0][0] * 1000) / 1000:.1f} s")
    assert code == 0, comp.output()
    assert len(lines) == 1 and lines[0].endswith(
        "helm offline: MAV_GCS_SYSID is 255 but the companion speaks as system 1, so ArduPilot "
        "would ignore its RC override: set SystemID = 255 in iMAVLink"), lines
    assert not [m for m in named(log, "HELM_ONLINE") if m.value == 1.0]
    assert not named(log, "AP_CMD_RC_THROTTLE") and not named(log, "AP_CMD_RC_STEER")
    assert armed_rc and all(c[6] >= 1800 for _, c in armed_rc), "the switch was up"
    assert all((c[0], c[2]) == (radio_before[0], radio_before[2]) for _, c in armed_rc)
    assert travelled(track) < 1.0


def test_servo_output_reaches_servo_output_raw_and_a_motor_output_is_refused_once(
        real_sitl, tmp_path) -> None:
    sitl = real_sitl(model="motorboat", speedup=SPEEDUP)
    t_wall = time.monotonic()
    with start_operator(sitl) as op:
        sitl.wait_listening(sitl.ports.serial1)
        # WINCH on the free output 9
        comp = companion(servo_mission(9), sitl.ports.serial1,
                                tmp_path / "winch9")
        try:
            wait_line(op, comp, "helm offline: autopilot disarmed")
            op.hand_over("GUIDED", timeout_s=HAND_OVER_WALL_S, retry_s=1.0 / sitl.speedup)
            wait_line(op, comp, "helm ONLINE")
            wait_watching(op, comp, lambda: op.servos and op.servos[-1][1][8] == 1700,
                          EVENT_WALL_S, "SERVO_OUTPUT_RAW servo9_raw 1700")
            wait_autopilot(op, comp, 5.0)
        finally:
            code9 = comp.stop()
        log9 = comp.alog()
        # WINCH on output 1, the motorboat's steering: refused by ArduPilot, reported once
        start1 = op.boot_ms
        assert start1 is not None
        comp = companion(servo_mission(1), sitl.ports.serial1,
                                tmp_path / "winch1")
        try:
            wait_line(op, comp, "helm ONLINE")
            wait_line(op, comp, "servo output 1 (WINCH) refused by the autopilot")
            wait_autopilot(op, comp, 7.0)
            end = op.boot_ms
        finally:
            code1 = comp.stop()
        log1 = comp.alog()
    wall_s = time.monotonic() - t_wall
    handed = op.handed_over_boot_ms
    assert handed is not None
    servo9_before = {s[8] for t, s in op.servos if t < handed}
    at_1700 = next(t for t, s in op.servos if s[8] == 1700)
    online9 = next(m for m in named(log9, "HELM_ONLINE") if m.value == 1.0)
    sent9 = named(log9, "AP_CMD_SERVO9")
    refresh9 = [round(b.time - a.time, 2) for a, b in zip(sent9, sent9[1:], strict=False)]
    sent1 = named(log1, "AP_CMD_SERVO1")
    warnings = [m.string for m in named(log1, "MAVLINK_WARNING") if "servo output" in m.string]
    lines = comp.find_all("servo output 1 (WINCH) refused")
    servo1_after = sorted({s[0] for t, s in op.servos if start1 <= t <= end})
    acks = [m.string for m in named(log1, "AP_COMMAND_ACK")
            if m.string.startswith(f"command={mavlink.MAV_CMD_DO_SET_SERVO},")]
    ap_texts = [m.string for m in named(log1, "AP_STATUSTEXT") if "in use" in m.string]
    print(f"\n[servo] x{sitl.speedup:g}, {wall_s:.1f} s wall; WINCH@9: servo9_raw before the "
          f"hand-over {sorted(servo9_before)}, 1700 {(at_1700 - handed) / 1000:.2f} autopilot s "
          f"after it; first AP_CMD_SERVO9 {sent9[0].time - online9.time:+.3f} s after "
          f"HELM_ONLINE 1, {len(sent9)} x {sorted({m.double for m in sent9})}, refreshed after "
          f"{refresh9} s")
    print(f"[servo] WINCH@1: AP_CMD_SERVO1 {len(sent1)} x "
          f"{sorted({m.double for m in sent1})}, DO_SET_SERVO acks {sorted(set(acks))} "
          f"x {len(acks)}, autopilot texts {sorted(set(ap_texts))}; servo1_raw meanwhile "
          f"{servo1_after}")
    print(f"[servo] console: {lines}; MAVLINK_WARNING: {warnings}")
    assert code9 == 0 and code1 == 0, comp.output()
    assert servo9_before == {0}, "output 9 idle before the hand-over"
    assert {m.double for m in sent9} == {1700.0}, "+50 % of 1100..1900"
    assert 0.0 <= sent9[0].time - online9.time <= 0.15, "sent at once when online"
    # never early (timed on the clock that stamps the log); late by at most a few ticks
    assert refresh9 and all(2.0 <= gap <= 2.5 for gap in refresh9), refresh9
    assert (at_1700 - handed) / 1000 <= 2.0
    assert len(sent1) >= 3 and len(acks) >= 3, "refreshed every 2 s while online"
    assert all(not a.endswith(f"result={mavlink.MAV_RESULT_ACCEPTED}") for a in acks), acks
    assert len(lines) == 1 and len(warnings) == 1, (lines, warnings)
    assert warnings[0].startswith("servo output 1 (WINCH) refused by the autopilot")
    assert 1700 not in servo1_after, "the steering output was not taken over"
