"""The shipped worlds and maps: what they contain, how the ground queries answer, how maps are derived."""

from __future__ import annotations

import heapq
import json
import math

import numpy as np
import pytest

from vehicle_sim.mapgen import DEFAULT_MAP_ERROR, NO_MAP_ERROR, MapError, derive_map, map_for
from vehicle_sim.worldfile import KINDS, SlopeShape, StairsShape, World, load_world, parse_world, world_path
from vehicle_sim.worldgen import ROADSIDE_CLEARANCE, build_campus, build_north_hills


@pytest.fixture(scope="module")
def campus() -> World:
    return load_world("campus")


@pytest.fixture(scope="module")
def hills() -> World:
    return load_world("north_hills")


def shortest(world: World, src: str, dst: str, avoid_modes: tuple[str, ...] = ()) -> tuple[float, list[str]]:
    """Dijkstra over the path graph; edge cost = length × mean cost of its path objects."""
    best = {src: 0.0}
    prev: dict[str, tuple[str, str]] = {}
    heap = [(0.0, src)]
    while heap:
        d, n = heapq.heappop(heap)
        if n == dst:
            break
        if d > best.get(n, math.inf):
            continue
        for e in world.edges_at(n):
            if e.mode in avoid_modes:
                continue
            costs = [world.object(o).cost for o in e.path_objects] or [1.0]
            nd = d + e.length * float(np.mean(costs))
            m = e.other(n)
            if nd < best.get(m, math.inf):
                best[m] = nd
                prev[m] = (n, e.id)
                heapq.heappush(heap, (nd, m))
    path = []
    n = dst
    while n != src:
        n, eid = prev[n]
        path.append(eid)
    return best[dst], path[::-1]


def test_shipped_files_are_what_the_generator_writes(tmp_path):
    from vehicle_sim.worldgen import write_worlds

    for p in write_worlds(tmp_path):
        assert p.read_bytes() == world_path(p.name.split(".")[0], kind=p.name.split(".")[1]).read_bytes(), p.name


def test_campus_network(campus):
    assert len(campus.intersections) >= 6
    for e in campus.edges:
        for oid in e.path_objects:
            o = campus.object(oid)
            assert o.role == "path" and math.isfinite(o.cost)
    walk_widths = {e.width for e in campus.edges if e.mode == "follow-road"}
    assert min(walk_widths) >= 2.0 and max(walk_widths) <= 3.0
    for name in ("library", "gym", "quad", "stairs_top", "dorm"):
        assert campus.place(name).node_kind == "place"
    kinds = {o.kind for o in campus.objects}
    assert {"sidewalk", "intersection", "grass", "stairs", "slope", "tree", "building"} <= kinds
    assert campus.start is not None and campus.start.node == "dorm"


def test_campus_stairs_beside_slope_same_grey(campus):
    stairs = campus.object("stairs_main")
    slope = campus.object("slope_ramp")
    assert stairs.colour == slope.colour
    assert stairs.footprint.distance(slope.footprint) < 1.5
    assert isinstance(stairs.shape, StairsShape) and isinstance(slope.shape, SlopeShape)
    # both climb to the same plaza height
    top = campus.elevation(np.array([[60.0, 74.0]]))[0]
    assert stairs.shape.z0 + stairs.shape.rise == pytest.approx(top)
    assert slope.shape.z0 + slope.shape.rise == pytest.approx(top)
    # the lawn beside the ramp lies in the ramp's plane (range alone cannot tell them apart)
    zs = campus.elevation(np.array([[66.0, 67.0], [74.0, 67.0]]))
    assert zs[0] == pytest.approx(zs[1], abs=1e-9)
    lab = campus.label_at(np.array([[66.0, 67.0], [74.0, 67.0], [60.0, 69.0]]))
    assert [KINDS[i] for i in lab] == ["slope", "grass", "stairs"]


def test_campus_stairs_shortest_slope_longer(campus):
    via_stairs, path = shortest(campus, "dorm", "library")
    assert "e_stairs" in path and "e_slope" not in path
    avoiding, path2 = shortest(campus, "dorm", "library", avoid_modes=("climb-stairs",))
    assert "e_slope" in path2
    assert avoiding > via_stairs


