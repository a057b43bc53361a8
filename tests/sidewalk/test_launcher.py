"""What the launcher sets up before anything starts: the map the robot gets, where the PILOT believes
it starts (the mission's or the map's start plus the injected error, never the truth), the true
destinations. No processes are started here."""

import math

import numpy as np
import pytest

from sidewalk.codger_run import build_plans
from sidewalk.launcher import RunConfig, prepare_run
from vehicle_sim.node import NodeConfig, SimNode
from vehicle_sim.worldfile import load_world
from wire.network import NetworkConfig


def _args(plans, name: str) -> tuple[str, ...]:
    return next(p.args for p in plans if p.name == name)


def _flag(args: tuple[str, ...], name: str) -> str | None:
    for i, a in enumerate(args):
        if a.startswith(f"{name}="):
            return a.split("=", 1)[1]
        if a == name:
            return args[i + 1]
    return None


def test_the_pilot_starts_from_the_map_start_not_the_truth(tmp_path):
    cfg = RunConfig(mission="campus-tour", out=tmp_path)
    setup = prepare_run(cfg)
    told = load_world("campus", kind="map").start
    truth = load_world("campus").start
    assert (told.x, told.y) != (truth.x, truth.y)  # the shipped map is off: the test can tell them apart
    assert setup.start_belief == pytest.approx((told.x, told.y, math.radians(told.yaw_deg)))
    assert setup.start_truth is None
    plans = build_plans(cfg, setup, "ns", "tcp/127.0.0.1:7447")
    pose = [float(v) for v in _flag(_args(plans, "pilot"), "--start-pose").split(",")]
    assert pose == pytest.approx(list(setup.start_belief))
    assert _flag(_args(plans, "sim"), "--start") is None  # the simulator keeps the world's start
    assert _flag(_args(plans, "map_navigator"), "--map").endswith("campus.map.geojson")
    assert setup.map_error.requested_m is None and setup.map_error.path_max_m > 0.0


def test_the_pose_error_moves_the_told_start_by_exactly_what_was_asked(tmp_path):
    told = load_world("campus", kind="map").start
    for seed in (0, 1, 2):
        b = prepare_run(RunConfig(mission="campus-tour", out=tmp_path, seed=seed, pose_error_m=1.5, pose_error_deg=3.0)).start_belief
        assert math.hypot(b[0] - told.x, b[1] - told.y) == pytest.approx(1.5)
        assert abs(b[2] - math.radians(told.yaw_deg)) == pytest.approx(math.radians(3.0))


def test_a_mission_start_places_the_vehicle_and_the_pilot(tmp_path):
    mission = tmp_path / "here.yaml"
    mission.write_text("mission: here\nworld: campus\nstart: {x: 60, y: -1.0, yaw_deg: 180}\nsteps:\n  - destination: hall\n")
    cfg = RunConfig(mission=str(mission), out=tmp_path / "out", pose_error_m=1.0)
    setup = prepare_run(cfg)
    assert setup.start_truth == pytest.approx((60.0, -1.0, math.pi))
    assert math.hypot(setup.start_belief[0] - 60.0, setup.start_belief[1] + 1.0) == pytest.approx(1.0)
    sim = _args(build_plans(cfg, setup, "ns", "tcp/127.0.0.1:7447"), "sim")
    assert [float(v) for v in _flag(sim, "--start").split(",")] == pytest.approx([60.0, -1.0, 180.0])
    # the simulator puts the vehicle where the flag says
    node = SimNode(load_world("campus"), NodeConfig(start=setup.start_truth), NetworkConfig(namespace="t"))
    assert (node.sim.state.x, node.sim.state.y, node.sim.state.yaw) == pytest.approx((60.0, -1.0, math.pi))


