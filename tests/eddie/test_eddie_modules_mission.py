"""The EDDIE mission service's core: routes per step from the MAP NAVIGATOR, outcomes judged from the believed pose."""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddie.modules.mission_progress import MissionProgress, MissionRouteError, step_goals
from modules.captain.missionfile import load_mission, parse_mission
from modules.map_navigator import load_map
from vehicle_sim.worldfile import WORLDS_DIR


@pytest.fixture(scope="module")
def campus():
    return load_map("campus")


def _along(route, step_m: float = 0.5):
    """Yield points every `step_m` [m] along a polyline."""
    pts = np.asarray(route)
    for a, b in zip(pts[:-1], pts[1:]):
        n = max(1, int(np.linalg.norm(b - a) / step_m))
        for t in np.arange(n) / n:
            yield tuple(a + t * (b - a))
    yield tuple(pts[-1])


def test_a_drive_along_each_route_succeeds_step_by_step_with_the_trigger_wait(campus) -> None:
    mission = load_mission(WORLDS_DIR / "campus-tour.yaml").model_copy(update={"mission_id": "tour-1"})
    start = (campus.world.start.x, campus.world.start.y)
    goals = step_goals(campus, start, mission)
    assert [g.step_index for g in goals] == [0, 1, 2, 3]
    assert goals[2].speed_mps == pytest.approx(0.8)
    assert all(math.dist(goals[i].route[-1], goals[i].goal) < 1.0 for i in range(4))
    prog = MissionProgress(mission, goals, submitted_at=0.0)
    prog.start(0.0)
    t, changes = 0.0, []
    for g in goals:
        for p in _along(g.route):
            t += 0.5
            if prog.update(t, p):
                changes.append((t, prog.status.current_step, prog.status.state))
    for _ in range(10):  # the wait of step 3 ("wait 2 s") ends in sim time, standing at the last goal
        t += 0.5
        prog.update(t, goals[-1].goal)
    st = prog.status
    assert st.state == "succeeded", st
    assert [s.state for s in st.steps] == ["succeeded"] * 4
    assert len(changes) >= 4
    assert st.steps[0].finished_at < st.steps[1].finished_at < st.steps[3].finished_at


def test_a_vehicle_that_stands_still_fails_the_step_after_the_stall_time(campus) -> None:
    mission = load_mission(WORLDS_DIR / "campus-tour.yaml").model_copy(update={"mission_id": "tour-2"})
    start = (campus.world.start.x, campus.world.start.y)
    prog = MissionProgress(mission, step_goals(campus, start, mission), stall_s=20.0)
    prog.start(0.0)
    t = 0.0
    while not prog.status.terminal and t < 100.0:
        t += 1.0
        prog.update(t, start)
    st = prog.status
    assert st.state == "failed" and 20.0 < st.finished_at <= 22.0
    assert "no progress" in st.steps[0].reason and st.steps[1].state == "cancelled"


def test_progress_is_judged_along_the_route_even_where_it_leads_away_from_the_goal() -> None:
    from eddie.modules.mission_progress import StepGoal

    mission = load_mission(WORLDS_DIR / "amv-delivery.yaml").model_copy(update={"mission_id": "u-turn"})
    # a U: 60 m north, 10 m east, 60 m south to a goal 10 m east of the start — the first minute leads away from it
    route = ((0.0, 0.0), (0.0, 60.0), (10.0, 60.0), (10.0, 0.0))
    prog = MissionProgress(mission, [StepGoal(step_index=0, route=route, goal=(10.0, 0.0), reach_m=1.5)], stall_s=20.0)
    prog.start(0.0)
    t = 0.0
    for p in _along(route, 1.0):  # 1 m/s
        t += 1.0
        prog.update(t, p)
    st = prog.status
    assert st.state == "succeeded", st
    # standing still on the way still fails, and says what it waited for
    prog = MissionProgress(mission, [StepGoal(step_index=0, route=route, goal=(10.0, 0.0), reach_m=1.5)], stall_s=20.0)
    prog.start(0.0)
    for k in range(1, 40):
        prog.update(float(k), (0.0, 30.0))
    st = prog.status
    assert st.state == "failed" and "along the route" in st.steps[0].reason and "100.0 m of its route left" in st.steps[0].reason


def test_a_belief_off_across_the_route_arrives_at_the_routes_end_and_one_far_off_does_not() -> None:
    from eddie.modules.mission_progress import StepGoal

    mission = load_mission(WORLDS_DIR / "amv-delivery.yaml").model_copy(update={"mission_id": "offset"})
    route = ((0.0, 0.0), (0.0, 20.0))
    goals = [StepGoal(step_index=0, route=route, goal=(0.0, 20.0), reach_m=1.5)]
    for offset, want in ((1.4, "succeeded"), (3.5, "failed")):
        prog = MissionProgress(mission, goals, stall_s=20.0)
        prog.start(0.0)
        t = 0.0
        for p in _along(((offset, 0.0), (offset, 20.0)), 1.0):  # the belief runs `offset` m beside the route
            t += 1.0
            prog.update(t, p)
        for k in range(30):  # then stands at the end
            prog.update(t + k + 1.0, (offset, 20.0))
        assert prog.status.state == want, (offset, prog.status)
        if want == "succeeded":  # 1.4 m off is outside the 1.2 m the distance test takes: the route's end decided
            assert "end of its route" in prog.status.steps[0].reason


def test_a_step_to_an_unknown_place_names_the_step(campus) -> None:
    text = "mission: lost\nsteps:\n  - name: nowhere\n    destination: atlantis\n"
    mission = parse_mission(text.encode(), source="t")
    with pytest.raises(MissionRouteError, match="step 1 \\(nowhere\\)"):
        step_goals(campus, (0.0, -28.0), mission)