def test_campus_trees_shade_sidewalks(campus):
    """Some tree crowns cast their shadow onto a sidewalk under the world's sun."""
    import shapely

    walks = shapely.union_all([o.footprint for o in campus.objects_of_kind("sidewalk", "intersection")])
    sun = campus.sun.direction()
    trees = campus.objects_of_kind("tree")
    assert len(trees) >= 20
    near = [t for t in trees if walks.distance(shapely.Point(t.center)) < 7.0]
    assert len(near) >= 15
    shading = 0
    for t in near:
        h = t.shape.crown_base + (t.shape.height - t.shape.crown_base) / 2  # crown centre height
        off = -sun[:2] / sun[2] * h
        shadow = shapely.Point(t.center[0] + off[0], t.center[1] + off[1]).buffer(t.shape.crown_radius)
        if shadow.intersects(walks):
            shading += 1
    assert shading >= 10


def test_north_hills_route(hills):
    assert len(hills.intersections) == 4
    road = sum(e.length for e in hills.edges if e.mode == "follow-road")
    assert road >= 650.0
    kinds = [o.kind for o in hills.objects]
    assert kinds.count("driveway") >= 10 and kinds.count("mailbox") >= 10 and kinds.count("building") >= 10 and kinds.count("tree") >= 10
    assert "sidewalk" not in kinds  # suburban streets: no sidewalks, no markings
    length, path = shortest(hills, "start", "mailbox")
    assert length >= 600.0  # the 0.4-mile run
    # walk the route: the nodes passed and the turn at each
    node = "start"
    nodes = [node]
    for eid in path:
        node = hills.edge(eid).other(node)
        nodes.append(node)
    crossed = [n for n in nodes if hills.node(n).node_kind == "intersection"]
    assert len(crossed) == 4
    turns = []
    for a, b, c in zip(nodes, nodes[1:], nodes[2:]):
        if hills.node(b).node_kind != "intersection":
            continue
        ea = hills.edge(path[nodes.index(b) - 1]).points
        ec = hills.edge(path[nodes.index(b)]).points
        if hills.edge(path[nodes.index(b) - 1]).to_node != b:
            ea = ea[::-1]
        if hills.edge(path[nodes.index(b)]).from_node != b:
            ec = ec[::-1]
        h_in = math.atan2(*(ea[-1] - ea[-2])[::-1])
        h_out = math.atan2(*(ec[1] - ec[0])[::-1])
        turns.append(math.degrees((h_out - h_in + math.pi) % (2 * math.pi) - math.pi))
    lefts = [t for t in turns if 80.0 <= t <= 100.0]
    straight = [t for t in turns if abs(t) < 15.0]
    assert len(lefts) == 2 and len(straight) == 2, turns
    mb = hills.object("mailbox_dest")
    dest = hills.place("mailbox")
    assert math.dist(mb.center, (dest.x, dest.y)) < 6.0


def test_ground_queries(campus):
    # stairs: 7 treads of 0.15 m rising north from y=66 to y=72
    ys = np.array([65.9, 66.1, 66.95, 71.9])
    z = campus.elevation(np.column_stack([np.full(4, 60.0), ys]))
    assert z == pytest.approx([0.0, 0.15, 0.3, 1.05])
    # slope: linear from y=61.5 to 72
    z = campus.elevation(np.array([[66.0, 61.5 + 10.5 * f] for f in (0.1, 0.5, 0.9)]))
    assert z == pytest.approx([0.105, 0.525, 0.945], abs=0.01)
    lab = campus.label_at(np.array([[30.0, 30.0], [0.0, 0.0], [30.0, 0.0], [100.0, 30.0], [1000.0, 1000.0]]))
    assert [KINDS[i] for i in lab] == ["building", "intersection", "sidewalk", "grass", "none"]
    assert campus.elevation(np.array([[1000.0, 1000.0]]))[0] == 0.0


