"""The realised map error, measured against the world by feature id."""

import numpy as np
import pytest

from sidewalk.map_error import measure_map_error
from vehicle_sim.mapgen import map_with_error
from vehicle_sim.worldfile import World, WorldObject, load_world


def _moved(o: WorldObject, d: tuple[float, float] | None = None, per_vertex: list | None = None) -> WorldObject:
    corners = np.asarray(o.polygon if o.polygon is not None else (o.center,), dtype=float)
    v = corners + (np.asarray(per_vertex) if per_vertex is not None else np.asarray(d))
    geo = {"polygon": tuple(map(tuple, v))} if o.polygon is not None else {"center": tuple(v[0])}
    return WorldObject(**{**{f: getattr(o, f) for f in WorldObject.model_fields}, **geo})


def test_a_hand_made_map_error():
    campus = load_world("campus")
    walk = next(o for o in campus.objects if o.role == "path" and len(o.vertices) == 4)
    post = next(o for o in campus.objects if o.role == "landmark" and o.polygon is None)
    house = next(o for o in campus.objects if o.role == "landmark" and o.polygon is not None)
    tree = next(o for o in campus.objects if o.role == "obstacle")
    world = World(name="hand", objects=(walk, post, house, tree))
    # the walk: two corners 0.5 m off (0.3, 0.4), two exact; the post 1 m off; the house and the tree left out
    mp = World(name="hand", objects=(_moved(walk, per_vertex=[(0.3, 0.4), (0.3, 0.4), (0, 0), (0, 0)]), _moved(post, (0.0, -1.0))))
    e = measure_map_error(world, mp, requested_m=1.0)
    assert (e.path_mean_m, e.path_max_m) == (0.25, 0.5)
    assert (e.landmark_mean_m, e.landmark_max_m) == (1.0, 1.0)
    assert (e.missing, e.requested_m) == (2, 1.0)


def test_the_shipped_map_is_not_reported_perfect():
    e = measure_map_error(load_world("campus"), load_world("campus", kind="map"))
    assert e.path_max_m > 0.1 and e.landmark_max_m > 0.1 and e.missing >= 1 and e.requested_m is None


def test_a_derived_map_measures_within_what_was_asked():
    hills = load_world("north_hills")
    e = measure_map_error(hills, map_with_error(hills, 0.5, np.random.default_rng(3)), requested_m=0.5)
    assert 0.0 < e.path_mean_m < e.path_max_m <= 0.5 + 1e-3
    assert 0.0 < e.landmark_mean_m < e.landmark_max_m <= 0.5 + 1e-3
    assert max(e.path_max_m, e.landmark_max_m) == pytest.approx(0.5, abs=0.1)
