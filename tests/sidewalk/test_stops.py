"""Stops for obstacles and the closest approach to actors, measured from a true track (report evaluation)."""

from __future__ import annotations

import numpy as np
import pytest

from sidewalk.stops import stop_summary


def _track(stop_from: float, stop_for: float, speed: float = 2.0, dt: float = 0.1, total: float = 30.0):
    """Return (t, x, y, yaw) rows of a drive north along x = 1.5 on Oak from y = -40, standing still once."""
    rows, y, t = [], -40.0, 100.0
    while t < 100.0 + total:
        rows.append((t, 1.5, y, np.pi / 2))
        if not (stop_from <= t - 100.0 < stop_from + stop_for):
            y += speed * dt
        t += dt
    return rows


def test_one_stop_on_the_way_is_counted_with_its_time_and_place() -> None:
    s = stop_summary(_track(8.0, 5.0), actors=None, world_name="north_hills", vehicle="navlab", t0=100.0)
    assert s.stops == 1
    assert s.stopped_s == pytest.approx(5.0, abs=0.25)
    (span,) = s.spans
    assert span.at_s == pytest.approx(8.0, abs=0.2) and span.y == pytest.approx(-40.0 + 16.0, abs=0.5)
    assert s.min_actor_clearance_m is None  # no actors in the world file or the run
    assert s.obstacle_stops == 0 and span.actor is None


def test_clearance_to_an_actor_standing_in_the_lane_is_measured(tmp_path) -> None:
    # a bin in the lane ahead of where the track ends (y ≈ -23.8): the Navlab's body reaches 4.6 m ahead
    # of its rear axle, so its front stops about 0.5 m short of the bin's near face (y = -18.7)
    f = tmp_path / "bin.yaml"
    f.write_text("actors:\n  - {id: bin, kind: bin, path: [{x: 1.5, y: -18.35}]}\n")
    s = stop_summary(_track(8.0, 5.0, total=13.0), actors=str(f), world_name="north_hills", vehicle="navlab", t0=100.0)
    assert s.min_actor_clearance_m is not None and s.min_actor_clearance_m == pytest.approx(0.5, abs=0.3)


def test_a_stop_with_an_actor_ahead_in_the_lane_is_a_stop_for_an_obstacle(tmp_path) -> None:
    f = tmp_path / "two.yaml"  # a bin in the lane ahead of the stop, a dog far off to the side
    f.write_text("actors:\n  - {id: bin, kind: bin, path: [{x: 1.5, y: -16.0}]}\n"
                 "  - {id: dog, kind: dog, path: [{x: 12.0, y: -22.0}]}\n")
    s = stop_summary(_track(8.0, 5.0), actors=str(f), world_name="north_hills", vehicle="navlab", t0=100.0)
    assert s.stops == 1 and s.obstacle_stops == 1 and s.spans[0].actor == "bin"
    assert s.obstacle_stopped_s == pytest.approx(s.stopped_s)
