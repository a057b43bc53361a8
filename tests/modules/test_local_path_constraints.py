"""DRIVING UNIT NAVIGATOR core: margin, keep-right within the body's room, obstacle clearance, failures."""

from __future__ import annotations

import pytest
import shapely
from shapely.geometry import LineString, Point

from modules.pilot.local_path_constraints import ConstraintError, NavigatorConfig, local_constraints
from modules.pilot.polyline import PathLine

PATH = PathLine.from_points([(0, 0), (30, 0)])


def _walk(width):
    return LineString(PATH.xy).buffer(width / 2, cap_style="flat")


def test_keep_right_on_a_wide_walk_uses_the_offset():
    cfg = NavigatorConfig(margin=0.5, keep_offset=0.6, body_half_width=1.0)
    c = local_constraints(PATH, [_walk(4.0), _walk(4.0)], [10.0, 20.0], [False, False], keep="right", cfg=cfg)
    assert c.goals[:, 1] == pytest.approx([-0.6, -0.6])
    assert c.region.bounds[1] == pytest.approx(-1.5) and c.region.bounds[3] == pytest.approx(1.5)


def test_keep_right_shrinks_so_the_body_stays_on_a_narrow_walk():
    cfg = NavigatorConfig(margin=0.5, keep_offset=0.6, body_half_width=1.0)
    c = local_constraints(PATH, [_walk(2.4)], [10.0], [False], keep="right", cfg=cfg)
    assert -0.2 - 1e-9 <= c.goals[0, 1] <= 0.0  # body edge at most at the walk's edge
    c = local_constraints(PATH, [_walk(2.0)], [10.0], [False], keep="right", cfg=cfg, lateral_offset=-0.5)
    assert c.goals[0, 1] == pytest.approx(0.0)  # no room for the body off-centre: stay on the centreline


def test_standing_objects_are_cut_out_with_clearance():
    cfg = NavigatorConfig(margin=0.3, obstacle_clearance=1.0)
    post = Point(15.0, 1.8).buffer(0.15)
    c = local_constraints(PATH, [_walk(6.0)], [25.0], [False], cfg=cfg, obstacles=(post,))
    assert not shapely.contains_xy(c.region, 15.0, 1.0)
    assert shapely.contains_xy(c.region, 15.0, -1.0)
    assert c.region.distance(post) >= 1.0 - 0.01  # buffers are polygons: 1 cm of chord error


def test_region_too_narrow_is_a_constraint_error():
    with pytest.raises(ConstraintError, match="narrower"):
        local_constraints(PATH, [_walk(0.8)], [10.0], [False], cfg=NavigatorConfig(margin=0.5))
    with pytest.raises(ConstraintError, match="one region"):
        local_constraints(PATH, [_walk(3.0)], [10.0, 20.0], [False], cfg=NavigatorConfig())


def test_position_uncertainty_widens_obstacle_clearance():
    cfg = NavigatorConfig(margin=0.3, obstacle_clearance=1.0, uncertainty_gain=1.0, uncertainty_cap=1.0)
    post = Point(15.0, 2.5).buffer(0.15)
    sure = local_constraints(PATH, [_walk(6.0)], [25.0], [False], cfg=cfg, obstacles=(post,), sigma=0.0)
    unsure = local_constraints(PATH, [_walk(6.0)], [25.0], [False], cfg=cfg, obstacles=(post,), sigma=0.6)
    assert shapely.contains_xy(sure.region, 15.0, 0.8) and not shapely.contains_xy(unsure.region, 15.0, 0.8)
    capped = local_constraints(PATH, [_walk(6.0)], [25.0], [False], cfg=cfg, obstacles=(post,), sigma=50.0)
    assert capped.region.distance(post) == pytest.approx(2.0, abs=0.02)
