"""Generated campuses: every seed loads and checks, has its route both ways up the terrace, keeps clear, reproduces byte for byte."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest
import shapely
import yaml

from modules.captain.missionfile import load_mission
from vehicle_sim.generated import GENERATORS, campus
from vehicle_sim.generated.campus import CAMPUS_CLEARANCE, PATH_KINDS
from vehicle_sim.generated.check import GeneratedWorldError, check_written, shortest_route
from vehicle_sim.worldfile import SlopeShape, StairsShape, load_world

CHUNK = 10


def _profile(world, edge_id: str, step: float = 0.1) -> np.ndarray:
    """Return the ground height [m] every `step` [m] along an edge of the world."""
    line = shapely.LineString(world.edge(edge_id).coords)
    pts = [line.interpolate(s) for s in np.arange(0.0, line.length + 1e-9, step)]
    return world.elevation(np.array([[p.x, p.y] for p in pts]))


def _shadow(tree, sun) -> shapely.Geometry:
    """Return the ground disc [m] a tree's crown shades: its middle projected away from the sun (azimuth: compass degrees)."""
    s = tree.shape
    reach = (s.crown_base + (s.height - s.crown_base) / 2) / math.tan(math.radians(sun.elevation_deg))
    az = math.radians(sun.azimuth_deg + 180.0)
    return shapely.Point(tree.center[0] + reach * math.sin(az), tree.center[1] + reach * math.cos(az)).buffer(s.crown_radius)


class _Without:
    """Map `m` seen without the edges `edge_ids` (what `shortest_route` reads: edges and objects)."""

    def __init__(self, m, *edge_ids: str) -> None:
        self.edges = tuple(e for e in m.edges if e.id not in edge_ids)
        self.object, self.has_object = m.object, m.has_object


_without = _Without


@pytest.mark.timeout(240)  # ~0.3 s CPU per seed; 16 s wall at load 16 on 2 cores per chunk of 10 seeds
@pytest.mark.parametrize("first", [pytest.param(f, marks=[pytest.mark.missions] if f >= 50 else [])  # 50-99: `make test-missions`
                                   for f in range(0, 100, CHUNK)])
def test_every_seed_loads_has_its_route_both_ways_and_keeps_clear(first, tmp_path):
    """Seeds 0-99: written, read back, checked; the route up the stairs, and up the slope avoiding stairs; the terrace joined both ways."""
    for seed in range(first, first + CHUNK):
        cw = campus.generate(seed)
        paths = campus.write(cw, tmp_path / str(seed))  # write() runs check_written on the files, both ways up
        assert [p.name.split(".", 1)[1] for p in paths] == ["world.geojson", "map.geojson", "yaml", "actors.yaml"]
        mission = load_mission(paths[2])
        assert mission.vehicle == "terregator" and mission.steps[-1].destination.place == "library"
        avoid = mission.steps[0].constraints.avoid_stairs
        assert avoid == cw.facts["avoid_stairs"], seed
        world, m = load_world(paths[0]), load_world(paths[1], kind="map")
        assert m.start is not None and m.start.node == "dorm" and all(o.appearance is None for o in m.objects)
        # the route both ways, and each the cheapest under its constraint
        assert tuple(shortest_route(m, "dorm", "library")) == cw.terrace.stairs_route, seed
        assert tuple(shortest_route(m, "dorm", "library", avoid_stairs=True)) == cw.terrace.slope_route, seed
        assert cw.route == (cw.terrace.slope_route if avoid else cw.terrace.stairs_route)
        assert "e_stairs" in {e.id for e in m.edges} and "e_slope" in {e.id for e in m.edges}
        # the stairs and the slope join the terrace to the walks below, each on its own
        assert shortest_route(_without(m, "e_stairs", "e_slope"), "dorm", "library") is None, seed
        assert shortest_route(_without(m, "e_slope"), "dorm", "library") is not None, seed
        assert shortest_route(_without(m, "e_stairs"), "dorm", "library") is not None, seed
        h = cw.terrace.height_m
        stairs, ramp = world.object("stairs_main"), world.object("slope_ramp")
        assert isinstance(stairs.shape, StairsShape) and isinstance(ramp.shape, SlopeShape)
        assert stairs.kind == "stairs" and ramp.kind == "slope" and stairs.colour == ramp.colour, seed  # the same grey concrete
        assert stairs.shape.n_steps == cw.terrace.steps and ramp.footprint.distance(stairs.footprint) < 1.5, seed  # beside them
        up = _profile(world, "e_slope")
        assert abs(up[0]) < 1e-9 and abs(up[-1] - h) < 1e-9 and np.max(np.abs(np.diff(up))) < 0.02, seed  # no step on the way up
        climb = _profile(world, "e_stairs")
        assert abs(climb[0]) < 1e-9 and abs(climb[-1] - h) < 1e-9 and np.max(np.diff(climb)) == pytest.approx(0.15), seed
        assert world.elevation(np.array([world.place("library").xy]))[0] == pytest.approx(h)  # the destination is on the terrace
        # what the walks are made of
        js = [j for j in cw.network.junctions if j.id not in ("foot", "x_terrace")]
        assert 3 <= len(js) <= 4 and any(j.kind == "Y" for j in js), seed
        assert {"left", "right"} <= {j.turn for j in js if j.kind != "Y"}, seed
        assert all(55.0 <= j.angle_deg <= 125.0 for j in js if j.kind != "Y"), seed
        assert all(50.0 <= j.angle_deg <= 90.0 for j in js if j.kind == "Y"), seed
        paths_area = shapely.union_all([o.footprint for o in world.objects if o.kind in PATH_KINDS])
        standing = [o for o in world.objects if o.kind in CAMPUS_CLEARANCE]
        assert {"tree", "lamp_post", "sign", "building"} <= {o.kind for o in standing}, seed
        for o in standing:
            assert o.footprint.distance(paths_area) >= CAMPUS_CLEARANCE[o.kind], (seed, o.id)
        trees = [o for o in standing if o.kind == "tree"]
        assert sum(o.footprint.distance(paths_area) < CAMPUS_CLEARANCE["tree"] + 0.05 for o in trees) >= 3, seed  # at the least clearance
        assert any(_shadow(o, world.sun).intersects(paths_area) for o in trees), seed  # crowns' shadows fall across the walks


