"""``mavhelm run`` against the real ArduPilot Rover SITL: the demo mission end to end.

The companion runs as its own process (``mavhelm run examples/demo.moos --connect tcp:... --clock
autopilot``) on the SITL's SERIAL1, paced on the autopilot's ``time_boot_ms``; a ground station
(``ardupilot.RealOperator``) on SERIAL0 arms the boat and switches modes. What is asserted comes
from the companion's .alog (every bus variable, stamped in autopilot seconds), its console lines
and, for the broken link, a TCP proxy between it and SERIAL1 that parses what crosses it.
Wall-clock bounds below only guard against a hang; every timing assertion is in autopilot
seconds. Measured figures are printed (run with ``-s`` to see them).

Tests 2 and 3 judge "which tick" a posting belongs to. The companion posts nothing every tick
while its helm is offline, so those two run the real CLI through a small launcher that also
posts ``TEST_TICK`` (stamped with the tick's own time) at the start of every tick: postings that
follow a ``TEST_TICK`` in the .alog, up to the next one, were made in that tick.

Needs MAVHELM_ARDUPILOT (see tests/support/ardupilot.py); skips without it.
"""

from __future__ import annotations

import math
import queue
import selectors
import socket
import statistics
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.core.bus import Message
from tests.support.ardupilot import (
    CompanionProcess,
    RealOperator,
    _candidates,
    _claim,
    instance_free,
    instance_ports,
    truth_track,
    wait_autopilot,
    wait_line,
    wait_watching,
)

# real_sitl: fixture in conftest.py

pytestmark = pytest.mark.slow

DEMO = Path(__file__).resolve().parent.parent / "examples" / "demo.moos"
SPEEDUP = 10
"""Not faster: these tests assert timings in autopilot seconds, and a loaded machine's stall of
the simulator or the companion lasts speed-up times longer in them. The companion's clock
extrapolates the autopilot's rate between stamps, so at x20 a 0.15 s stall of the simulator
read as a 3 s silent link (a false "link lost"), and the 10 Hz helm fell behind its AppTick."""
TICK_S = 0.1                 # the demo's pHelm AppTick = 10
LINK_TIMEOUT_S = 3.0         # iMAVLink LinkTimeOut (default)
MS = 0.0015                  # the .alog's time stamps are rounded to the millisecond
LINK_TEST_SPEEDUP = 10       # see test_broken_link_...
NO_STALL_S = 1.5             # autopilot s: half LinkTimeOut, far below a blocked connect
CUT_S = 6.0                  # autopilot seconds the proxy refuses the companion
BLIP_S = 0.5                 # and a blip, shorter than the companion's first retry (1 s)
STREAM_HZ = 4                # the operator's telemetry (SIMSTATE truth), autopilot hertz
HAND_OVER_WALL_S = 60.0      # "it did not hang" guards, wall seconds
EVENT_WALL_S = 30.0
MISSION_WALL_S = 90.0

# The built-in simulator runs the demo so (tests/test_demo.py pins the start order there too).
SIM_STARTED = ["InitialDelay", "MissionClock", "South", "North", "Home", "AllStop"]
SIM_ENDED = ["InitialDelay:timeout", "South:timeout", "North:timeout", "Home:complete"]


TICK_MARK = "TEST_TICK"
TICK_LAUNCHER = f"""
import sys
from mavhelm import cli
from mavhelm.companion.companion import Companion
_tick = Companion.tick
def tick(self, now):
    self.bus.notify({TICK_MARK!r}, float(self.community.ticks), "test", time=now)
    _tick(self, now)
Companion.tick = tick
sys.exit(cli.main(sys.argv[1:]))
"""
"""``mavhelm run`` itself (``cli.main``), with a ``TEST_TICK`` posting at the start of each tick."""


# -- the companion process ---------------------------------------------------------------------

TICK_LAUNCH = [sys.executable, "-c", TICK_LAUNCHER]


# -- reading the .alog -------------------------------------------------------------------------