def test_map_error_writes_the_derived_map_and_measures_it(tmp_path):
    cfg = RunConfig(mission="campus-tour", out=tmp_path, map_error_m=0.5, seed=4)
    setup = prepare_run(cfg)
    assert setup.map_file == tmp_path / "map.geojson" and setup.map_file.exists()
    derived = load_world(setup.map_file, kind="map")
    assert setup.start_belief[:2] == pytest.approx((derived.start.x, derived.start.y))
    e = setup.map_error
    assert e.requested_m == 0.5 and max(e.path_max_m, e.landmark_max_m) <= 0.5 + 1e-3 and e.missing >= 1
    assert _flag(_args(build_plans(cfg, setup, "ns", "tcp/127.0.0.1:7447"), "map_navigator"), "--map") == str(setup.map_file)


def test_destinations_are_the_true_places(tmp_path):
    mission = tmp_path / "dests.yaml"
    mission.write_text("mission: d\nworld: campus\nsteps:\n  - destination: library\n  - destination: i_hall\n"
                       "  - destination: {x: 61.2, y: 30}\n")
    setup = prepare_run(RunConfig(mission=str(mission), out=tmp_path / "out"))
    lib = load_world("campus").place("library")
    assert setup.destinations[0] == (lib.x, lib.y)
    assert setup.destinations[1] == (60.0, 0.0)
    # a point off the walks is judged at its nearest point on a walk's centreline (x = 60 runs north)
    assert np.allclose(setup.destinations[2], (60.0, 30.0))


def test_a_step_keeping_to_a_side_is_judged_in_its_lane_of_the_route_arriving(tmp_path):
    # Birch runs north–south (6 m) through the mailbox; the route from the start comes down it from the north, the
    # third step back up it from the south: keeping right, each ends in the lane of its own direction of travel
    mission = tmp_path / "lanes.yaml"
    mission.write_text("mission: l\nworld: north_hills\nvehicle: navlab\nsteps:\n"
                       "  - {destination: mailbox, constraints: [keep_right]}\n"
                       "  - {destination: {x: -240, y: 90}, constraints: [keep_left]}\n"
                       "  - {destination: mailbox, constraints: [keep_right]}\n"
                       "  - destination: mailbox\n")
    setup = prepare_run(RunConfig(world="north_hills", mission=str(mission), out=tmp_path / "out"))
    node = load_world("north_hills").place("mailbox")
    assert setup.lane_offsets == pytest.approx((-1.5, 1.5, -1.5, 0.0))
    west, east = (node.x - 1.5, node.y), (node.x + 1.5, node.y)
    assert setup.goal_points[0] == pytest.approx(west)  # south-bound: the right lane is west of the centre
    assert setup.goal_points[1] == pytest.approx((-240.0 + 1.5, 90.0))  # still south-bound, its left lane
    assert setup.goal_points[2] == pytest.approx(east)  # north-bound
    assert setup.goal_points[3] == pytest.approx((node.x, node.y))  # no side: the destination
    # the campus tour's plaza step comes up the 4 m slope westwards, avoiding the 6 m stairs: judged 1 m north of
    # stairs_top (a quarter of the slope's width, right of west), not on the stairs' lane
    tour = prepare_run(RunConfig(mission="campus-tour", out=tmp_path / "tour"))
    top = load_world("campus").place("stairs_top")
    assert tour.lane_offsets[2] == pytest.approx(-1.0)
    assert tour.goal_points[2] == pytest.approx((top.x, top.y + 1.0), abs=0.05)


def test_lockstep_plans_give_the_simulator_its_flag_and_the_deciders_the_switch(tmp_path):
    from sidewalk.launcher import LOCKSTEP_BYSTANDERS, lockstep_plans
    from wire.timemode import LOCKSTEP_ENV

    cfg = RunConfig(mission="campus-tour", out=tmp_path, lockstep=True)
    assert cfg.time_mode == "lockstep" and RunConfig().time_mode == "realtime"
    plans = lockstep_plans(build_plans(cfg, prepare_run(cfg), "ns", "tcp/127.0.0.1:7447"))
    assert "--lockstep" in _args(plans, "sim") and "--lockstep" not in _args(plans, "pilot")
    for p in plans:
        env = dict(p.env)
        assert env["PYTHONHASHSEED"] == "0", p.name  # the same set iteration order in every process, every run
        assert (env.get(LOCKSTEP_ENV) == "1") == (p.name not in LOCKSTEP_BYSTANDERS), p.name
