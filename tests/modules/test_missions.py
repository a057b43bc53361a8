"""The shipped missions: valid, written for their worlds, and routed as the issue asks."""

from __future__ import annotations

from pathlib import Path

import pytest

from modules.captain import load_mission
from codger.map_navigator.__main__ import start_position
from modules.map_navigator import NavigatorOptions, Planned, StepJob, load_map
from modules.vocabulary import Mission, RouteSegmentDescription

WORLDS = Path(__file__).resolve().parents[2] / "worlds"


def _plan_all(m: Mission) -> list[tuple[Planned, tuple[RouteSegmentDescription, ...]]]:
    """Plan every step in order from the map's start, each from the previous step's goal."""
    assert m.world is not None
    mp = load_map(m.world)
    pos = start_position(mp, None)
    out = []
    for i, _ in enumerate(m.steps):
        run_step = _step_token(m, i)
        job = StepJob(mp, run_step, pos, NavigatorOptions(vehicle=m.vehicle or "terregator"))
        planned = job.plan()
        assert isinstance(planned, Planned), planned
        out.append((planned, planned.segments))
        pos = planned.plan.goal_xy
    return out


def _step_token(m: Mission, i: int):
    from modules.captain import MissionRun

    return MissionRun(m).step_token(i)


@pytest.mark.parametrize("name", ["campus-tour", "campus-stairs", "amv-delivery"])
def test_shipped_missions_parse_and_name_real_places(name: str) -> None:
    m = load_mission(WORLDS / f"{name}.yaml")
    assert m.name == name and m.world is not None
    mp = load_map(m.world)
    for s in m.steps:
        assert s.destination.place is not None and mp.find_place(s.destination.place) is not None, s.destination


def test_campus_tour_passes_three_intersections_and_the_slope_keeping_right() -> None:
    m = load_mission(WORLDS / "campus-tour.yaml")
    assert len(m.steps) >= 4 and all(s.constraints.keep == "right" for s in m.steps)
    plans = _plan_all(m)
    segs = [s for _, ss in plans for s in ss]
    inter = {s.path_object_ids for s in segs if "intersection" in s.mode}
    assert len(inter) >= 3
    assert any(s.mode == "go-through-slope" for s in segs)
    assert all(s.constraints.keep == "right" and s.constraints.lateral_offset_m < 0 for s in segs)
    assert not any(s.mode == "climb-stairs" for s in segs)


def test_campus_stairs_takes_the_slope_although_the_stairs_are_shorter() -> None:
    m = load_mission(WORLDS / "campus-stairs.yaml")
    assert m.steps[-1].constraints.avoid_stairs
    (planned, segs), = _plan_all(m)
    assert "e_slope" in planned.plan.edge_ids and "e_stairs" not in planned.plan.edge_ids
    free = m.model_copy(update={"steps": (m.steps[0].model_copy(update={"constraints": m.steps[0].constraints.model_copy(update={"avoid_stairs": False})}),)})
    (planned_free, _), = _plan_all(free)
    assert "e_stairs" in planned_free.plan.edge_ids
    assert planned_free.plan.cost < planned.plan.cost


def test_amv_delivery_drives_the_navlab_to_the_mailbox_with_two_left_turns() -> None:
    m = load_mission(WORLDS / "amv-delivery.yaml")
    assert m.vehicle == "navlab" and m.world == "north_hills"
    (planned, segs), = _plan_all(m)
    assert planned.plan.node_ids[-1] == "mailbox"
    turns = [s for s in segs if s.mode == "turn-at-intersection"]
    assert len(turns) == 2
    assert segs[-1].constraints.stop_at_exit and segs[-1].constraints.speed_limit == 5.0
    assert planned.plan.length_m > 600.0
