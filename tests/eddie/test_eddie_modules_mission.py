"""The EDDIE mission service's core: routes per step from the MAP NAVIGATOR, outcomes judged from the believed pose."""

from __future__ import annotations

import math

import numpy as np
import pytest

from eddie.mission_service.mission_progress import MissionProgress, MissionRouteError, step_goals
from modules.captain.arrival import REST_HOLD_S
from modules.captain.missionfile import load_mission, parse_mission
from modules.map_navigator import load_map
from modules.vocabulary import MissionStatus
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
        if mission.steps[g.step_index].trigger.action != "continue":  # the vehicle stops there: claimed once at rest
            for _ in range(4):
                t += 0.5
                if prog.update(t, g.route[-1]):
                    changes.append((t, prog.status.current_step, prog.status.state))
    for _ in range(10):  # the wait of step 3 ("wait 2 s") ends in sim time, standing at the last goal
        t += 0.5
        prog.update(t, goals[-1].goal)
    st = prog.status
    assert st.state == "succeeded", st
    assert [s.state for s in st.steps] == ["succeeded"] * 4
    assert len(changes) >= 4
    assert st.steps[0].finished_at < st.steps[1].finished_at < st.steps[3].finished_at


def _stand_still(campus, mission_id: str, waiting: str = "") -> MissionStatus:  # noqa: ANN001
    """Return the status of a campus tour whose vehicle stands at the start (stall time 20 s), `waiting` after 10 s."""
    mission = load_mission(WORLDS_DIR / "campus-tour.yaml").model_copy(update={"mission_id": mission_id})
    start = (campus.world.start.x, campus.world.start.y)
    prog = MissionProgress(mission, step_goals(campus, start, mission), stall_s=20.0)
    prog.start(0.0)
    t = 0.0
    while not prog.status.terminal and t < 100.0:
        t += 1.0
        prog.update(t, start, waiting=waiting if t > 10 else "")
    return prog.status


def test_a_vehicle_that_stands_still_fails_the_step_after_the_stall_time(campus) -> None:
    st = _stand_still(campus, "tour-2")
    assert st.state == "failed" and 20.0 < st.finished_at <= 22.0
    assert "no progress" in st.steps[0].reason and st.steps[1].state == "cancelled"


def test_a_stalled_step_says_what_the_vehicle_waited_for(campus) -> None:
    why = "obstacle hold (obstacle stop sees something 8.8 m ahead on the path at 3.0 s)"
    assert _stand_still(campus, "tour-3", why).steps[0].reason.endswith(f"waiting: {why}")


def test_progress_is_judged_along_the_route_even_where_it_leads_away_from_the_goal() -> None:
    from eddie.mission_service.mission_progress import StepGoal

    mission = load_mission(WORLDS_DIR / "amv-delivery.yaml").model_copy(update={"mission_id": "u-turn"})
    # a U: 60 m north, 10 m east, 60 m south to a goal 10 m east of the start — the first minute leads away from it
    route = ((0.0, 0.0), (0.0, 60.0), (10.0, 60.0), (10.0, 0.0))
    prog = MissionProgress(mission, [StepGoal(step_index=0, route=route, goal=(10.0, 0.0), reach_m=1.5)], stall_s=20.0)
    prog.start(0.0)
    t = 0.0
    for p in _along(route, 1.0):  # 1 m/s
        t += 1.0
        prog.update(t, p)
    assert prog.arrival is not None and prog.status.state == "running"  # arrived, not yet at rest
    arrived = prog.arrival[1]
    for _ in range(2):  # then stands
        t += 1.0
        prog.update(t, route[-1])
    st = prog.status
    assert st.state == "succeeded" and st.steps[0].finished_at == arrived + REST_HOLD_S, st
    # standing still on the way still fails, and says what it waited for
    prog = MissionProgress(mission, [StepGoal(step_index=0, route=route, goal=(10.0, 0.0), reach_m=1.5)], stall_s=20.0)
    prog.start(0.0)
    for k in range(1, 40):
        prog.update(float(k), (0.0, 30.0))
    st = prog.status
    assert st.state == "failed" and "along the route" in st.steps[0].reason and "100.0 m of its route left" in st.steps[0].reason


def test_a_belief_off_across_the_route_arrives_at_the_routes_end_and_one_far_off_does_not() -> None:
    from eddie.mission_service.mission_progress import StepGoal

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


def _where_it_ends(prog: MissionProgress, drive) -> tuple[float, float] | None:
    """Drive the belief along `drive` at 1 m/s, one update every 0.1 m; return where the step arrived (None: it did not).

    The last step is claimed once the vehicle is at rest: standing where it arrived, it is.
    """
    prog.start(0.0)
    t = 0.0
    for p in _along(drive, 0.1):
        t += 0.1
        prog.update(t, p)
        if prog.arrival is not None or prog.status.terminal:
            for _ in range(20):  # it stops there
                t += 0.1
                prog.update(t, p)
            assert prog.status.state == "succeeded" and "; at rest" in prog.status.steps[0].reason, prog.status
            return p
    return None