def named(log: list[Message], name: str) -> list[Message]:
    return [m for m in log if m.name == name]


def index_of(log: list[Message], pred, start: int = 0) -> int | None:
    return next((i for i in range(start, len(log)) if pred(log[i])), None)


def tick_numbers(log: list[Message]) -> list[int]:
    """For each posting, the tick it was made in: the number of TEST_TICKs before it, minus 1
    (postings of the last app of a tick, the console, come before the next TEST_TICK)."""
    ticks, n = [], -1
    for m in log:
        if m.name == TICK_MARK:
            n += 1
        ticks.append(n)
    return ticks


def tick_times(log: list[Message]) -> list[float]:
    return [m.time for m in log if m.name == TICK_MARK]


def is_value(name: str, value: float | str):
    return lambda m: m.name == name and m.value == value


# -- a TCP proxy between the companion and SERIAL1 ---------------------------------------------

@dataclass
class ProxiedConnection:
    """One companion connection through the proxy and its own connection to the autopilot."""

    number: int
    client: socket.socket
    upstream: socket.socket
    opened_wall: float
    closed_wall: float | None = None
    sent: list[str] = field(default_factory=list)
    """Message types the companion sent on this connection, in order."""
    sent_wall: list[float] = field(default_factory=list)
    heartbeat_at: int | None = None
    """``len(sent)`` when the autopilot's first HEARTBEAT had been passed on to the companion."""
    heartbeat_wall: float | None = None
    bytes_up: int = 0
    bytes_down: int = 0

    def __post_init__(self) -> None:
        self._up = mavlink.MAVLink(None)
        self._up.robust_parsing = True
        self._down = mavlink.MAVLink(None)
        self._down.robust_parsing = True

    def parse_up(self, data: bytes, now: float) -> None:
        try:
            msgs = self._up.parse_buffer(data) or []
        except mavlink.MAVError:
            msgs = []
        for m in msgs:
            if m.get_type() != "BAD_DATA":
                self.sent.append(m.get_type())
                self.sent_wall.append(now)

    def parse_down(self, data: bytes, now: float) -> None:
        """Only until the autopilot's first HEARTBEAT: that is all the test needs from this
        direction (and parsing all of ArduPilot's telemetry at x20 would cost a core)."""
        if self.heartbeat_at is not None:
            return
        try:
            msgs = self._down.parse_buffer(data) or []
        except mavlink.MAVError:
            msgs = []
        for m in msgs:
            if (m.get_type() == "HEARTBEAT" and m.get_srcSystem() == 1
                    and m.get_srcComponent() == 1 and m.type != mavlink.MAV_TYPE_GCS
                    and m.autopilot != mavlink.MAV_AUTOPILOT_INVALID):
                self.heartbeat_at = len(self.sent)
                self.heartbeat_wall = now
                return

    def sent_before_heartbeat(self) -> list[str]:
        return self.sent if self.heartbeat_at is None else self.sent[:self.heartbeat_at]


