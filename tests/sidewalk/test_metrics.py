"""Run metrics against hand-computed values."""

import numpy as np
import pytest

from sidewalk.metrics import cross_track_errors, path_length, position_errors


def test_path_length_of_an_l_shape():
    assert path_length(np.array([[0, 0], [3, 0], [3, 4]])) == pytest.approx(7.0)
    assert path_length(np.zeros((1, 2))) == 0.0


def test_cross_track_error_is_distance_to_the_route_polyline():
    route = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    pts = np.array([[5.0, 1.5], [11.0, 5.0], [5.0, -2.0]])
    assert cross_track_errors(pts, route) == pytest.approx([1.5, 1.0, 2.0])


def test_position_error_interpolates_the_truth_in_time_and_drops_stamps_outside_it():
    t_true = np.array([0.0, 10.0])
    xy_true = np.array([[0.0, 0.0], [10.0, 0.0]])
    t_est = np.array([-1.0, 5.0, 10.0, 11.0])
    xy_est = np.array([[9, 9], [5.0, 3.0], [10.0, -4.0], [9, 9]], dtype=float)
    assert position_errors(t_est, xy_est, t_true, xy_true) == pytest.approx([3.0, 4.0])
