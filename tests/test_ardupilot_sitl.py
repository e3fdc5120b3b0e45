"""The real ArduPilot Rover SITL, through tests/support/ardupilot.py, without the companion.

These pin what mavhelm assumes about ArduPilot against the binary itself: how long a motorboat
takes to be armed in GUIDED, that SET_ATTITUDE_TARGET from a companion on SERIAL1 (system 1,
component 191) drives the boat and that the autopilot stops it 3 s after the last one, and that
two SITLs run side by side. They need MAVHELM_ARDUPILOT (see tests/support/ardupilot.py) and skip
without it. Measured figures are printed (run with -s to see them).
"""

from __future__ import annotations

import math
import time
from collections import Counter

import pytest

from tests.support.ardupilot import (
    ARDUPILOT_ENV,
    ArduPilotConfigError,
    RealOperator,
    ardupilot_binary,
    connect_tcp,
    listening_ports,
    read_available,
    truth_track,
)

# real_sitl: fixture in conftest.py

STOP_TEXT = "target not received last 3secs, stopping"
COMPANION_SYSTEM, COMPANION_COMPONENT = 1, 191
ATTITUDE_TYPE_MASK = 0x03        # ignore body roll and pitch rate: use body_yaw_rate and thrust
YAW_RATE = 0.3                   # rad/s
THRUST = 0.5                     # of WP_SPEED (5 m/s in rover.parm): 2.5 m/s
SEND_PERIOD_S = 0.1              # wall
DRIVE_S = 25.0                   # autopilot seconds of sending


def _path_speed(track: list[tuple[float, float, float, float]]) -> float:
    """Mean speed along a truth track (path length over time: the boat is circling)."""
    length = sum(math.dist(a[1:3], b[1:3]) for a, b in zip(track, track[1:], strict=False))
    return length / (track[-1][0] - track[0][0])


def _turned(track: list[tuple[float, float, float, float]]) -> float:
    """Heading change along a truth track in radians, unwrapped (positive: clockwise)."""
    total = 0.0
    for a, b in zip(track, track[1:], strict=False):
        total += (b[3] - a[3] + math.pi) % (2 * math.pi) - math.pi
    return total


def test_misconfigured_binary_fails_not_skips(monkeypatch, tmp_path) -> None:
    monkeypatch.delenv(ARDUPILOT_ENV, raising=False)
    assert ardupilot_binary() is None
    monkeypatch.setenv(ARDUPILOT_ENV, str(tmp_path / "missing"))
    with pytest.raises(ArduPilotConfigError, match="no such file"):
        ardupilot_binary()
    plain = tmp_path / "ardurover"
    plain.write_text("")
    monkeypatch.setenv(ARDUPILOT_ENV, str(plain))
    with pytest.raises(ArduPilotConfigError, match="not executable"):
        ardupilot_binary()


@pytest.mark.slow
def test_operator_arms_motorboat_in_guided_after_about_43_autopilot_seconds(real_sitl) -> None:
    sitl = real_sitl(model="motorboat", speedup=10)
    with RealOperator(sitl.ports.serial0) as op:
        op.request_streams(10)
        # retry every autopilot second: 1 s of wall would be 10 s of the autopilot's clock
        wall = op.hand_over("GUIDED", timeout_s=30.0, retry_s=1.0 / sitl.speedup)
        assert op.armed and op.mode == "GUIDED"
        assert op.first_heartbeat_boot_ms is not None and op.handed_over_boot_ms is not None
        took = (op.handed_over_boot_ms - op.first_heartbeat_boot_ms) / 1000.0
        since_hb_wall = op.handed_over_wall - op.first_heartbeat_wall
        gps = next(t for t, text in op.statustexts if "EKF3 IMU0 is using GPS" in text)
        print(f"\n[ardupilot] started in {sitl.ready_s:.2f} s wall on -I {sitl.instance}; "
              f"first HEARTBEAT at boot {op.first_heartbeat_boot_ms} ms; armed GUIDED at boot "
              f"{op.handed_over_boot_ms} ms: {took:.1f} autopilot s after the first HEARTBEAT "
              f"({since_hb_wall:.2f} s wall, x{took / since_hb_wall:.1f}); hand_over {wall:.2f} s "
              "wall")
        print(f"[ardupilot] mode changes (autopilot s): "
              f"{[(None if b is None else b / 1000, m, a) for _, b, m, a in op.modes]}")
        print(f"[ardupilot] {len(op.statustexts)} texts; senders {dict(op.sources)}; "
              f"{op.bad_data} non-MAVLink chunks on SERIAL0")
        assert 38.0 <= took <= 50.0
        assert gps <= op.handed_over_wall      # GUIDED only once the EKF uses GPS
        assert took / since_hb_wall > 1.0      # time_boot_ms runs faster than the wall