class LinkProxy:
    """A loopback TCP proxy (one thread, ``selectors``) on a free port, forwarding both ways to
    ``127.0.0.1:target``. ``cut()`` closes every connection on both sides and the listening
    socket (new connections are refused: ECONNREFUSED); ``restore()`` listens again on the
    same port. Each companion connection is a ``ProxiedConnection`` in ``connections``."""

    def __init__(self, target_port: int, host: str = "127.0.0.1") -> None:
        self.host = host
        self.target = (host, target_port)
        self.connections: list[ProxiedConnection] = []
        self.failed_upstream = 0
        self._sel = selectors.DefaultSelector()
        self._listener: socket.socket | None = self._listen(0)
        self.port: int = self._listener.getsockname()[1]
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._sel.register(self._wake_r, selectors.EVENT_READ, ("wake", None))
        self._commands: queue.Queue = queue.Queue()
        self._running = True
        self._thread = threading.Thread(target=self._run, name="link-proxy", daemon=True)
        self._thread.start()

    def _listen(self, port: int) -> socket.socket:
        s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        s.bind((self.host, port))
        s.listen(4)
        s.setblocking(False)
        self._sel.register(s, selectors.EVENT_READ, ("accept", None))
        return s

    # -- called from the test ----------------------------------------------------------------

    def _do(self, command: str) -> None:
        done = threading.Event()
        self._commands.put((command, done))
        self._wake_w.send(b"x")
        if not done.wait(5.0):
            raise RuntimeError(f"proxy did not {command}")

    def cut(self) -> None:
        self._do("cut")

    def restore(self) -> None:
        self._do("restore")

    def close(self) -> None:
        if self._running:
            self._do("close")
            self._thread.join(5.0)
        self._wake_r.close()
        self._wake_w.close()

    # -- the proxy's thread ------------------------------------------------------------------

    def _run(self) -> None:
        while self._running:
            for key, _ in self._sel.select(0.5):
                kind, conn = key.data
                if kind == "wake":
                    self._commands_due()
                elif kind == "accept":
                    self._accept()
                elif conn.closed_wall is None:
                    self._forward(conn, up=kind == "up")
        self._sel.close()

    def _commands_due(self) -> None:
        try:
            self._wake_r.recv(4096)
        except BlockingIOError:
            pass
        while not self._commands.empty():
            command, done = self._commands.get()
            if command in ("cut", "close"):
                for conn in self.connections:
                    self._close(conn)
                if self._listener is not None:
                    self._sel.unregister(self._listener)
                    self._listener.close()
                    self._listener = None
                if command == "close":
                    self._running = False
            elif command == "restore" and self._listener is None:
                self._listener = self._listen(self.port)
            done.set()

    def _accept(self) -> None:
        assert self._listener is not None
        try:
            client, _ = self._listener.accept()
        except BlockingIOError:
            return
        try:
            upstream = socket.create_connection(self.target, timeout=2.0)
        except OSError:
            self.failed_upstream += 1
            client.close()
            return
        for s in (client, upstream):
            s.settimeout(2.0)
            s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        conn = ProxiedConnection(len(self.connections), client, upstream, time.monotonic())
        self.connections.append(conn)
        self._sel.register(client, selectors.EVENT_READ, ("up", conn))
        self._sel.register(upstream, selectors.EVENT_READ, ("down", conn))

    def _forward(self, conn: ProxiedConnection, up: bool) -> None:
        src, dst = (conn.client, conn.upstream) if up else (conn.upstream, conn.client)
        try:
            data = src.recv(65536)
            if data:
                dst.sendall(data)
        except OSError:
            data = b""
        if not data:
            self._close(conn)
            return
        now = time.monotonic()
        if up:
            conn.bytes_up += len(data)
            conn.parse_up(data, now)
        else:
            conn.bytes_down += len(data)
            conn.parse_down(data, now)   # after passing it on: the companion may have it now

    def _close(self, conn: ProxiedConnection) -> None:
        if conn.closed_wall is not None:
            return
        conn.closed_wall = time.monotonic()
        for s in (conn.client, conn.upstream):
            self._sel.unregister(s)
            s.close()


# -- the tests ---------------------------------------------------------------------------------

