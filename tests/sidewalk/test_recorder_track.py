"""The recorder's true track holds one pose per sim time (the lock-step repeat test counted start-up repeats)."""

from __future__ import annotations

from sidewalk.recorder import Track


def test_a_pose_repeated_while_sim_time_stands_is_kept_once() -> None:
    track = Track()
    # the simulator repeats its pose at t = 0 a wall-time-dependent number of times before a run starts
    kept = [track.add(0.0, 0.0, -28.0, 1.57) for _ in range(5)]
    kept += [track.add(0.05, 0.0, -27.98, 1.57), track.add(0.05, 0.0, -27.98, 1.57), track.add(0.1, 0.0, -27.95, 1.57)]
    assert kept == [True, False, False, False, False, True, False, True]
    assert track.array()[:, 0].tolist() == [0.0, 0.05, 0.1]
    # a sample out of order is kept (only the newest stamp repeating is a repeat)
    assert track.add(0.05, 0.0, -27.98, 1.57) and len(track.rows) == 4
