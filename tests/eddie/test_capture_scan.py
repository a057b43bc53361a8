"""OBSTACLE STOP's laser-only capture from a real simulator process: the scan a full frame carries, to the bit."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np

from wire.keys import SimKeys
from wire.network import NetworkConfig
from wire.ports import free_port

from eddie.obstacle_stop import ObstacleStopConfig, obstacle_ahead
from eddie.modules.sensing import capture_frame, capture_scan
from eddie.toolkit import Module
from modules.perception.obstacles import LaserScan
from tests.modules._procs import spawn, stop


async def test_a_laser_only_capture_is_the_laser_of_a_full_frame_and_decides_the_same():
    ns = f"scan{os.getpid()}"
    ep = f"tcp/127.0.0.1:{free_port()}"
    procs: list[subprocess.Popen] = []
    try:
        # lock-step holds the simulator at sim time 0 (nobody releases it): every capture has the same stamp and pose,
        # so the same noise
        procs.append(spawn([sys.executable, "-m", "sidewalk", "sim", "serve", "--world", "campus", "--vehicle", "terregator",
                            "--lockstep", "--seed", "3", "--ns", ns, "--mode", "router", "--listen", ep], "ready sim", timeout=180))
        async with Module("tester", NetworkConfig(namespace=ns, connect=(ep,))) as me:
            await me.wait_connected(10.0)
            frame = await capture_frame(me)
            scan = await capture_scan(me)
            full = LaserScan.from_capture(frame)
            assert scan.stamp == full.stamp
            for name in ("range_m", "valid", "az", "el", "T_vehicle_laser"):
                a, b = getattr(scan, name), getattr(full, name)
                assert a.dtype == b.dtype and np.array_equal(a, b), name
            assert scan.ambiguity == full.ambiguity and scan.reflectance is None and full.reflectance is None
            assert scan.valid.any()
            # what OBSTACLE STOP concludes from either, along a path that bends away and at speed
            cfg = ObstacleStopConfig(stop_distance_m=5.0)
            path = np.array([[0.0, 0.0], [6.0, 0.0], [10.0, 4.0]])
            for kw in ({}, {"speed": 2.0}, {"path_local": path, "pose_local": (0.0, 0.0, 0.0)}):
                assert obstacle_ahead(scan, cfg, **kw) == obstacle_ahead(full, cfg, **kw), kw
            # and the simulator sent no camera: the scan's reply is a fraction of the frame's
            key = SimKeys(ns).capture
            sizes = {}
            for cam in (True, False):
                replies = await me.link.get(key, payload=json.dumps({"laser": True, "camera": cam}).encode(), timeout=15.0)
                sizes[cam] = len(replies[0].payload)
            assert sizes[False] < 0.7 * sizes[True], sizes
    finally:
        for p in procs:
            stop(p)