def test_a_step_ends_at_the_closest_approach_not_at_the_reachs_edge() -> None:
    from eddie.mission_service.mission_progress import SETTLE_S, StepGoal

    mission = load_mission(WORLDS_DIR / "amv-delivery.yaml").model_copy(update={"mission_id": "closest"})
    goals = [StepGoal(step_index=0, route=((0.0, 0.0), (0.0, 20.0)), goal=(0.0, 20.0), reach_m=1.5)]
    # driving on to the route's end: the belief enters the 1.2 m circle at 18.8 m, the step ends at the route's end
    prog = MissionProgress(mission, goals, stall_s=20.0)
    ended_at = _where_it_ends(prog, ((0.0, 0.0), (0.0, 20.0)))
    assert prog.status.state == "succeeded" and ended_at is not None and ended_at[1] >= 19.4, ended_at
    # a belief 0.9 m beside the route passes the goal's side: the step ends just past the closest approach
    prog = MissionProgress(mission, [goals[0].model_copy(update={"route": ((0.9, 0.0), (0.9, 30.0))})], stall_s=20.0)
    ended_at = _where_it_ends(prog, ((0.9, 0.0), (0.9, 30.0)))
    assert ended_at is not None and 20.0 < ended_at[1] < 21.0, ended_at
    # stopped inside the reach short of the route's end: the step ends once the belief stops closing in
    prog = MissionProgress(mission, goals, stall_s=20.0)
    prog.start(0.0)
    t = 0.0
    for p in _along(((0.0, 0.0), (0.0, 19.0)), 0.1):
        t += 0.1
        prog.update(t, p)
    assert prog.status.state == "running"
    stood = t
    while not prog.status.terminal and t < stood + 10.0:
        t += 0.1
        prog.update(t, (0.0, 19.0))
    assert prog.status.state == "succeeded" and t - stood == pytest.approx(SETTLE_S, abs=0.3)


def test_the_dead_reckoned_route_keeps_to_the_steps_side_in_its_lane(campus) -> None:
    from eddie.missions.lane import kept_lane_offset, shift_into_lane

    # a quarter of the width, at most the keep offset, leaving the clearance inside the edge; the right is negative
    assert kept_lane_offset("right", 8.0, 1.5, 1.0) == pytest.approx(-1.5)
    assert kept_lane_offset("left", 4.0, 1.5, 1.0) == pytest.approx(1.0)
    assert kept_lane_offset("right", 3.0, 1.5, 1.0) == pytest.approx(-0.5)
    assert kept_lane_offset("right", 1.5, 1.5, 1.0) == 0.0 and kept_lane_offset(None, 8.0, 1.5, 1.0) == 0.0
    # one offset per vertex: a road narrowing from 8 m to 3 m along the way north
    out = shift_into_lane(np.array([[0.0, 0.0], [0.0, 10.0], [0.0, 20.0]]), np.array([-1.5, -1.5, -0.5]))
    assert out[:, 0] == pytest.approx([1.5, 1.5, 0.5]) and out[:, 1] == pytest.approx([0.0, 10.0, 20.0])


def test_a_step_kept_right_ends_in_its_goals_lane_where_the_road_leaves_room(campus) -> None:
    from eddie.missions.lane import KERB_MARGIN_M
    from eddie.mission_service.mission_progress import mission_route
    from modules.pilot import pilot_config_for

    mission = load_mission(WORLDS_DIR / "campus-tour.yaml").model_copy(update={"mission_id": "tour-lanes"})
    goals = step_goals(campus, (campus.world.start.x, campus.world.start.y), mission)
    nav = pilot_config_for("terregator").navigator
    kw = dict(speed_mps=1.0, keep_offset_m=nav.keep_offset, edge_keep_m=nav.obstacle_clearance + KERB_MARGIN_M)
    pts, speeds, offsets = mission_route(campus, goals, mission.steps, **kw)
    assert len(pts) == len(speeds) == len(offsets)

    def at(goal):
        return int(np.argmin([math.dist(p, goal) for p in pts]))

    # the plaza: its goal's lane is the slope's the route arrives on (4 m: a quarter, 1.0 m right of the route's last
    # direction, west), as far as 1.6 m inside the edge leaves (0.4 m); the quad's and the library's walks (2 m, 3 m)
    # leave a 2 m vehicle no room off their centre line
    plaza = at(goals[2].goal)
    assert goals[2].lane_offset_m == pytest.approx(-1.0)
    assert goals[2].lane_goal == pytest.approx((goals[2].goal[0], goals[2].goal[1] + 1.0), abs=0.01)  # north of it
    assert offsets[plaza] == pytest.approx(-0.4)
    assert offsets[at(goals[0].goal)] == 0.0 and offsets[at(goals[3].goal)] == 0.0
    # in its lane the route turns north at the plaza 0.4 m inside the corner
    lane_pts, _, _ = mission_route(campus, goals, mission.steps, in_lane=True, **kw)
    assert math.dist(lane_pts[plaza], goals[2].goal) == pytest.approx(0.4, abs=0.01)
    assert lane_pts[plaza][0] > goals[2].goal[0] and lane_pts[plaza][1] > goals[2].goal[1]
    # the route road following asks for carries them, one per point (or none: the centre line)
    from eddie.messages.modules import MissionRoute

    assert MissionRoute(mission_id="m", points=tuple(pts), speeds=tuple(speeds), offsets=tuple(offsets), state="running").offsets[plaza] == pytest.approx(-0.4)
    with pytest.raises(ValueError, match="one per point"):
        MissionRoute(mission_id="m", points=((0.0, 0.0), (1.0, 0.0)), offsets=(0.0,))