def test_demo_mission_end_to_end(real_sitl, tmp_path) -> None:
    sitl = real_sitl(model="motorboat", speedup=SPEEDUP)
    with RealOperator(sitl.ports.serial0).wait_first_heartbeat(STREAM_HZ) as op:
        sitl.wait_listening(sitl.ports.serial1)        # opens once SERIAL0 has a client
        comp = CompanionProcess(DEMO, sitl.ports.serial1, tmp_path / "companion")
        try:
            wait_line(op, comp, "helm offline: autopilot disarmed")
            handing_wall, handing_boot = time.monotonic(), op.boot_ms
            op.hand_over("GUIDED", timeout_s=HAND_OVER_WALL_S, retry_s=1.0 / sitl.speedup)
            online_wall = wait_line(op, comp, "helm ONLINE")
            ended_wall = wait_line(op, comp, "MISSION ENDED", timeout_s=MISSION_WALL_S)
            ended_boot = op.boot_ms
            wait_autopilot(op, comp, 2.0)              # the operator hears the last texts
        finally:
            code = comp.stop()
    log = comp.alog()

    started = [m.string for m in named(log, "TASK_STARTED")]
    ended = [m.string for m in named(log, "TASK_ENDED")]
    online = named(log, "HELM_ONLINE")
    mission_end = named(log, "MISSION_ENDED")
    assert online and online[0].value == 1.0
    mission_ap_s = mission_end[0].time - online[0].time
    mission_wall_s = ended_wall - online_wall
    track = truth_track(op, since_wall=op.handed_over_wall, until_wall=ended_wall)
    farthest = max(math.hypot(n, e) for _, n, e, _ in track)
    final = math.hypot(track[-1][1], track[-1][2])
    seen_by_operator = [text for _, text in op.companion_texts]
    spurious = [m for m in named(log, "MAVLINK_WARNING") if "link lost" in m.string]
    print(f"\n[companion] -I {sitl.instance} x{sitl.speedup:g}: hand-over "
          f"{op.handed_over_wall - handing_wall:.2f} s wall "
          f"({(op.handed_over_boot_ms - handing_boot) / 1000:.1f} autopilot s); mission "
          f"(ONLINE -> MISSION_ENDED) {mission_ap_s:.1f} autopilot s in {mission_wall_s:.2f} s "
          f"wall: x{mission_ap_s / mission_wall_s:.1f}; autopilot boot at the end "
          f"{ended_boot / 1000:.1f} s")
    print(f"[companion] tasks started {started}; ended {ended}")
    print(f"[companion] 'autopilot link lost' warnings although the link never broke: "
          f"{[round(m.time - log[0].time, 3) for m in spurious]} (autopilot s after start)")
    print(f"[companion] SIMSTATE truth: farthest {farthest:.0f} m from the hand-over point, "
          f"{final:.0f} m at MISSION_ENDED ({len(track)} samples)")
    print(f"[companion] operator saw {len(seen_by_operator)} helm texts: "
          f"{seen_by_operator[:8]}")
    assert code == 0 and comp.find("mavhelm: stopped") is not None, comp.output()
    assert spurious == [], "no 'link lost' while the link never broke"
    assert started == SIM_STARTED
    assert ended == SIM_ENDED
    assert [m.string for m in mission_end] == ["AllStop"]
    # online only after the hand-over: not before the first HEARTBEAT saying armed in GUIDED,
    # and in the very tick that heard it (the link's posts of one tick come together, before
    # pNav's and pHelm's; a tick delayed on a busy machine may hear two HEARTBEATs at once);
    # the mission (its first task) began with it
    first_guided = index_of(log, is_value("AP_MODE", "GUIDED"))
    assert first_guided is not None
    armed_then = [m for m in log[first_guided:first_guided + 3] if m.name == "AP_ARMED"]
    assert armed_then and armed_then[0].value == 1.0
    online_at = log.index(online[0])
    assert first_guided < online_at
    assert {m.source for m in log[first_guided:online_at]} == {"iMAVLink"}, \
        log[first_guided:online_at]
    statuses = [m.string for m in named(log, "HELM_STATUS")]
    assert any(s.startswith("offline: autopilot disarmed") for s in statuses[:3])
    assert online_wall > handing_wall
    assert named(log, "TASK_STARTED")[0].time >= online[0].time
    assert farthest > 100.0
    assert "task South started" in seen_by_operator   # the helm's events reach the GCS