@pytest.mark.slow
def test_attitude_target_on_serial1_drives_the_boat_and_times_out(real_sitl) -> None:
    sitl = real_sitl(model="motorboat", speedup=10,
                     params={"SIM_WIND_SPD": 0, "SIM_WAVE_ENABLE": 0})
    with RealOperator(sitl.ports.serial0) as op:
        op.request_streams(10)
        companion = connect_tcp(sitl.ports.serial1, source_system=COMPANION_SYSTEM,
                                source_component=COMPANION_COMPONENT)
        heard: Counter[str] = Counter()
        senders: Counter[tuple[int, int]] = Counter()

        def drain() -> None:
            for m in read_available(companion):
                heard[m.get_type()] += 1
                senders[(m.get_srcSystem(), m.get_srcComponent())] += 1

        try:
            op.hand_over("GUIDED", timeout_s=30.0, retry_s=1.0 / sitl.speedup)
            op.wait_until(lambda: op.boot_ms is not None
                          and op.boot_ms >= op.handed_over_boot_ms + 1000, 5.0, "a second")
            drain()
            start_wall, start_boot = time.monotonic(), op.boot_ms
            servo_idle = op.servo_output_raw.servo3_raw
            next_send = start_wall
            sent = 0
            last_send_wall = last_send_boot = 0
            while op.boot_ms < start_boot + DRIVE_S * 1000:
                now = time.monotonic()
                if now >= next_send:
                    companion.mav.set_attitude_target_send(
                        0, 1, 1, ATTITUDE_TYPE_MASK, [1.0, 0.0, 0.0, 0.0], 0.0, 0.0, YAW_RATE,
                        THRUST)
                    sent += 1
                    last_send_wall, last_send_boot = now, op.boot_ms
                    next_send = max(next_send + SEND_PERIOD_S, now)
                op.poll(0.01)
                drain()
                assert time.monotonic() - start_wall < 30.0, "autopilot clock stalled"
            stop_wall, stop_boot = time.monotonic(), op.boot_ms
            servo_driving = op.servo_output_raw.servo3_raw
            early = [text for t, text in op.statustexts
                     if start_wall <= t <= stop_wall and STOP_TEXT in text]
            hit_wall, _ = op.wait_text(STOP_TEXT, timeout_s=5.0, since=stop_wall)
            hit_boot = op.boot_ms
            op.wait_until(lambda: op.boot_ms >= hit_boot + 3000, 5.0, "3 s after the stop")
            drain()
        finally:
            companion.close()

    drive = truth_track(op, start_wall, stop_wall)
    late = [row for row in drive if row[0] >= drive[-1][0] - 10.0]
    speed, turned = _path_speed(late), _turned(drive)
    rate = _turned(late) / (late[-1][0] - late[0][0])
    after = truth_track(op, hit_wall)
    coast = _path_speed(after[-10:])
    print(f"\n[ardupilot] -I {sitl.instance}: {sent} SET_ATTITUDE_TARGET over "
          f"{(stop_boot - start_boot) / 1000:.1f} autopilot s ({stop_wall - start_wall:.2f} s "
          f"wall); truth speed {speed:.2f} m/s, turn rate {rate:.3f} rad/s over the last 10 s, "
          f"turned {math.degrees(turned):.0f} deg; servo3 {servo_idle} -> {servo_driving}")
    waited = (hit_boot - last_send_boot) / 1000
    print(f"[ardupilot] '{STOP_TEXT}' {waited:.1f} autopilot s after the last send "
          f"({hit_wall - last_send_wall:.2f} s wall); speed 3 s later {coast:.2f} m/s; "
          f"stop texts while sending {len(early)} (a stalled test process, not the autopilot)")
    print(f"[ardupilot] SERIAL1 heard (default streams) from {dict(senders)}: "
          f"{dict(sorted(heard.items()))}")
    assert speed > 1.0
    assert turned > 1.0                    # positive yaw rate: clockwise
    assert 2.5 <= waited <= 5.0


@pytest.mark.slow
def test_two_sitls_side_by_side(real_sitl) -> None:
    t0 = time.monotonic()
    a = real_sitl(model="rover", speedup=20)
    b = real_sitl(model="rover", speedup=20)
    assert a.instance != b.instance
    assert not set(a.ports) & set(b.ports)
    with RealOperator(a.ports.serial0) as op_a, RealOperator(b.ports.serial0) as op_b:
        for sitl, op in ((a, op_a), (b, op_b)):
            op.wait_until(lambda op=op: op.heartbeats > 0, 10.0, "HEARTBEAT")
            sitl.wait_listening(sitl.ports.serial1)
            assert set(sitl.ports) <= listening_ports(sitl.pid)
    print(f"\n[ardupilot] side by side: -I {a.instance} (pid {a.pid}, {a.ports}) and "
          f"-I {b.instance} (pid {b.pid}, {b.ports}); both heard in "
          f"{time.monotonic() - t0:.2f} s wall")
