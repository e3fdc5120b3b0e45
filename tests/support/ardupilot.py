"""A real ArduPilot Rover SITL for tests: start it, talk to it as an operator, stop it.

The binary is not part of mavhelm. Tests find it through ``MAVHELM_ARDUPILOT`` (e.g.
``../shared/ardupilot/ardurover``, its stock parameter files in ``params/`` beside it) and skip
when the variable is unset; when it is set but wrong they fail, so a misconfigured CI cannot
quietly skip. The ``real_sitl`` fixture in conftest.py starts ``RealSitl``s and stops them.

- ``RealSitl(tmp_dir, model=..., speedup=..., params={...})``: the binary running in
  ``tmp_dir`` (it writes eeprom.bin and logs/ in its working folder) on a free instance number
  (``-I N``, N in 20..60, so every port is 5760 + 10 N .. 5763 + 10 N), its output in
  ``ardurover.log`` there. SERIAL0 listens at once; the autopilot's clock does not start, and
  SERIAL1/SERIAL2 do not open, until a client connects to SERIAL0.
- ``RealOperator(port)``: a ground station (system 255, component 190) on SERIAL0, driven by
  ``poll()``: it tracks the autopilot's mode, armed flag, texts, acks, SIMSTATE ground truth and
  servo outputs, sends its own heartbeat each wall second and hands the vehicle over
  (arm, then set the mode) with ``hand_over()``.
- ``connect_tcp(port, ...)``: a pymavlink TCP connection, retried until the port accepts (for a
  companion on SERIAL1, which opens only after SERIAL0 has a client).

A plain helper module (not a test module), imported by the tests that use it.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import math
import os
import select
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections import Counter
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import IO, NamedTuple, Self

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from tests.support.ground_station import GroundStation
from tests.support.processes import PREEXEC, ConsoleProcess
from tests.support.waiting import wait_for

ARDUPILOT_ENV = "MAVHELM_ARDUPILOT"
SKIP_REASON = ("real ArduPilot SITL not configured: "
               f"set {ARDUPILOT_ENV}=../shared/ardupilot/ardurover")

INSTANCES = range(20, 61)          # -I N; clear of a user's -I0/-I1 and of the simulator's ports
BASE_PORT = 5760                   # SERIAL0; SERIAL1 = +2, SERIAL2 = +3; every port moves 10 N
RC_IN_BASE_PORT = 5501             # UDP RC input the SITL binds (5501 + 10 N)
READY_TIMEOUT_S = 30.0
STOP_GRACE_S = 5.0
START_ATTEMPTS = 5
LOG_NAME = "ardurover.log"
EXTRA_PARM = "extra.parm"

GCS_SYSTEM_ID = 255               # ArduPilot takes RC override only from MAV_GCS_SYSID (255)
GCS_COMPONENT_ID = mavlink.MAV_COMP_ID_MISSIONPLANNER    # 190
COMPANION_COMPONENT_ID = mavlink.MAV_COMP_ID_ONBOARD_COMPUTER    # 191, the companion's default

MODEL_DEFAULTS: dict[str, tuple[str, ...]] = {
    "rover": ("rover.parm",),
    "rover-skid": ("rover.parm", "rover-skid.parm"),
    "motorboat": ("rover.parm", "motorboat.parm"),
    "motorboat-skid": ("rover.parm", "motorboat.parm", "rover-skid.parm"),
}


class ArduPilotConfigError(RuntimeError):
    """MAVHELM_ARDUPILOT is set but does not name a runnable binary."""


def ardupilot_binary() -> Path | None:
    """The SITL binary named by MAVHELM_ARDUPILOT (relative paths from the current folder),
    or None when the variable is unset or empty. Raises ArduPilotConfigError when it is set but
    the file is missing or not executable: a CI that meant to run these tests must fail."""
    value = os.environ.get(ARDUPILOT_ENV, "").strip()
    if not value:
        return None
    path = Path(value).expanduser()
    if not path.is_absolute():
        path = Path.cwd() / path
    path = path.resolve()
    if not path.is_file():
        raise ArduPilotConfigError(
            f"{ARDUPILOT_ENV}={value!r}: no such file ({path}); unset it to skip the real-SITL "
            "tests, or point it at the ardurover SITL binary")
    if not os.access(path, os.X_OK):
        raise ArduPilotConfigError(f"{ARDUPILOT_ENV}={value!r}: {path} is not executable")
    return path


class SitlPorts(NamedTuple):
    serial0: int
    serial1: int
    serial2: int


def instance_ports(instance: int) -> SitlPorts:
    base = BASE_PORT + 10 * instance
    return SitlPorts(base, base + 2, base + 3)


def _port_free(port: int, kind: int) -> bool:
    with socket.socket(socket.AF_INET, kind) as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)   # as the SITL binds
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def instance_free(instance: int) -> bool:
    """Whether every port of ``-I instance`` (TCP 5760+10N..5763+10N, UDP RC in 5501+10N) is
    free on 127.0.0.1."""
    base = BASE_PORT + 10 * instance
    return (all(_port_free(p, socket.SOCK_STREAM) for p in range(base, base + 4))
            and _port_free(RC_IN_BASE_PORT + 10 * instance, socket.SOCK_DGRAM))


def _claim(instance: int) -> IO[str] | None:
    """An exclusive lock on the instance number across this machine's test processes (held
    until closed), or None when another process holds it."""
    lock = open(Path(tempfile.gettempdir()) / f"mavhelm-ardupilot-I{instance}.lock", "w")
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        lock.close()
        return None
    return lock


def _candidates(avoid: Iterable[int] = ()) -> list[int]:
    """Instance numbers in an order that depends on the pid, so concurrent runs start apart."""
    n = len(INSTANCES)
    start = (os.getpid() * 7) % n
    avoid = set(avoid)
    return [INSTANCES[(start + i) % n] for i in range(n) if INSTANCES[(start + i) % n] not in avoid]


def listening_ports(pid: int) -> set[int]:
    """TCP ports on which process ``pid`` holds a listening socket (Linux /proc)."""
    inodes: set[str] = set()
    with contextlib.suppress(OSError):
        for fd in os.scandir(f"/proc/{pid}/fd"):
            with contextlib.suppress(OSError):
                target = os.readlink(fd.path)
                if target.startswith("socket:["):
                    inodes.add(target[8:-1])
    ports: set[int] = set()
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        with contextlib.suppress(OSError), open(table) as f:
            next(f, None)
            for line in f:
                fields = line.split()
                if len(fields) > 9 and fields[3] == "0A" and fields[9] in inodes:
                    ports.add(int(fields[1].rsplit(":", 1)[1], 16))
    return ports


class RealSitl:
    """The real ArduPilot SITL binary, started in ``tmp_dir`` on a free instance number.

    ``defaults`` replaces the model's stock parameter files (names in the binary's ``params/``
    folder, or paths); ``params`` ({"WP_SPEED": 2, ...}) are written to ``extra.parm`` in
    ``tmp_dir`` and loaded last. ``instance`` pins ``-I N`` instead of choosing one.
    Use as a context manager, or ``start()``/``stop()``.
    """

    def __init__(self, tmp_dir: str | os.PathLike[str], *, model: str = "motorboat",
                 speedup: float = 10, instance: int | None = None,
                 home: tuple[float, float, float, float] = (56.4120, -5.4760, 0, 90),
                 params: dict[str, float] | None = None, defaults: list[str] | None = None,
                 binary: str | os.PathLike[str] | None = None,
                 ready_timeout_s: float = READY_TIMEOUT_S) -> None:
        if binary is None:
            binary = ardupilot_binary()
            if binary is None:
                raise ArduPilotConfigError(SKIP_REASON)
        self.binary = Path(binary)
        if defaults is None:
            if model not in MODEL_DEFAULTS:
                raise ValueError(f"no default parameter files for model {model!r}; "
                                 f"pass defaults=[...] (known: {', '.join(MODEL_DEFAULTS)})")
            defaults = list(MODEL_DEFAULTS[model])
        self.tmp_dir = Path(tmp_dir)
        self.model = model
        self.speedup = speedup
        self.home = home
        self.params = dict(params or {})
        self.requested_instance = instance
        self.ready_timeout_s = ready_timeout_s
        self.log_path = self.tmp_dir / LOG_NAME
        self.defaults = [self._param_file(name) for name in defaults]
        self.instance: int | None = None
        self.ports: SitlPorts | None = None
        self.proc: subprocess.Popen | None = None
        self.started_at: float | None = None     # wall (monotonic) time the binary started
        self.ready_s: float | None = None        # wall seconds until SERIAL0 listened
        self._log: IO[bytes] | None = None
        self._lock: IO[str] | None = None

    def _param_file(self, name: str) -> Path:
        path = Path(name)
        if not path.is_absolute() and not path.exists():
            path = self.binary.parent / "params" / name
        if not path.is_file():
            raise ArduPilotConfigError(f"parameter file {name!r} not found ({path})")
        return path.resolve()

    @property
    def pid(self) -> int | None:
        return self.proc.pid if self.proc is not None else None

    def running(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def command_line(self, instance: int) -> list[str]:
        files = list(self.defaults)
        if self.params:
            extra = self.tmp_dir / EXTRA_PARM
            extra.write_text("".join(f"{name} {value}\n" for name, value in self.params.items()))
            files.append(extra)
        return [str(self.binary), "--model", self.model, "--speedup", f"{self.speedup:g}",
                "-I", str(instance), "-w",
                "--home", ",".join(str(v) for v in self.home),
                "--defaults", ",".join(str(f) for f in files)]

    def log_tail(self, lines: int = 25) -> str:
        try:
            text = self.log_path.read_text(errors="replace")
        except OSError:
            return "(no log)"
        return "\n".join(text.splitlines()[-lines:])

    def start(self) -> RealSitl:
        if self.proc is not None:
            raise RuntimeError("RealSitl already started")
        self.tmp_dir.mkdir(parents=True, exist_ok=True)
        tried: list[int] = []
        for _ in range(START_ATTEMPTS):
            instance = self._pick_instance(tried)
            tried.append(instance)
            if self._start_on(instance):
                return self
        raise RuntimeError(f"ArduPilot SITL could not bind its ports (tried -I {tried}); "
                           f"log {self.log_path}:\n{self.log_tail()}")

    def _pick_instance(self, tried: list[int]) -> int:
        if self.requested_instance is not None:
            if tried:
                raise RuntimeError(f"-I {self.requested_instance}: its ports are taken; "
                                   f"log {self.log_path}:\n{self.log_tail()}")
            lock = _claim(self.requested_instance)
            if lock is None:
                raise RuntimeError(f"-I {self.requested_instance} is held by another test run")
            self._lock = lock
            return self.requested_instance
        for instance in _candidates(tried):
            lock = _claim(instance)
            if lock is None:
                continue
            if instance_free(instance):
                self._lock = lock
                return instance
            lock.close()
        raise RuntimeError(f"no free ArduPilot SITL instance in -I {INSTANCES.start}.."
                           f"{INSTANCES.stop - 1}")

    def _start_on(self, instance: int) -> bool:
        """Start on ``-I instance``; True once SERIAL0 listens, False if its ports were taken
        meanwhile (then the next instance is tried). Raises on any other failure."""
        cmd = self.command_line(instance)
        self._log = open(self.log_path, "ab")  # closed in stop()
        self._log.write(f"$ {' '.join(cmd)}\n".encode())
        self._log.flush()
        self.started_at = time.monotonic()
        self.proc = subprocess.Popen(
            cmd, cwd=self.tmp_dir, stdin=subprocess.DEVNULL, stdout=self._log,
            stderr=subprocess.STDOUT,
            preexec_fn=PREEXEC)
        self.instance = instance
        self.ports = instance_ports(instance)
        deadline = self.started_at + self.ready_timeout_s
        while True:
            if self.proc.poll() is not None:
                tail = self.log_tail()
                code = self.proc.returncode
                self._release()
                if "bind failed" in tail:
                    return False
                raise RuntimeError(f"ArduPilot SITL exited with code {code} before SERIAL0 "
                                   f"listened; log {self.log_path}:\n{tail}")
            if self.ports.serial0 in listening_ports(self.proc.pid):
                self.ready_s = time.monotonic() - self.started_at
                return True
            if time.monotonic() > deadline:
                self.stop()
                raise RuntimeError(f"ArduPilot SITL did not listen on SERIAL0 (TCP "
                                   f"{self.ports.serial0}) within {self.ready_timeout_s:g} s; "
                                   f"log {self.log_path}:\n{self.log_tail()}")
            time.sleep(0.02)

    def wait_listening(self, port: int, timeout_s: float = 10.0) -> float:
        """Wall seconds until the SITL listens on ``port`` (SERIAL1/2 open only after a client
        has connected to SERIAL0)."""
        t0 = time.monotonic()
        while port not in listening_ports(self.pid or -1):
            if not self.running():
                raise RuntimeError(f"ArduPilot SITL exited; log:\n{self.log_tail()}")
            if time.monotonic() - t0 > timeout_s:
                raise TimeoutError(f"ArduPilot SITL not listening on {port} after "
                                   f"{timeout_s:g} s; log:\n{self.log_tail()}")
            time.sleep(0.02)
        return time.monotonic() - t0

    def stop(self) -> int | None:
        """SIGTERM the SITL (its own pid only), SIGKILL after 5 s; returns its exit code."""
        code = None
        if self.proc is not None:
            if self.proc.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    self.proc.send_signal(signal.SIGTERM)
                try:
                    self.proc.wait(STOP_GRACE_S)
                except subprocess.TimeoutExpired:
                    with contextlib.suppress(ProcessLookupError):
                        self.proc.kill()
                    self.proc.wait()
            code = self.proc.returncode
        self._release()
        return code

    def _release(self) -> None:
        if self._log is not None:
            self._log.close()
            self._log = None
        if self._lock is not None:
            self._lock.close()
            self._lock = None

    def __enter__(self) -> RealSitl:
        if self.proc is None:
            self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def __repr__(self) -> str:
        return (f"RealSitl(model={self.model!r}, speedup={self.speedup:g}, "
                f"instance={self.instance}, pid={self.pid}, ports={self.ports})")


def connect_tcp(port: int, *, source_system: int, source_component: int,
                host: str = "127.0.0.1", timeout_s: float = 10.0) -> mavutil.mavfile:
    """A pymavlink TCP connection to ``host:port``, retried every 20 ms until it is accepted."""
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            return mavutil.mavlink_connection(f"tcp:{host}:{port}", source_system=source_system,
                                              source_component=source_component,
                                              dialect="ardupilotmega", retries=0)
        except OSError as exc:
            if exc.errno not in (errno.ECONNREFUSED, errno.ECONNRESET) \
                    or time.monotonic() > deadline:
                raise
            time.sleep(0.02)


def wait_readable(conn: mavutil.mavfile, timeout_s: float) -> None:
    if timeout_s > 0:
        select.select([conn.port], [], [], timeout_s)


def read_available(conn: mavutil.mavfile) -> list:
    """Every message whose bytes have arrived on a non-blocking pymavlink TCP connection, read
    in bulk; bytes that are not MAVLink (the SITL's boot banner on SERIAL0) come back as
    BAD_DATA messages."""
    messages: list = []
    while data := conn.recv(65536):
        try:
            messages.extend(conn.mav.parse_buffer(data) or [])
        except mavlink.MAVError as exc:
            messages.append(mavlink.MAVLink_bad_data(data, str(exc)))
    return messages


class RealOperator(GroundStation):
    """A ground station (system 255, component 190) on the SITL's SERIAL0.

    Call ``poll()`` often: it reads what arrived, updates the tracked state and sends the GCS
    heartbeat each wall second. Wall times are ``time.monotonic()``; autopilot times are the
    ``time_boot_ms`` of the autopilot's messages (its simulated clock, ``speedup`` × faster).
    Besides the autopilot's own texts it keeps the companion's (system 1, component 191), which
    ArduPilot routes to SERIAL0, in ``companion_texts``.
    """

    def __init__(self, port: int, *, host: str = "127.0.0.1", target_system: int = 1,
                 target_component: int = 1, connect_timeout_s: float = 10.0,
                 heartbeat_s: float = 1.0) -> None:
        self.heartbeat_s = heartbeat_s
        self.mode_names: dict[int, str] = dict(mavutil.mode_mapping_rover)
        """custom_mode → name: Rover's; an ArduSub operator sets mavutil.mode_mapping_sub."""
        """Wall seconds between this GCS's heartbeats: 1/speedup keeps the 1 Hz of the
        autopilot's time a real ground station gives a SITL running in real time."""
        self.conn = connect_tcp(port, source_system=GCS_SYSTEM_ID,
                                source_component=GCS_COMPONENT_ID, host=host,
                                timeout_s=connect_timeout_s)
        self.connected_at = time.monotonic()
        self.target_system = target_system
        self.target_component = target_component
        self.mode: str | None = None
        self.armed = False
        self.system_status: int | None = None
        self.heartbeats = 0
        self.first_heartbeat_wall: float | None = None
        self.first_heartbeat_boot_ms: int | None = None
        self.boot_ms: int | None = None           # latest time_boot_ms from the autopilot
        self.statustexts: list[tuple[float, str]] = []
        self.companion_texts: list[tuple[float, str]] = []
        self.acks: list[tuple[float, int, int]] = []
        # changes of (mode, armed): wall, boot ms, mode, armed
        self.modes: list[tuple[float, int | None, str, bool]] = []
        self.simstate = None                       # latest SIMSTATE (ground truth)
        # every SIMSTATE: wall, boot ms, lat and lng (1e-7 deg), yaw (rad)
        self.simstates: list[tuple[float, int | None, int, int, float]] = []
        self.servo_output_raw = None
        self.counts: Counter[str] = Counter()      # messages from the autopilot, by type
        self.sources: Counter[tuple[int, int]] = Counter()   # every message, by (sysid, compid)
        self.bad_data = 0
        self.handed_over_wall: float | None = None
        self.handed_over_boot_ms: int | None = None
        self._next_heartbeat = 0.0

    # -- receiving ---------------------------------------------------------------------------

    def poll(self, timeout_s: float = 0.0) -> list:
        """Send the heartbeat if due, wait up to ``timeout_s`` for data, handle what arrived."""
        now = time.monotonic()
        if now >= self._next_heartbeat:
            self._next_heartbeat = now + self.heartbeat_s
            self.heartbeat()
        wait_readable(self.conn, min(timeout_s, max(0.0, self._next_heartbeat - now)))
        msgs = read_available(self.conn)
        now = time.monotonic()
        for msg in msgs:
            self._handle(msg, now)
        return msgs

    def _handle(self, msg, now: float) -> None:
        kind = msg.get_type()
        if kind == "BAD_DATA":
            self.bad_data += 1
            return
        self.sources[(msg.get_srcSystem(), msg.get_srcComponent())] += 1
        if (kind == "STATUSTEXT" and msg.get_srcSystem() == self.target_system
                and msg.get_srcComponent() == COMPANION_COMPONENT_ID):
            self.companion_texts.append((now, msg.text))
        if (msg.get_srcSystem() != self.target_system
                or msg.get_srcComponent() != self.target_component):
            return
        self.counts[kind] += 1
        boot = getattr(msg, "time_boot_ms", None)
        if isinstance(boot, int):
            self.boot_ms = boot
            if self.heartbeats and self.first_heartbeat_boot_ms is None:
                self.first_heartbeat_boot_ms = boot
        if kind == "HEARTBEAT" and msg.type != mavlink.MAV_TYPE_GCS:
            self.heartbeats += 1
            if self.first_heartbeat_wall is None:
                self.first_heartbeat_wall = now
                self.first_heartbeat_boot_ms = self.boot_ms
            mode = self.mode_names.get(msg.custom_mode, str(msg.custom_mode))
            armed = bool(msg.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
            if (mode, armed) != (self.mode, self.armed):
                self.modes.append((now, self.boot_ms, mode, armed))
            self.mode, self.armed, self.system_status = mode, armed, msg.system_status
        elif kind == "STATUSTEXT":
            self.statustexts.append((now, msg.text))
        elif kind == "COMMAND_ACK":
            self.acks.append((now, msg.command, msg.result))
        elif kind == "SIMSTATE":
            self.simstate = msg
            self.simstates.append((now, self.boot_ms, msg.lat, msg.lng, msg.yaw))
        elif kind == "SERVO_OUTPUT_RAW":
            self.servo_output_raw = msg

    def wait_until(self, predicate: Callable[[], bool], timeout_s: float, what: str) -> float:
        """Poll until ``predicate()``; returns the wall seconds it took, raises TimeoutError
        (with the autopilot's last texts) after ``timeout_s``."""
        t0 = time.monotonic()
        wait_for(predicate, timeout_s, what, self._seen, pause=lambda: self.poll(0.02),
                 error=TimeoutError)
        return time.monotonic() - t0

    def _seen(self) -> str:
        return f"mode {self.mode}, armed {self.armed}; last texts: {self.texts()[-8:]}"

    def wait_text(self, fragment: str, timeout_s: float, since: float = 0.0) -> tuple[float, str]:
        """The first STATUSTEXT containing ``fragment`` received at or after wall time
        ``since``: (wall time, text)."""
        def found() -> tuple[float, str] | None:
            return next(((t, s) for t, s in self.statustexts if t >= since and fragment in s),
                        None)
        self.wait_until(lambda: found() is not None, timeout_s, f"text {fragment!r}")
        hit = found()
        assert hit is not None
        return hit

    def texts(self) -> list[str]:
        return [text for _, text in self.statustexts]

    def last_ack(self, command: int) -> int | None:
        return next((result for _, cmd, result in reversed(self.acks) if cmd == command), None)

    @property
    def mav(self) -> mavlink.MAVLink:
        return self.conn.mav

    def wait_first_heartbeat(self, stream_hz: int, timeout_s: float = 10.0) -> Self:
        """Ask for every stream at ``stream_hz`` and wait for the autopilot's first HEARTBEAT
        (how a test's ground station starts); returns itself."""
        self.request_streams(stream_hz)
        self.wait_until(lambda: self.heartbeats > 0, timeout_s, "the autopilot's first HEARTBEAT")
        return self

    # -- handing over ------------------------------------------------------------------------

    def hand_over(self, mode: str = "GUIDED", timeout_s: float = 60.0,
                  retry_s: float = 1.0) -> float:
        """Arm, then switch to ``mode``, retrying every ``retry_s`` wall seconds (as a person
        clicking again would: ArduPilot refuses until its EKF uses GPS) until the heartbeat says
        armed in ``mode``. The mode is asked for at once when an arm is accepted. Returns the
        wall seconds it took; ``handed_over_wall``/``handed_over_boot_ms`` record when."""
        mode = mode.upper()
        t0 = time.monotonic()
        next_try = t0
        acks_seen = len(self.acks)
        while not (self.armed and self.mode == mode):
            now = time.monotonic()
            if now - t0 > timeout_s:
                raise TimeoutError(f"not armed in {mode} after {timeout_s:g} s wall (mode "
                                   f"{self.mode}, armed {self.armed}); last texts: "
                                   f"{self.texts()[-8:]}")
            arm_accepted = any(cmd == mavlink.MAV_CMD_COMPONENT_ARM_DISARM
                               and result == mavlink.MAV_RESULT_ACCEPTED
                               for _, cmd, result in self.acks[acks_seen:])
            acks_seen = len(self.acks)
            if self.mode is not None and (now >= next_try or arm_accepted):
                next_try = now + retry_s
                if self.armed or arm_accepted:
                    self.set_mode(mode)
                else:
                    self.arm()
            self.poll(min(0.02, retry_s))
        self.handed_over_wall = time.monotonic()
        self.handed_over_boot_ms = self.boot_ms
        return self.handed_over_wall - t0

    def close(self) -> None:
        self.conn.close()

    def __enter__(self) -> RealOperator:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def truth_track(op: RealOperator, since_wall: float = 0.0,
                until_wall: float = math.inf) -> list[tuple[float, float, float, float]]:
    """SIMSTATE ground truth between two wall times as (autopilot s, north m, east m, yaw rad),
    north/east from the first sample (flat earth: fine over a few hundred metres)."""
    rows = [(boot, lat, lng, yaw) for wall, boot, lat, lng, yaw in op.simstates
            if since_wall <= wall <= until_wall and boot is not None]
    if not rows:
        return []
    _, lat0, lng0, _ = rows[0]
    k = math.radians(1e-7) * 6_371_000.0
    coslat = math.cos(math.radians(lat0 * 1e-7))
    return [(boot / 1000.0, (lat - lat0) * k, (lng - lng0) * k * coslat, yaw)
            for boot, lat, lng, yaw in rows]


class CompanionProcess(ConsoleProcess):
    """``mavhelm run MISSION --connect tcp:127.0.0.1:PORT --clock autopilot`` in its own
    process (or the same through ``launcher``, a command standing in for ``python -m
    mavhelm.cli``); its console lines are collected, with the wall time each was read."""

    def __init__(self, mission: Path, port: int, log_dir: Path, *,
                 launcher: list[str] | None = None) -> None:
        self.log_dir = Path(log_dir)
        self.log_dir.mkdir(parents=True, exist_ok=True)
        head = launcher or [sys.executable, "-m", "mavhelm.cli"]
        super().__init__(head + ["run", str(mission), "--connect", f"tcp:127.0.0.1:{port}",
                                 "--clock", "autopilot", "--log-dir", str(self.log_dir)],
                         cwd=self.log_dir)

    def alog(self) -> list:
        from mavhelm.companion.alog import read_alog

        paths = sorted(self.log_dir.glob("*.alog"))
        assert len(paths) == 1, f"expected one .alog in {self.log_dir}, found {paths}"
        return read_alog(paths[0])


# -- waiting on the operator while the companion runs ----------------------------------------------

def wait_watching(op: RealOperator, comp: CompanionProcess | None, predicate: Callable[[], object],
                  timeout_s: float, what: str) -> float:
    """Poll the operator until ``predicate()``; fail at once if the companion exited, and with
    its console on a time-out. Returns the wall seconds it took."""
    def check() -> bool:
        if comp is not None and not comp.running():
            raise AssertionError(f"the companion exited (code {comp.proc.returncode}) while "
                                 f"waiting for {what}:\n{comp.output()}")
        return bool(predicate())
    try:
        return op.wait_until(check, timeout_s, what)
    except TimeoutError as exc:
        tail = comp.output() if comp is not None else ""
        raise AssertionError(f"{exc}\ncompanion console:\n{tail}") from None


def wait_line(op: RealOperator, comp: CompanionProcess, fragment: str, nth: int = 1,
              timeout_s: float = 30.0) -> float:
    """Wait for the companion's ``nth`` console line containing ``fragment``; the wall time it
    was read."""
    wait_watching(op, comp, lambda: comp.find(fragment, nth) is not None, timeout_s,
                  f"companion line {fragment!r} #{nth}")
    hit = comp.find(fragment, nth)
    assert hit is not None
    return hit[0]


def wait_autopilot(op: RealOperator, comp: CompanionProcess | None, seconds: float) -> int:
    """Let ``seconds`` of the autopilot's clock pass (its time_boot_ms on SERIAL0); returns the
    boot ms reached."""
    assert op.boot_ms is not None
    until = op.boot_ms + int(seconds * 1000)
    wait_watching(op, comp, lambda: op.boot_ms is not None and op.boot_ms >= until,
                  5.0 + 3.0 * seconds, f"{seconds:g} autopilot s")
    return op.boot_ms
