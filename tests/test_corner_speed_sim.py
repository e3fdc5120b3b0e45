"""A zig-zag of chained TrackLines with 135° corners flown in the mavhelm simulator at 5 m/s,
the sharp corners slowed for (mavhelm.tasks.corner_speed): every line is held in the window
(from 10 m along it to 5 m before its end) as a straight one is."""

from __future__ import annotations

import math

from mavhelm.core.mission import parse_mission
from mavhelm.tasks.geometry import track_position
from tests.support.mission import NAV_AP_FALLBACK, mission_text
from tests.test_corner_speed import zigzag

ORIGIN = (56.4120, -5.4760)


def chained(points: list[tuple[float, float]]) -> str:
    blocks = []
    for k in range(len(points) - 1):
        (x1, y1), (x2, y2) = points[k], points[k + 1]
        start = f"        StartFlag = Line{k}\n" if k else ""
        finish = f"Line{k + 1}" if k < len(points) - 2 else "EndMission"
        blocks.append(f"""
    Task = TrackLine
    {{
        Name = T{k}
        P1 = {x1:.3f}, {y1:.3f}
        P2 = {x2:.3f}, {y2:.3f}
        Radius = 1
        Thrust = 100
        TimeOut = 200
{start}        FinishFlag = {finish}
    }}
""")
    return "".join(blocks)


def test_a_zig_zag_with_135_degree_corners_is_held_at_5_m_s() -> None:
    from mavhelm.demo.harness import SimulatedRun

    points = zigzag(135.0)
    text = mission_text(chained(points), origin=ORIGIN, nav=NAV_AP_FALLBACK,
                        imavlink=[("OnlineModes", "GUIDED")], helm={"MAXTHRUST": 100},
                        overall_timeout=300, clock_name="Clock", end_name="AllStop")
    mission = parse_mission(text, "zigzag.moos")
    with SimulatedRun.start(mission, fast_start=True, start_heading=90.0,
                            params={"WP_SPEED": 5.0}) as run:
        assert run.run_mission(max_time=300, linger=0.0)
        track = [(s.x, s.y) for s in run.track]
    for p1, p2 in zip(points[1:], points[2:], strict=False):
        length = math.dist(p1, p2)
        # the points of this line's window: near it, and nearer than to any other line
        held = []
        for p in track:
            along, xte = track_position(p1, p2, p)
            if 10.0 <= along <= length - 5.0 and abs(xte) < 5.0:
                held.append(abs(xte))
        assert held and max(held) < 0.8       # the simulator's GPS wanders ~0.5 m at most