def test_label_at_agrees_with_footprints(campus):
    """Away from edges (> one raster cell), the raster label is the top object's kind."""
    import shapely

    rng = np.random.default_rng(3)
    xmin, ymin, xmax, ymax = campus.bounds()
    pts = rng.uniform((xmin, ymin), (xmax, ymax), size=(3000, 2))
    idx = campus.object_index_at(pts)
    checked = 0
    for p, i in zip(pts, idx):
        if i < 0:
            continue
        o = campus.objects[i]
        fp = o.footprint
        if fp.exterior.distance(shapely.Point(p)) < 0.2:
            continue
        assert fp.contains(shapely.Point(p)), (o.id, p)
        checked += 1
    assert checked > 2500


def test_world_round_trips(campus):
    again = parse_world(json.dumps(campus.to_geojson()), source="roundtrip")
    assert again.to_geojson() == campus.to_geojson()


def test_build_is_deterministic():
    assert build_campus().to_geojson() == build_campus().to_geojson()
    assert build_north_hills().to_geojson() == build_north_hills().to_geojson()


def test_shipped_worlds_are_what_the_generator_builds(tmp_path):
    for name, build in (("campus", build_campus), ("north_hills", build_north_hills)):
        written = build().save(tmp_path / f"{name}.world.geojson")
        assert written.read_bytes() == world_path(name).read_bytes(), f"worlds/{name}.world.geojson: run python -m vehicle_sim.worldgen"


def test_nothing_stands_in_a_north_hills_road(hills):
    import shapely

    roads = shapely.union_all([o.footprint for o in hills.objects if o.kind in ("road", "intersection")])
    standing = [o for o in hills.objects if o.kind in ROADSIDE_CLEARANCE]
    assert len(standing) > 50
    for o in standing:
        assert o.footprint.distance(roads) >= ROADSIDE_CLEARANCE[o.kind] - 1e-6, o.id
    # each driveway meets exactly one road, from the side its house is on
    for d in hills.objects_of_kind("driveway"):
        touching = [r.id for r in hills.objects if r.kind in ("road", "intersection") and r.footprint.intersects(d.footprint)]
        assert len(touching) == 1, (d.id, touching)


def test_keep_clear_drops_trees_and_refuses_other_objects():
    from vehicle_sim.worldgen import _Builder, ASPHALT, MAILBOX
    from vehicle_sim.worldfile import PostShape

    b = _Builder("t")
    b.rect("road_a", "road", 0.0, -3.0, 50.0, 3.0, role="path", colour=ASPHALT, cost=1.0)
    b.tree("tree_in", 10.0, 1.0, np.random.default_rng(0))
    b.tree("tree_out", 10.0, 9.0, np.random.default_rng(0))
    b.keep_clear(("road",), ROADSIDE_CLEARANCE)
    assert [o.id for o in b.objects] == ["road_a", "tree_out"]
    b.round_obj("mailbox_in", "mailbox", 20.0, 3.2, 0.25, role="landmark", colour=MAILBOX, shape=PostShape(height=1.1))
    with pytest.raises(ValueError, match="mailbox mailbox_in is 0.00 m from a road area"):
        b.keep_clear(("road",), ROADSIDE_CLEARANCE)


def test_shipped_map_is_derived_with_default_error(campus):
    shipped = load_world("campus", kind="map")
    assert shipped.to_geojson() == map_for(campus, 1.0, 0).to_geojson()
    exact = derive_map(campus, NO_MAP_ERROR, np.random.default_rng(0))
    # with no error the map is the world as a map states it: the same geometry, colour types, no appearance
    told = [o.as_mapped().to_feature() for o in campus.objects] + [f.to_feature() for f in (*campus.nodes, *campus.edges)]
    assert exact.to_geojson()["features"] == told