def test_manual_mid_mission_stops_actuation_within_one_tick(real_sitl, tmp_path) -> None:
    sitl = real_sitl(model="motorboat", speedup=SPEEDUP)
    with RealOperator(sitl.ports.serial0).wait_first_heartbeat(STREAM_HZ) as op:
        sitl.wait_listening(sitl.ports.serial1)
        comp = CompanionProcess(DEMO, sitl.ports.serial1, tmp_path / "companion",
                                launcher=TICK_LAUNCH)
        try:
            wait_line(op, comp, "helm offline: autopilot disarmed")
            op.hand_over("GUIDED", timeout_s=HAND_OVER_WALL_S, retry_s=1.0 / sitl.speedup)
            wait_line(op, comp, "task South started")
            wait_autopilot(op, comp, 3.0)
            op.set_mode("MANUAL")
            wait_watching(op, comp, lambda: op.mode == "MANUAL", EVENT_WALL_S, "MANUAL")
            wait_line(op, comp, "helm offline: autopilot in MANUAL")
            wait_autopilot(op, comp, 3.0)
            op.hand_over("GUIDED", timeout_s=HAND_OVER_WALL_S, retry_s=1.0 / sitl.speedup)
            wait_line(op, comp, "helm ONLINE", nth=2)
            wait_autopilot(op, comp, 3.0)
        finally:
            code = comp.stop()
    log = comp.alog()
    ticks = tick_numbers(log)
    marks = tick_times(log)

    south = index_of(log, is_value("TASK_STARTED", "South"))
    assert south is not None
    i_manual = index_of(log, is_value("AP_MODE", "MANUAL"), south)
    assert i_manual is not None, "the companion never heard MANUAL"
    i_off = index_of(log, is_value("HELM_ONLINE", 0.0), south)
    i_on = index_of(log, is_value("HELM_ONLINE", 1.0), i_manual)
    assert i_off is not None and i_on is not None
    cmds = ("AP_CMD_THRUST", "AP_CMD_YAW_RATE")
    before = [i for i in range(south, i_manual) if log[i].name in cmds]
    between = [i for i in range(i_manual, i_on) if log[i].name in cmds]
    after = [i for i in range(i_on, len(log)) if log[i].name in cmds]
    tick_manual = ticks[i_manual]
    same_tick = [i for i in between if ticks[i] == tick_manual]
    later = [i for i in between if ticks[i] > tick_manual]
    last_cmd = log[before[-1]] if before else None
    resumed = log[after[0]] if after else None
    t_manual = log[i_manual].time
    print(f"\n[companion] MANUAL heard at {t_manual - log[south].time:.2f} autopilot s into "
          f"South (tick {tick_manual}); HELM_ONLINE 0 {log[i_off].time - t_manual:+.3f} s "
          f"(tick {ticks[i_off]}); last AP_CMD before it "
          f"{(last_cmd.time - t_manual) if last_cmd else float('nan'):+.3f} s (tick "
          f"{ticks[before[-1]] if before else None}); AP_CMD in the MANUAL tick: "
          f"{len(same_tick)}, in later ticks before the hand-back: {len(later)}")
    print(f"[companion] offline for {log[i_on].time - t_manual:.2f} autopilot s; "
          f"AP_CMD_* resumed {(resumed.time - log[i_on].time) if resumed else float('nan'):+.3f}"
          f" s after HELM_ONLINE 1 (tick {ticks[after[0]] - ticks[i_on] if after else None} "
          f"after it); {len(after) // 2} commands after the hand-back; tick period median "
          f"{statistics.median(b - a for a, b in zip(marks, marks[1:], strict=False)):.3f} s")
    assert code == 0, comp.output()
    assert before, "no actuation during South before MANUAL"
    assert ticks[i_off] == tick_manual          # offline in the tick the MANUAL HEARTBEAT came
    assert not later, [(log[i].name, log[i].time - t_manual) for i in later]
    assert not same_tick                        # the bridge documents: stopped in that same tick
    assert after and ticks[after[0]] - ticks[i_on] <= 1
    assert len(after) >= 2 * 10                 # driving again: >= 10 commands in the 3 s after


