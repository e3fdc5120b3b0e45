"""``mavhelm view``: several vehicles on one link, told apart by MAV_SYSID, each with the task
that steers it; first the model on messages made here, then three simulators and three
companions fanned out to one UDP port (each simulator's ``--out``, as ArduPilot's telemetry
ports or MAVProxy's ``--out`` would)."""

from __future__ import annotations

import json
import re
import sys
import threading
import time
import urllib.request

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mavlink

from mavhelm.companion.fleet import Fleet
from mavhelm.companion.status import Goal, HelmState, TaskStarted
from mavhelm.companion.status_wire import STATUS_PAYLOAD_TYPE, encode
from mavhelm.demo.groundstation import GroundStation, Operator
from tests.support.interop_helpers import REPO, SimProcess
from tests.support.mission import mission_text
from tests.support.ports import free_port, free_udp_port
from tests.support.processes import ConsoleProcess
from tests.support.waiting import wait_for


def heard(msg, system: int, component: int):
    mav = mavlink.MAVLink(None, srcSystem=system, srcComponent=component)
    return mav.decode(bytearray(msg.pack(mav)))


def tunnel(event) -> mavlink.MAVLink_tunnel_message:
    data = encode(event)
    return mavlink.MAVLink_tunnel_message(0, 0, STATUS_PAYLOAD_TYPE, len(data),
                                          list(data) + [0] * (128 - len(data)))


def test_the_fleet_keeps_each_system_apart():
    fleet = Fleet()
    boat_hb = mavlink.MAVLink_heartbeat_message(
        mavlink.MAV_TYPE_SURFACE_BOAT, mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
        mavlink.MAV_MODE_FLAG_SAFETY_ARMED, 15, 0, 3)
    gcs_hb = mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS,
                                               mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3)
    for system in (2, 3):
        fleet.take(heard(boat_hb, system, 1), 0.0)
        fleet.take(heard(tunnel(HelmState(True, "ONLINE: autopilot armed in GUIDED")),
                         system, 191), 0.0)
        fleet.take(heard(tunnel(TaskStarted(f"Leg{system}")), system, 191), 0.0)
        fleet.take(heard(tunnel(Goal(f"Leg{system}", "heading 90")), system, 191), 0.0)
        fleet.take(heard(mavlink.MAVLink_named_value_float_message(0, b"NAV_X", 10.0 * system),
                         system, 191), 0.0)
    fleet.take(heard(gcs_hb, 255, 190), 0.0)
    bad = tunnel(TaskStarted("X"))
    bad.payload[0] = 99  # not this wire version
    fleet.take(heard(bad, 4, 191), 0.0)
    fleet.take(heard(mavlink.MAVLink_named_value_float_message(0, b"NAV_Y", float("nan")),
                     5, 191), 0.0)
    rows = fleet.rows(1.0)
    assert [r["sysid"] for r in rows] == [2, 3]
    assert [r["steering"] for r in rows] == ["Leg2: heading 90", "Leg3: heading 90"]
    assert [(r["mode"], r["armed"], r["online"], r["x"]) for r in rows] == \
        [("GUIDED", True, True, 20.0), ("GUIDED", True, True, 30.0)]
    lines = fleet.lines(10.0)
    assert len(lines) == 3 and "Leg3: heading 90  (silent)" in lines[2]


def boat_tasks(n: int) -> str:
    return f"""
    Task = ConstantHeading
    {{
        Name = Leg{n}
        Heading = {60 * n}
        Thrust = 40
        TimeOut = 300
        FinishFlag = EndMission
    }}
"""


@pytest.mark.slow
def test_three_boats_on_one_screen(tmp_path):
    port, web = free_udp_port(), free_port()
    view = ConsoleProcess([sys.executable, "-u", "-m", "mavhelm.cli", "view", "--connect",
                           f"udpin:127.0.0.1:{port}", "--web", f"127.0.0.1:{web}"], cwd=REPO,
                          log_path=tmp_path / "view.log")
    sims: list[SimProcess] = []
    companions: list[ConsoleProcess] = []
    operators: list[Operator] = []
    running = True

    def operate() -> None:
        start = time.monotonic()
        while running:
            for op in operators:
                op.tick(time.monotonic() - start)
            time.sleep(0.05)

    thread = threading.Thread(target=operate, daemon=True)
    try:
        for n in (2, 3, 4):
            sim = SimProcess("--fast-start", "--param", f"MAV_SYSID={n}", "--out",
                             f"udp:127.0.0.1:{port}", "--home", f"56.41{n},-5.476,0")
            sims.append(sim)
            mission = tmp_path / f"boat{n}.moos"
            mission.write_text(mission_text(
                boat_tasks(n), origin=(56.41 + n / 1000, -5.476), overall_timeout=600,
                imavlink={"Connect": f"tcp:127.0.0.1:{sim.ports[0]}", "SystemID": n,
                          "TargetSystem": n}))
            companions.append(ConsoleProcess(
                [sys.executable, "-u", "-m", "mavhelm.cli", "run", str(mission), "--log-dir",
                 str(tmp_path)], cwd=REPO, log_path=tmp_path / f"companion{n}.log"))
            gcs = GroundStation.connect(f"tcp:127.0.0.1:{sim.ports[1]}")
            gcs.target_system = n
            operators.append(Operator(gcs))
        thread.start()

        def table() -> list[str] | None:
            blocks = view.find_all("mavhelm view ")
            if not blocks:
                return None
            lines = [line for _, line in list(view.lines)]
            last = max(i for i, line in enumerate(lines) if line.startswith("mavhelm view "))
            rows = lines[last + 2:last + 2 + 3]
            steering = [re.search(r"Leg\d", row) for row in rows]
            if len(rows) == 3 and all(steering) and all(" GUIDED " in row for row in rows):
                return rows
            return None
        rows = wait_for(table, 60.0, "three vehicles, each steered by its own Leg task",
                        lambda: view.output(8))
        assert [int(row.split()[0]) for row in rows] == [2, 3, 4]
        assert [re.search(r"Leg\d", row).group(0) for row in rows] == ["Leg2", "Leg3", "Leg4"]

        def owners() -> list[tuple[int, str]]:
            with urllib.request.urlopen(f"http://127.0.0.1:{web}/api/state",
                                        timeout=5) as answer:
                page = json.loads(answer.read())
            return [(b["sysid"], b["owner"]) for b in page["boats"]]

        # the page's server is a separate process fed a few frames a second: on a loaded
        # machine it may be a frame behind the console
        seen: list[list[tuple[int, str]]] = []
        wait_for(lambda: seen.append(owners()) or seen[-1] == [(2, "Leg2"), (3, "Leg3"),
                                                                (4, "Leg4")],
                 20.0, "the page showing the three boats and their Leg tasks", lambda: seen[-1:])
    finally:
        running = False
        if thread.is_alive():
            thread.join(2.0)
        for op in operators:
            op.gcs.close()
        for proc in companions:
            proc.stop()
        for sim in sims:
            sim.close()
        view.stop()
