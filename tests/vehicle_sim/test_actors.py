"""Actors (objects not on the map): scripted motion, seen by the scanner, collisions counted, clear file errors."""

from __future__ import annotations

import math

import numpy as np
import pytest

from modules.perception.obstacles import LaserScan, detect_obstacles
from tests.vehicle_sim.test_scene import GREEN, GREY, box
from vehicle_sim.actors import Actor, ActorError, ActorSet, Waypoint, load_actors
from vehicle_sim.scene import Scene
from vehicle_sim.sensors import CaptureRequest, capture
from vehicle_sim.simulator import SimConfig, Simulator
from vehicle_sim.worldfile import KINDS, FlatShape, World, WorldObject
from wire.drive import DriveCommand


def road_world() -> World:
    """Return a flat road along +x (y in -3…3) on grass."""
    return World(name="road", objects=[
        WorldObject(id="grass", kind="grass", role="none", cost=3.0, **GREEN, shape=FlatShape(), polygon=box(-20, -30, 80, 30)),
        WorldObject(id="road", kind="road", role="path", cost=1.0, **GREY, shape=FlatShape(), polygon=box(-20, -3, 80, 3)),
    ])


def walker(**kw) -> Actor:
    base = dict(id="w", kind="pedestrian", speed=1.0,
                path=(Waypoint(x=20.0, y=-4.0), Waypoint(x=20.0, y=0.0, dwell=5.0), Waypoint(x=20.0, y=4.0)))
    base.update(kw)
    return Actor(**base)


def test_walker_follows_its_script_with_dwell() -> None:
    s = ActorSet([walker()])
    assert s.states(0.0)[0].y == pytest.approx(-4.0)
    assert s.states(2.0)[0].y == pytest.approx(-2.0)
    mid = s.states(6.0)[0]  # arrived at 4 s, dwells until 9 s
    assert mid.y == pytest.approx(0.0) and not mid.moving
    assert s.states(11.0)[0].y == pytest.approx(2.0)
    assert s.states(100.0)[0].y == pytest.approx(4.0)


def test_triggered_actor_waits_for_the_vehicle() -> None:
    s = ActorSet([walker(trigger_distance=10.0)])
    s.update(5.0, (0.0, 0.0))  # 20 m away: nothing happens
    assert s.states(8.0)[0].y == pytest.approx(-4.0)
    s.update(8.0, (12.0, 0.0))  # within 10 m: starts now
    assert s.states(10.0)[0].y == pytest.approx(-2.0)


def test_scanner_sees_a_parked_car_and_the_detector_finds_it() -> None:
    w = road_world()
    car = Actor(id="car", kind="car", yaw_deg=0.0, path=(Waypoint(x=12.0, y=0.5),))
    actors = ActorSet([car])
    scene = Scene(w, seed=1)
    scene.add_actors(actors)
    req = CaptureRequest(camera=False, truth=True)
    empty = capture(Scene(w, seed=1), (0.0, 0.0, 0.0), 0.0, req, vehicle="navlab")
    seen = capture(scene.at_time(actors, 0.0), (0.0, 0.0, 0.0), 0.0, req, vehicle="navlab")
    rock = KINDS.index("rock")
    assert (empty.laser_labels == rock).sum() == 0
    assert (seen.laser_labels == rock).sum() > 100
    obs = detect_obstacles(LaserScan.from_capture(seen))
    assert obs, "the car was not detected"
    near = obs[0]
    # the car's rear face is at 12 − 2.2 = 9.8 m ahead of the vehicle origin
    assert min(p[0] for p in near.polygon) == pytest.approx(9.8, abs=0.5)
    assert near.height == pytest.approx(1.5, abs=0.25)
    assert detect_obstacles(LaserScan.from_capture(empty)) == []


def test_the_camera_sees_an_actor_in_a_world_with_weather() -> None:
    # north_hills has wet patches and leaves: an actor's material must have a weather entry too
    from vehicle_sim.worldfile import load_world

    w = load_world("north_hills")
    assert w.weather is not None
    actors = ActorSet([Actor(id="car", kind="car", yaw_deg=90.0, path=(Waypoint(x=1.5, y=-30.0),))])
    scene = Scene(w, seed=1)
    scene.add_actors(actors)
    cap = capture(scene.at_time(actors, 0.0), (1.5, -40.0, math.pi / 2), 0.0, CaptureRequest(camera=True, truth=True), vehicle="navlab")
    assert (cap.camera_labels == KINDS.index("rock")).sum() > 100


def test_driving_into_a_parked_car_is_a_collision_and_clearance_is_tracked() -> None:
    w = road_world()
    car = Actor(id="car", kind="car", yaw_deg=0.0, path=(Waypoint(x=15.0, y=0.0),))
    sim = Simulator(w, SimConfig(vehicle="navlab"), start=(0.0, 0.0, 0.0), actors=ActorSet([car]))
    events = []
    for k in range(100):
        sim.submit(DriveCommand(speed=3.0, duration=1.0, seq=k + 1))
        events += sim.advance(0.1)
    hits = [e for e in events if e.kind == "collision"]
    assert len(hits) == 1 and hits[0].object_id == "car"
    assert sim.actor_clearance_min <= 0.0
    assert sim.state.x < 15.0 - 2.2  # blocked at the car's rear


def test_bad_actors_file_names_where_and_what(tmp_path) -> None:
    p = tmp_path / "a.yaml"
    p.write_text("actors:\n  - {id: x, kind: unicorn, path: [{x: 0, y: 0}]}\n")
    with pytest.raises(ActorError, match=r"a.yaml: actors\[0\]\.kind"):
        load_actors(p)
    with pytest.raises(ActorError, match="neither a file nor a preset"):
        load_actors("no-such-preset")
    assert len(load_actors("amv-delivery")) == 2
    with pytest.raises(ActorError, match="duplicate"):
        ActorSet([walker(), walker()])
    assert math.isfinite(ActorSet([walker()]).states(0.0)[0].x)
    assert np.isfinite(ActorSet([walker()]).footprints(0.0)[0][1]).all()


def test_actors_declared_in_the_world_file_are_loaded_and_a_bad_one_is_named(tmp_path) -> None:
    import json

    from vehicle_sim.worldfile import WorldFileError, load_world, parse_world

    doc = load_world("north_hills").to_geojson()
    assert "actors" not in doc
    doc["actors"] = [{"id": "bin", "kind": "bin", "path": [{"x": 3.6, "y": 10.0}]}]
    f = tmp_path / "nh.world.geojson"
    f.write_text(json.dumps(doc))
    w = load_world(f)
    (bin_,) = w.actor_set().actors
    assert bin_.kind == "bin" and bin_.path[0].y == 10.0
    assert w.to_geojson()["actors"] == doc["actors"]  # kept when the world is written back
    # the robot's map never carries them
    from vehicle_sim.mapgen import map_for

    assert map_for(w, 0.0, 0).actors == ()
    doc["actors"] = [{"id": "bin", "kind": "piano", "path": [{"x": 3.6, "y": 10.0}]}]
    with pytest.raises(WorldFileError, match=r"actors.*actors\[0\]\.kind"):
        parse_world(doc, source="nh.world.geojson")
    doc["actors"] = {"bin": 1}
    with pytest.raises(WorldFileError, match="actors: must be a list"):
        parse_world(doc, source="nh.world.geojson")