@pytest.mark.timeout(120)  # ~6 s CPU
def test_seeds_vary_the_terrace_the_way_up_and_the_crossings():
    """Over 20 seeds: both ways up, the slope on either side, several heights, Ys and crossings near both ends of 55-125°, another sun each."""
    worlds = [campus.generate(seed) for seed in range(20)]
    assert {w.facts["avoid_stairs"] for w in worlds} == {True, False}
    assert {w.facts["terrace"]["slope_side"] for w in worlds} == {"left", "right"}
    assert len({w.terrace.steps for w in worlds}) >= 2
    angles = [j.angle_deg for w in worlds for j in w.network.junctions if j.kind != "Y" and j.id != "foot"]
    assert min(angles) < 65.0 and max(angles) > 115.0
    assert len({(w.world.sun.azimuth_deg, w.world.weather.wet_cover) for w in worlds}) == 20
    assert sum(w.facts["benches"] for w in worlds) >= 20 and sum(w.facts["hedges"] for w in worlds) >= 10


@pytest.mark.timeout(60)  # ~1 s CPU
def test_same_seed_writes_identical_files_and_another_seed_does_not(tmp_path):
    a = GENERATORS["campus"](7, tmp_path / "a", None)
    b = GENERATORS["campus"](7, tmp_path / "b", None)
    c = GENERATORS["campus"](8, tmp_path / "c", None)
    for pa, pb, pc in zip(a, b, c):
        assert pa.name == pb.name and pa.read_bytes() == pb.read_bytes(), pa.name
        assert pa.read_bytes() != pc.read_bytes(), pa.name


@pytest.mark.timeout(60)
def test_checker_refuses_a_lamp_post_inside_its_clearance_naming_it(tmp_path):
    paths = campus.write(campus.generate(4), tmp_path)
    world = load_world(paths[0])
    lamp = next(o for o in world.objects if o.kind == "lamp_post" and o.shape.z0 == 0.0)
    walk = world.object("walk_dorm_x1")
    p = walk.footprint.exterior.interpolate(0.3, normalized=True)
    q = walk.footprint.representative_point()
    d = np.array([p.x - q.x, p.y - q.y])
    off = np.array([p.x, p.y]) + d / np.linalg.norm(d) * 0.3  # 0.3 m outside the walk's edge: less than a lamp post's 0.6 m
    doc = json.loads(paths[0].read_text())
    feature = next(f for f in doc["features"] if f["properties"]["id"] == lamp.id)
    feature["geometry"]["coordinates"] = [round(float(off[0]), 3), round(float(off[1]), 3)]
    paths[0].write_text(json.dumps(doc))
    with pytest.raises(GeneratedWorldError, match=rf"lamp_post '{lamp.id}' is 0\.\d\d m from a sidewalk, intersection, slope or stairs "
                                                  r"area, less than the 0.6 m it needs"):
        check_written(*paths, path_kinds=PATH_KINDS, clearance=CAMPUS_CLEARANCE)


@pytest.mark.timeout(60)
def test_checker_refuses_a_map_without_its_slope_when_the_mission_avoids_stairs(tmp_path):
    paths = campus.write(campus.generate(4), tmp_path)
    doc = yaml.safe_load(paths[2].read_text())
    doc["steps"][0]["constraints"] = ["keep_right", "avoid_stairs"]
    paths[2].write_text(yaml.safe_dump(doc))
    check_written(*paths, path_kinds=PATH_KINDS, clearance=CAMPUS_CLEARANCE)
    m = json.loads(paths[1].read_text())
    m["features"] = [f for f in m["features"] if f["properties"]["id"] != "e_slope"]
    paths[1].write_text(json.dumps(m))
    with pytest.raises(GeneratedWorldError, match="no way on the path graph from 'dorm' to 'library' avoiding stairs"):
        check_written(*paths, path_kinds=PATH_KINDS, clearance=CAMPUS_CLEARANCE)
    with pytest.raises(GeneratedWorldError, match="the cheapest way from 'dorm' to 'library' avoiding stairs is none"):
        check_written(*paths, path_kinds=PATH_KINDS, clearance=CAMPUS_CLEARANCE, ways=((campus.generate(4).terrace.slope_route, True),))


@pytest.mark.timeout(120)  # ~5 s (one process)
def test_worldgen_command_writes_a_campus_and_compare_takes_the_kind(tmp_path):
    from sidewalk.compare.layouts import parse_generated

    assert parse_generated("campus:3,suburb:2") == [("campus", 3), ("suburb", 2)]
    r = subprocess.run([sys.executable, "-m", "sidewalk", "worldgen", "campus", "--seed", "3", "--out", str(tmp_path)],
                       capture_output=True, text=True, timeout=100)
    assert r.returncode == 0, r.stderr
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["campus_3.actors.yaml", "campus_3.map.geojson", "campus_3.world.geojson", "campus_3.yaml"]
    assert "`sidewalk worldgen campus --seed 3`" in (tmp_path / "campus_3.yaml").read_text()
    assert math.isclose(load_world(tmp_path / "campus_3.world.geojson").start.x, 0.0)
