"""``mavhelm sim`` and ``mavhelm run --web`` as two processes, with an operator's ground station
handing the vehicle over on a thread: what the web view's tests and benchmark look at.

``state()`` reads the page's last frame (``/api/state``); ``control(action)`` posts an action as
the page's buttons do; ``gcs`` (under ``lock``) is the operator's own ground station.
"""

from __future__ import annotations

import json
import re
import sys
import threading
import time
import urllib.error
import urllib.request
from pathlib import Path
from typing import Any

from mavhelm.demo.groundstation import GroundStation, Operator
from tests.support.interop_helpers import REPO, SimProcess
from tests.support.mission import mission_text
from tests.support.ports import free_port
from tests.support.processes import ConsoleProcess
from tests.support.waiting import wait_for

TASKS = """
    Task = Timer
    {
        Name = Wait
        TimeOut = 2
        FinishFlag = Go
    }
    Task = TrackLine
    {
        Name = OutLeg
        P1 = 0,0
        P2 = 40,0
        Thrust = 60
        StartFlag = Go
        FinishFlag = Back
    }
    Task = GoToWayPoint
    {
        Name = HomeLeg
        Location = 0,20
        Radius = 4
        Thrust = 60
        StartFlag = Back
        FinishFlag = EndMission
    }
    Task = LimitBox
    {
        Name = Fence
        XMin = -100
        XMax = 100
        YMin = -100
        YMax = 100
        EventFlag = OutOfBox
    }
"""
"""Wait, then out along a line (OutLeg), then to a waypoint (HomeLeg): the task that steers
changes about 20 s after the hand-over."""

TOKEN_LINE = re.compile(r"token (\S+) ")


class LiveRun:
    """The two processes and the ground station; a context manager that stops them all."""

    def __init__(self, folder: Path, *, control: bool = False, tasks: str = TASKS,
                 web: bool = True) -> None:
        self.folder = folder
        self.sim = SimProcess("--fast-start", "--home", "56.4120,-5.4760,0")
        self.companion: ConsoleProcess | None = None
        self.gcs: GroundStation | None = None
        self.lock = threading.Lock()
        self._running = True
        self._thread: threading.Thread | None = None
        try:
            ports = self.sim.ports
            mission = folder / "web.moos"
            mission.write_text(mission_text(
                tasks, imavlink={"Connect": f"tcp:127.0.0.1:{ports[0]}", "RemoteFlag": "GoHome"},
                overall_timeout=600))
            self.web_port = free_port()
            cmd = [sys.executable, "-u", "-m", "mavhelm.cli", "run", str(mission),
                   "--log-dir", str(folder)]
            if web:
                cmd += ["--web", f"127.0.0.1:{self.web_port}"]
            if control:
                cmd.append("--web-control")
            self.companion = ConsoleProcess(cmd, cwd=REPO, log_path=folder / "companion.log")
            if web:
                wait_for(lambda: self.companion.find("web view on"), 20.0,
                         "the companion's 'web view on' line", self.companion.output)
            self.gcs = GroundStation.connect(f"tcp:127.0.0.1:{ports[1]}")
            self.operator = Operator(self.gcs)
            self._thread = threading.Thread(target=self._operate, daemon=True)
            self._thread.start()
        except BaseException:
            self.close()
            raise

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.web_port}/"

    @property
    def token(self) -> str:
        assert self.companion is not None
        found = self.companion.find("token ")
        assert found is not None, self.companion.output()
        match = TOKEN_LINE.search(found[1])
        assert match is not None, found[1]
        return match.group(1)

    def _operate(self) -> None:
        start = time.monotonic()
        while self._running:
            with self.lock:
                self.operator.tick(time.monotonic() - start)
            time.sleep(0.05)

    def hand_over(self, timeout: float = 30.0) -> None:
        wait_for(lambda: self.operator.handed_over_at is not None, timeout,
                 "the operator to arm and switch to GUIDED",
                 lambda: (self.gcs.mode, self.gcs.armed, self.gcs.statustexts[-3:]))

    def state(self) -> dict[str, Any]:
        with urllib.request.urlopen(self.url + "api/state", timeout=5) as answer:
            return json.loads(answer.read())

    def control(self, action: str, token: str | None, body: dict | None = None
                ) -> tuple[int, dict[str, Any]]:
        """POST an action as the page does: (HTTP status, JSON answer)."""
        headers = {"Content-Type": "application/json"}
        if token is not None:
            headers["X-Mavhelm-Token"] = token
        request = urllib.request.Request(self.url + f"api/control/{action}", method="POST",
                                         data=json.dumps(body or {}).encode(), headers=headers)
        try:
            with urllib.request.urlopen(request, timeout=5) as answer:
                return answer.status, json.loads(answer.read())
        except urllib.error.HTTPError as exc:
            return exc.code, json.loads(exc.read() or b"{}")

    def close(self) -> None:
        self._running = False
        if self._thread is not None:
            self._thread.join(2.0)
        if self.gcs is not None:
            self.gcs.close()
        if self.companion is not None:
            self.companion.stop()
        self.sim.close()

    def __enter__(self) -> LiveRun:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