def test_broken_link_goes_offline_keeps_ticking_and_recovers(real_sitl, tmp_path) -> None:
    # x10, not x20: "no tick gap over 2 periods" is 0.2 autopilot s, which at x20 is 10 ms of
    # wall, and this 2-core machine (SITL + companion + test) delays a wake-up by that much now
    # and then, online or not (measured: max gap 0.25 s at x20 in both phases)
    sitl = real_sitl(model="motorboat", speedup=LINK_TEST_SPEEDUP)
    with RealOperator(sitl.ports.serial0).wait_first_heartbeat(STREAM_HZ) as op:
        sitl.wait_listening(sitl.ports.serial1)
        proxy = LinkProxy(sitl.ports.serial1)
        comp = CompanionProcess(DEMO, proxy.port, tmp_path / "companion", launcher=TICK_LAUNCH)
        try:
            wait_line(op, comp, "helm offline: autopilot disarmed")
            op.hand_over("GUIDED", timeout_s=HAND_OVER_WALL_S, retry_s=1.0 / sitl.speedup)
            wait_line(op, comp, "task South started")
            wait_autopilot(op, comp, 3.0)
            cut_boot = op.boot_ms
            proxy.cut()
            cut_wall = time.monotonic()
            wait_line(op, comp, "helm offline: no")
            # restored 6 autopilot s after the cut; the companion retries 1, 3 and 7 s after
            # the loss (backoff 1-2-4 s), so it is back on the third retry, ~7 s after the cut
            wait_watching(op, comp, lambda: op.boot_ms >= cut_boot + CUT_S * 1000, EVENT_WALL_S,
                     "the end of the cut")
            restore_boot = op.boot_ms
            proxy.restore()
            wait_watching(op, comp, lambda: len(proxy.connections) >= 2, EVENT_WALL_S,
                     "the companion's new connection")
            wait_line(op, comp, "helm ONLINE", nth=2)
            # then a blip shorter than LinkTimeOut (the companion is back 1 s after the loss):
            # its last HEARTBEAT is still fresh, so only the new-connection rule keeps it from
            # actuating on the new connection before the autopilot's HEARTBEAT
            wait_autopilot(op, comp, 2.0)
            blip_boot = op.boot_ms
            proxy.cut()
            wait_watching(op, comp, lambda: op.boot_ms >= blip_boot + BLIP_S * 1000, EVENT_WALL_S,
                     "the end of the blip")
            proxy.restore()
            wait_watching(op, comp, lambda: len(proxy.connections) >= 3
                     and "SET_ATTITUDE_TARGET" in proxy.connections[2].sent, EVENT_WALL_S,
                     "actuation on the third connection")
            wait_line(op, comp, "task North started", timeout_s=MISSION_WALL_S)
            wait_autopilot(op, comp, 1.0)
        finally:
            code = comp.stop()
            proxy.close()
    log = comp.alog()
    ticks = tick_numbers(log)
    marks = tick_times(log)
    assert len(proxy.connections) == 3, proxy.connections
    first, second, third = proxy.connections

    def link_event(word: str, after: int) -> int:
        i = index_of(log, lambda m: m.name == "MAVLINK_LINK" and f" {word}" in m.string, after)
        assert i is not None, f"no 'link {word}' after line {after}"
        return i

    south = index_of(log, is_value("TASK_STARTED", "South"))
    assert south is not None
    # the long cut
    i_lost, i_off = link_event("lost", south), index_of(log, is_value("HELM_ONLINE", 0.0), south)
    assert i_off is not None
    i_open = link_event("open", i_lost)
    i_on = index_of(log, is_value("HELM_ONLINE", 1.0), i_open)
    assert i_on is not None
    i_hb = max(i for i in range(south, i_off) if log[i].name == "AP_MODE")   # the last HEARTBEAT
    hb_tick, off_tick = ticks[i_hb], ticks[i_off]
    hb_time, off_time = marks[hb_tick], marks[off_tick]
    down = marks[ticks[i_lost]:ticks[i_open] + 1]
    gaps = [b - a for a, b in zip(down, down[1:], strict=False)]
    # the blip
    i_lost2 = link_event("lost", i_on)
    i_open2 = link_event("open", i_lost2)
    i_off2 = index_of(log, is_value("HELM_ONLINE", 0.0), i_lost2)
    i_on2 = index_of(log, is_value("HELM_ONLINE", 1.0), i_lost2)
    assert i_off2 is not None and i_on2 is not None
    # what the .alog says was sent while there was no connection at all
    dead = [m for m in log[i_lost:i_off] + log[i_lost2:i_open2] if m.name == "AP_CMD_THRUST"]
    print(f"\n[companion] x{sitl.speedup:g}: link cut {(restore_boot - cut_boot) / 1000:.1f} "
          f"autopilot s; the companion lost it {log[i_lost].time - log[south].time:.2f} s into "
          f"South and was back on a new connection {log[i_open].time - log[i_lost].time:.2f} "
          f"autopilot s later ({second.opened_wall - cut_wall:.2f} s wall after cut())")
    print(f"[companion] last HEARTBEAT -> HELM_ONLINE 0: {off_time - hb_time:.3f} autopilot s "
          f"(tick times; alog post times {log[i_off].time - log[i_hb].time:.3f} s); "
          f"LinkTimeOut {LINK_TIMEOUT_S:g} s + tick {TICK_S:g} s")
    print(f"[companion] link down {down[-1] - down[0]:.2f} autopilot s: {len(down)} ticks, "
          f"gaps median {statistics.median(gaps):.3f} s, max {max(gaps):.3f} s")
    print(f"[companion] new connection: first types the companion sent {second.sent[:7]}; "
          f"the autopilot's HEARTBEAT passed after {second.heartbeat_at} of them; HELM_ONLINE 1 "
          f"{log[i_on].time - log[i_open].time:.2f} autopilot s after it opened")
    print(f"[companion] blip of {BLIP_S:g} autopilot s: back on a new connection "
          f"{log[i_open2].time - log[i_lost2].time:.2f} autopilot s after the loss, offline "
          f"{log[i_on2].time - log[i_off2].time:.2f} s; first types sent {third.sent[:7]}; "
          f"HEARTBEAT passed after {third.heartbeat_at} of them")
    print(f"[companion] SET_ATTITUDE_TARGET through the proxy per connection: "
          f"{[c.sent.count('SET_ATTITUDE_TARGET') for c in proxy.connections]}; AP_CMD_THRUST "
          f"posted while the companion had no connection (nothing could be sent): {len(dead)}")
    assert code == 0, comp.output()
    assert dead == [], "nothing logged as sent while there was no connection"
    assert "SET_ATTITUDE_TARGET" in first.sent
    # offline no later than the first tick past LinkTimeOut after the last HEARTBEAT; here
    # sooner: the cut closes the TCP connection, and a dropped connection is offline at once
    # (the .alog keeps milliseconds: MS of slack)
    assert 0.0 <= off_time - hb_time <= LINK_TIMEOUT_S + TICK_S + MS
    assert ticks[i_off] <= ticks[i_lost], "offline in the tick the connection was lost"
    # kept ticking at AppTick through the outage: the median gap is the tick, and no tick
    # waited on the link (a blocking reconnect would stall for its 5 s time-out, 50 autopilot
    # s at x10); the bound on the longest gap leaves room for a loaded machine's scheduling
    # (0.6 autopilot s = 60 ms of wall time seen beside two busy processes)
    assert (restore_boot - cut_boot) / 1000 >= 5.0 and down[-1] - down[0] >= 5.0
    assert statistics.median(gaps) <= TICK_S + MS, gaps
    assert max(gaps) <= NO_STALL_S, gaps
    # the new connection: no actuation before the autopilot's HEARTBEAT passed on it
    assert second.heartbeat_at is not None
    assert "SET_ATTITUDE_TARGET" not in second.sent_before_heartbeat()
    assert "SET_ATTITUDE_TARGET" in second.sent
    # the blip: back within LinkTimeOut, yet offline from the tick the connection dropped
    # until the new connection's HEARTBEAT, and nothing actuated on it before that passed
    # (the HEARTBEAT may come in the very tick the connection opens: online after the open,
    # in that tick or a later one)
    assert log[i_open2].time - log[i_lost2].time < LINK_TIMEOUT_S
    assert ticks[i_off2] == ticks[i_lost2] < ticks[i_open2] <= ticks[i_on2]
    assert i_open2 < i_on2
    assert third.heartbeat_at is not None
    assert "SET_ATTITUDE_TARGET" not in third.sent_before_heartbeat()
    # back ONLINE and the mission carries on: South ends as planned, North starts
    started = [m.string for m in named(log, "TASK_STARTED")]
    ended = [m.string for m in named(log, "TASK_ENDED")]
    assert started[:4] == SIM_STARTED[:4] and ended[:2] == SIM_ENDED[:2]
    assert any(m.name == "AP_CMD_THRUST" for m in log[i_on2:])


