"""DRIVING MONITOR core: a segment cut into driving units PERCEPTION can see at once, with where and what."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import LineString, Point

from modules.pilot.driving_units import DrivingUnitConfig, ExpectedObject, split_segment
from modules.pilot.polyline import PathLine, PolylineError


def test_units_cover_the_path_in_pieces_perception_can_see():
    path = PathLine.from_points([(0, 0), (20, 0), (20, 15)])
    region = LineString(path.xy).buffer(2.0)
    mailbox = ExpectedObject("mailbox-1", Point(21, 10).buffer(0.3))
    far_tree = ExpectedObject("tree-9", Point(100, 100).buffer(1.0))
    units = split_segment(path, region, (mailbox, far_tree), DrivingUnitConfig(unit_length=6.0, min_length=2.0))
    assert units[0].s_start == 0.0 and units[-1].s_end == pytest.approx(35.0)
    for a, b in zip(units[:-1], units[1:]):
        assert a.s_end == pytest.approx(b.s_start)
    assert all(2.0 <= u.length <= 8.0 for u in units)
    assert [u.last for u in units] == [False] * (len(units) - 1) + [True]
    assert all(u.region.within(region.buffer(1e-6)) for u in units)
    assert any("mailbox-1" in u.object_ids for u in units)
    assert not any("tree-9" in u.object_ids for u in units)
    # The view pose is on the path before the unit's near edge, heading along it.
    u2 = units[2]
    assert u2.view_pose[0] == pytest.approx(u2.s_start - 4.0) and u2.view_pose[2] == pytest.approx(0.0)
    last = units[-1]
    assert last.far_pose[:2] == pytest.approx((20.0, 15.0)) and last.far_pose[2] == pytest.approx(math.pi / 2)


def test_short_segment_is_one_unit_and_short_tail_is_merged():
    path = PathLine.from_points([(0, 0), (3, 0)])
    units = split_segment(path, LineString(path.xy).buffer(1.5))
    assert len(units) == 1 and units[0].last
    path = PathLine.from_points([(0, 0), (13, 0)])  # 2 × 6 m + 1 m tail: the tail joins the others
    units = split_segment(path, LineString(path.xy).buffer(1.5), cfg=DrivingUnitConfig(unit_length=6.0, min_length=2.0))
    assert len(units) == 2 and units[-1].s_end == pytest.approx(13.0)


def test_degenerate_path_is_rejected():
    with pytest.raises(PolylineError):
        PathLine.from_points([(1, 1), (1, 1)])
    with pytest.raises(PolylineError):
        PathLine.from_points([(0, 0), (np.inf, 1)])


def test_projection_and_offset():
    path = PathLine.from_points([(0, 0), (10, 0)])
    s, lat = path.project((4.0, -1.5))
    assert s == pytest.approx(4.0) and lat == pytest.approx(-1.5)
    assert np.allclose(path.offset(-0.5)[:, 1], -0.5)