@pytest.mark.parametrize("name", ["campus", "north_hills"])
def test_maps_state_colour_types_and_worlds_keep_the_appearance(name):
    """A map says what the paper's map said (GRAY, GREEN, a nominal colour); how surfaces look stays in the world."""
    world, shipped = load_world(name), load_world(name, kind="map")
    assert all(o.appearance is None for o in shipped.objects) and shipped.weather is None
    assert "appearance" not in world_path(name, kind="map").read_text() and "weather" not in world_path(name, kind="map").read_text()
    assert all(o.appearance is not None for o in world.objects) and world.weather is not None
    assert world.weather.wet_cover > 0 and world.weather.leaf_cover > 0
    walks = [o for o in world.objects if o.kind in ("sidewalk", "road")]
    # one material, one map colour; each object weathered on its own, none exactly the catalogue colour
    assert len({o.colour for o in walks}) == 1
    assert len({o.appearance.mean for o in walks}) == len(walks)
    nominal = np.array(walks[0].colour.nominal)
    gaps = [float(np.abs(np.array(o.appearance.mean) - nominal).max()) for o in walks]
    assert min(gaps) > 1.0 and max(gaps) > 15.0


def test_derive_map_error_model(campus):
    err = MapError(offset_x=2.0, offset_y=-1.0, rotation_deg=0.0, displace_std=0.0, missing_fraction=0.0)
    m = derive_map(campus, err, np.random.default_rng(1))
    for a, b in zip(campus.nodes, m.nodes):
        assert (b.x - a.x, b.y - a.y) == pytest.approx((2.0, -1.0))
    # rotation about the start: the start stays, far things move by ~ r·θ
    m = derive_map(campus, MapError(rotation_deg=1.0), np.random.default_rng(1))
    assert (m.start.x, m.start.y) == pytest.approx((campus.start.x, campus.start.y))
    lib_w, lib_m = campus.place("library"), m.place("library")
    r = math.dist((lib_w.x, lib_w.y), (campus.start.x, campus.start.y))
    assert math.dist((lib_w.x, lib_w.y), (lib_m.x, lib_m.y)) == pytest.approx(r * math.radians(1.0), rel=1e-3)
    # missing objects: only landmarks/obstacles, about the configured fraction
    m = derive_map(campus, MapError(missing_fraction=0.3), np.random.default_rng(5))
    kept = {o.id for o in m.objects}
    removable = [o for o in campus.objects if o.role in ("landmark", "obstacle")]
    gone = [o for o in removable if o.id not in kept]
    assert all(o.id in kept for o in campus.objects if o.role == "path")
    frac = len(gone) / len(removable)
    assert abs(frac - 0.3) < 3 * math.sqrt(0.3 * 0.7 / len(removable))
    # same rng seed, same map
    a = derive_map(campus, DEFAULT_MAP_ERROR, np.random.default_rng(9)).to_geojson()
    b = derive_map(campus, DEFAULT_MAP_ERROR, np.random.default_rng(9)).to_geojson()
    assert a == b


def test_scalar_elevation_matches_vectorised(campus):
    rng = np.random.default_rng(0)
    xy = np.vstack([rng.uniform((-45, -50), (240, 135), (3000, 2)), rng.uniform((55, 60), (85, 80), (2000, 2))])
    z = campus.elevation(xy)
    assert [campus.elevation_at(float(x), float(y)) for x, y in xy] == pytest.approx(list(z), abs=1e-12)
    assert z.max() == pytest.approx(1.05)


def test_map_objects_have_their_own_geometry(campus):
    campus.object("slope_ramp").vertices  # noqa: B018 - fill the truth's cached geometry first
    campus.object("slope_ramp").axis_extent()
    m = derive_map(campus, MapError(offset_x=5.0, rotation_deg=10.0), np.random.default_rng(0))
    a, b = campus.object("slope_ramp"), m.object("slope_ramp")
    assert not np.allclose(a.vertices, b.vertices)
    assert b.footprint.centroid.x == pytest.approx(np.mean(b.vertices[:, 0]), abs=0.5)
    # the map's ramp still rises along its own (rotated) axis: bottom edge low, top edge high
    lo = b.ground_z_at(*b.vertices[:2].mean(axis=0))
    hi = b.ground_z_at(*b.vertices[2:].mean(axis=0))
    assert lo == pytest.approx(0.0, abs=1e-6) and hi == pytest.approx(1.05, abs=1e-6)
