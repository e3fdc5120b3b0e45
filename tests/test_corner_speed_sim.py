"""A zig-zag of chained TrackLines with 135° corners flown in the mavhelm simulator at 5 m/s,
the sharp corners slowed for (mavhelm.tasks.corner_speed): every line is held in its held part
(from 10 m along it to 5 m before its end) within the simulator's GPS wander."""

from __future__ import annotations

from mavhelm.core.mission import parse_mission
from tests.support.mission import NAV_AP_FALLBACK, mission_text
from tests.support.routes import chained, held_xte, zigzag

ORIGIN = (56.4120, -5.4760)


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
    worst = held_xte(track, points)
    assert None not in worst
    assert max(w[1] for w in worst if w is not None) < 0.8   # its GPS wanders ~0.5 m at most