def _heading_drive(points, step_m: float = 0.2):
    """Yield (x, y, yaw) every `step_m` [m] along a polyline, yaw [rad] the direction of travel."""
    pts = np.asarray(points, dtype=float)
    for a, b in zip(pts[:-1], pts[1:]):
        yaw = math.atan2(b[1] - a[1], b[0] - a[0])
        n = max(1, int(np.linalg.norm(b - a) / step_m))
        for t in np.arange(n) / n:
            x, y = a + t * (b - a)
            yield float(x), float(y), yaw


def _two_steps(route1, route2, goal1, goal2, *, lane_offset_m: float | None):
    from eddie.mission_service.mission_progress import StepGoal

    text = "mission: corner\nsteps:\n  - name: first\n    destination: a\n  - name: second\n    destination: b\n"
    mission = parse_mission(text.encode(), source="t").model_copy(update={"mission_id": "corner"})

    def goal(i, route, g):
        return StepGoal(step_index=i, route=route, goal=g, reach_m=1.5, lane_offset_m=lane_offset_m)

    return mission, [goal(0, route1, goal1), goal(1, route2, goal2)]


def test_a_step_kept_right_whose_next_step_turns_is_reached_when_the_vehicle_turns_short_of_the_corner() -> None:
    # west along y = 0 to the corner (0, 0), then north; keeping right, the vehicle turns north 1.5 m short of the
    # corner: 1.5 m from the goal and from its lane's goal (north of it, right of the route's last direction), outside
    # the reach less the margin, but on the next step's route near its start: it turned onto it, the step is done.
    # Which way the vehicle faces does not move the goal (the mission service is told no heading)
    mission, goals = _two_steps(((20.0, 0.0), (0.0, 0.0)), ((0.0, 0.0), (0.0, 30.0)), (0.0, 0.0), (0.0, 30.0), lane_offset_m=-1.5)
    assert goals[0].lane_goal == pytest.approx((0.0, 1.5))
    drive = list(_heading_drive(((20.0, 0.0), (1.5, 0.0), (1.5, 29.0))))
    prog = MissionProgress(mission, goals, stall_s=20.0)
    prog.start(0.0)
    t = 0.0
    for x, y, _yaw in drive:  # 1 m/s
        t += 0.2
        prog.update(t, (x, y))
        if prog.status.current_step == 1:
            break
    assert prog.status.steps[0].state == "succeeded"
    assert 1.4 <= x <= 1.6 and 0.5 <= y < 1.5, (x, y)  # just past the turn, on the next route
    assert "onto the next step's route" in prog.status.steps[0].reason
    # one that turns north 4 m short of the corner is on neither route near the goal: the step fails
    prog = MissionProgress(mission, goals, stall_s=20.0)
    prog.start(0.0)
    t = 0.0
    for x, y, _yaw in _heading_drive(((20.0, 0.0), (4.0, 0.0), (4.0, 29.0))):
        t += 0.2
        prog.update(t, (x, y))
    assert prog.status.steps[0].state == "failed"


def test_a_pass_through_the_goal_between_two_looks_ends_the_step_once_the_belief_is_along_the_next_route() -> None:
    # north to (0, 20), then on north; looks 4.2 m apart (RTF 50 on a loaded machine) straddle the goal, neither
    # inside its reach, the second past the route's end: on the next route, it went through the goal
    mission, goals = _two_steps(((0.0, 0.0), (0.0, 20.0)), ((0.0, 20.0), (0.0, 50.0)), (0.0, 20.0), (0.0, 50.0), lane_offset_m=-0.5)
    looks = [(0.0, float(y)) for y in np.arange(1.2, 48.0, 4.2)]  # ..., 18.0, 22.2, ...
    assert min(abs(y - 20.0) for _, y in looks) > 1.9
    past = 4.2 * (1 + next(k for k, (_, y) in enumerate(looks) if y > 20.0))  # when the first look past the goal comes
    for beside, want in ((0.6, "succeeded"), (2.5, "failed")):  # on the next route, or more than the reach beside it
        prog = MissionProgress(mission, goals, stall_s=20.0)
        prog.start(0.0)
        t = 0.0
        for x, y in looks:
            t += 4.2
            prog.update(t, (x + beside, y))
        for k in range(10):  # then stands at the second step's end
            t += 4.2
            prog.update(t, (beside, 48.0))
        st = prog.status
        assert st.steps[0].state == want, (beside, st.steps[0])
        if want == "succeeded":
            assert "onto the next step's route" in st.steps[0].reason and st.steps[0].finished_at == pytest.approx(past)
