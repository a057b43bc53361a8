"""`--map-error M`: a map wrong the way real maps are (offset, rotation, scattered vertices, missing
objects) whose largest vertex displacement from the truth is exactly M."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from vehicle_sim.mapgen import MISSING_PER_M, REMOVABLE_ROLES, map_with_error
from vehicle_sim.worldfile import EDGE_END_TOLERANCE, World, load_world, parse_world


@pytest.fixture(scope="module")
def campus() -> World:
    return load_world("campus")


def _pairs(world: World, m: World) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Every vertex the map kept, with its true position, by feature: id → (true (N,2), map (N,2))."""
    out = {o.id: (_corners(o), _corners(m.object(o.id))) for o in world.objects if m.has_object(o.id)}
    out.update({n.id: (n.xy[None, :], m.node(n.id).xy[None, :]) for n in world.nodes})
    out.update({e.id: (e.points, m.edge(e.id).points) for e in world.edges})
    out["start"] = (np.array([[world.start.x, world.start.y]]), np.array([[m.start.x, m.start.y]]))
    return out


def _corners(o) -> np.ndarray:
    return np.asarray(o.polygon if o.polygon is not None else (o.center,), dtype=float)


def _largest(world: World, m: World) -> float:
    return max(float(np.max(np.hypot(*(b - a).T))) for a, b in _pairs(world, m).values())


def _rigid_fit(a: np.ndarray, b: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Best rotation [rad] and translation taking a (N,2) onto b (N,2) (Kabsch); the residuals (N,)."""
    ca, cb = a.mean(axis=0), b.mean(axis=0)
    u, _, vt = np.linalg.svd((a - ca).T @ (b - cb))
    r = (u @ vt).T
    th = math.atan2(r[1, 0], r[0, 0])
    t = cb - ca @ r.T
    return th, t, np.hypot(*(a @ r.T + t - b).T)


@pytest.mark.parametrize("m", [0.2, 0.5, 2.0])
def test_the_largest_vertex_displacement_is_what_was_asked(campus, m):
    mp = map_with_error(campus, m, np.random.default_rng(4))
    assert _largest(campus, mp) == pytest.approx(m, abs=2e-4)


def test_the_error_has_every_part_a_real_map_has(campus):
    mp = map_with_error(campus, 2.0, np.random.default_rng(4))
    path = [o for o in campus.objects if o.role == "path"]
    a = np.vstack([_corners(o) for o in path])
    b = np.vstack([_corners(mp.object(o.id)) for o in path])
    th, t, resid = _rigid_fit(a, b)
    # a rigid part: the path objects as a whole are shifted and turned ...
    assert np.hypot(*t) > 0.1 and abs(th) > math.radians(0.01)
    # ... and their vertices scattered besides (a rigid map would fit to zero)
    assert resid.max() > 0.2
    marks = [o for o in campus.objects if o.role == "landmark" and mp.has_object(o.id)]
    _, _, lresid = _rigid_fit(np.vstack([_corners(o) for o in marks]), np.vstack([_corners(mp.object(o.id)) for o in marks]))
    assert lresid.max() > 0.2
    # missing objects: landmarks and obstacles only, never a path object
    gone = [o for o in campus.objects if not mp.has_object(o.id)]
    assert gone and all(o.role in REMOVABLE_ROLES for o in gone)


def test_the_map_stays_a_valid_map(campus):
    mp = map_with_error(campus, 2.0, np.random.default_rng(4))
    again = parse_world(json.dumps(mp.to_geojson()))  # validates polygons, edge ends, references
    assert len(again.objects) == len(mp.objects)
    for e in mp.edges:
        for nid, end in ((e.from_node, e.coords[0]), (e.to_node, e.coords[-1])):
            assert math.dist(end, mp.node(nid).xy) <= EDGE_END_TOLERANCE
    # areas that touch in the world still touch: a shared corner moves once
    shared = 0
    seen: dict[tuple[int, int], np.ndarray] = {}
    for o in campus.objects:
        if o.polygon is None or not mp.has_object(o.id):
            continue
        for v, w in zip(o.vertices, mp.object(o.id).vertices):
            key = (round(v[0] * 100), round(v[1] * 100))
            if key in seen:
                shared += 1
                assert np.allclose(seen[key], w, atol=2e-4)
            seen[key] = w
    assert shared > 10
    # the thin walls (0.3 m) keep their outline: no vertex crosses to the other side
    for wall in ("wall_e", "wall_w"):
        assert mp.object(wall).footprint.is_valid and mp.object(wall).footprint.area > 0.5 * campus.object(wall).footprint.area


def test_no_error_is_the_world_as_a_map_states_it_and_more_error_leaves_out_more(campus):
    exact = map_with_error(campus, 0.0, np.random.default_rng(4))
    mapped = [o.as_mapped().to_feature() for o in campus.objects] + [f for f in campus.to_geojson()["features"]
                                                                     if f["properties"]["kind"] in ("node", "edge")]
    assert exact.to_geojson()["features"] == mapped  # no appearance, no markings: what a map never states
    assert exact.weather is None and campus.weather is not None
    removable = sum(1 for o in campus.objects if o.role in REMOVABLE_ROLES)
    kept = [{o.id for o in map_with_error(campus, m, np.random.default_rng(4)).objects} for m in (0.5, 1.0, 2.0)]
    assert kept[0] >= kept[1] >= kept[2]  # the same draw: what is missing at 0.5 m is missing at 2 m
    missing_2m = len(campus.objects) - len(kept[2])
    p = MISSING_PER_M * 2.0
    assert abs(missing_2m - p * removable) <= 3 * math.sqrt(p * (1 - p) * removable)


def test_reproducible_from_the_generator_and_bad_sizes_refused(campus):
    a = map_with_error(campus, 0.5, np.random.default_rng(9)).to_geojson()
    assert a == map_with_error(campus, 0.5, np.random.default_rng(9)).to_geojson()
    assert a != map_with_error(campus, 0.5, np.random.default_rng(10)).to_geojson()
    for bad in (-0.1, math.inf, math.nan):
        with pytest.raises(ValueError, match="map error must be a finite distance"):
            map_with_error(campus, bad, np.random.default_rng(0))