def _free_instance():
    """A free ``-I N`` and its lock (held until the SITL is about to take it)."""
    for instance in _candidates():
        lock = _claim(instance)
        if lock is None:
            continue
        if instance_free(instance):
            return instance, lock
        lock.close()
    pytest.fail("no free ArduPilot SITL instance")


def test_companion_started_before_the_autopilot_waits_then_goes_online(real_sitl,
                                                                       tmp_path) -> None:
    instance, lock = _free_instance()
    ports = instance_ports(instance)
    comp = CompanionProcess(DEMO, ports.serial1, tmp_path / "companion")
    try:
        deadline = time.monotonic() + EVENT_WALL_S
        while comp.find("waiting for the autopilot at") is None:
            assert comp.running(), comp.output()
            assert time.monotonic() < deadline, comp.output()
            time.sleep(0.02)
        waiting_wall = comp.find("waiting for the autopilot at")[0]
        time.sleep(1.5)       # its clock runs at wall speed until the autopilot is heard:
        assert comp.running()  # a retry at +1 s has been refused again by now
        lock.close()
        sitl_wall = time.monotonic()
        sitl = real_sitl(model="motorboat", speedup=SPEEDUP, instance=instance)
        with RealOperator(sitl.ports.serial0).wait_first_heartbeat(STREAM_HZ) as op:
            serial1_wall = time.monotonic() + sitl.wait_listening(ports.serial1)
            open_wall = wait_line(op, comp, "open (MAVLink 2)")
            wait_line(op, comp, "helm offline: autopilot disarmed")
            handing_wall = time.monotonic()
            op.hand_over("GUIDED", timeout_s=HAND_OVER_WALL_S, retry_s=1.0 / sitl.speedup)
            online_wall = wait_line(op, comp, "helm ONLINE")
            wait_line(op, comp, "task InitialDelay started")
    finally:
        lock.close()
        code = comp.stop()
    waits = [line for _, line in comp.lines if "waiting for the autopilot at" in line]
    log = comp.alog()
    spurious = [m for m in named(log, "MAVLINK_WARNING") if "link lost" in m.string]
    print(f"\n[companion] started {sitl_wall - comp.started_wall:.2f} s wall before the SITL "
          f"(-I {instance}); waiting line at +{waiting_wall - comp.started_wall:.2f} s: "
          f"{waits[0]!r}")
    print(f"[companion] SERIAL1 listening at +{serial1_wall - comp.started_wall:.2f} s, link "
          f"open at +{open_wall - comp.started_wall:.2f} s, ONLINE at "
          f"+{online_wall - comp.started_wall:.2f} s wall "
          f"({online_wall - handing_wall:.2f} s after the hand-over began)")
    print(f"[companion] 'autopilot link lost' warnings although the link never broke: "
          f"{[round(m.time - log[0].time, 3) for m in spurious]} (autopilot s after start)")
    assert len(waits) == 1, comp.output()
    assert spurious == [], "no 'link lost' while the link never broke"
    assert waiting_wall < sitl_wall < open_wall
    assert handing_wall < online_wall
    assert code == 0 and comp.find("mavhelm: stopped") is not None, comp.output()
