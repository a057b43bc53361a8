"""Simulator benchmark: sensor render time, physics step time, and the real-time factor reached.

`run(world, frames)` returns one dict (printed as JSON by `sidewalk bench sim --json`):
- `render_ms_p50`, `render_ms_p95`: one `capture` of both sensors at default resolution (laser
  256×64 + camera 320×240 + colored-range registration) at poses along the world's path graph [ms];
- `render_cpu_ms_p50`: the process's CPU time for the same captures, every thread counted (the camera
  renders on a side thread while the laser scans) [ms] (robust to other processes competing for the
  cores; `load_avg_1min` says how busy the machine was);
- `laser_ms_p50`, `camera_ms_p50`: the two sensors alone [ms];
- `obstacle_check_ms_p50`: OBSTACLE STOP's check of each of those laser images
  (`eddie.obstacle_stop.obstacle_stop.obstacle_ahead`: the points in the corridor along the path ahead, at
  2 m/s; the scan as the module gets it, without reflectance) [ms] wall;
- `step_us_p50`, `step_us_p95`: one `Simulator.step()` (kinematics, odometry, watchdog, ground checks) [µs];
- `rtf_reached`: sim seconds per wall second of the pure simulator loop — physics at 100 Hz driving
  the vehicle, plus a capture of both sensors every 0.5 s of sim time (the ERIM's 2 frames/s), as the
  node does; `rtf_physics_only`: the same without captures (the node captures only on request);
  `scene_build_s`: building the scene once [s].
"""

from __future__ import annotations

import math
import os
import time

import numpy as np

from wire.summary import percentile

__all__ = ["run", "path_poses"]


def path_poses(world, n: int) -> list[tuple[float, float, float]]:  # noqa: ANN001 - World
    """Return `n` poses (x [m], y [m], yaw [rad]) spread along the world's path edges, heading along them."""
    segs = []
    for e in world.edges:
        p = e.points
        for a, b in zip(p[:-1], p[1:]):
            L = float(np.hypot(*(b - a)))
            if L > 1e-6:
                segs.append((a, b, L))
    if not segs:
        s = world.start
        return [((s.x, s.y, s.yaw) if s else (0.0, 0.0, 0.0))] * n
    total = sum(L for _, _, L in segs)
    out = []
    for i in range(n):
        d = (i + 0.5) * total / n
        for a, b, L in segs:
            if d <= L:
                p = a + (b - a) * (d / L)
                yaw = math.atan2(b[1] - a[1], b[0] - a[0]) + (math.pi if i % 2 else 0.0)
                out.append((float(p[0]), float(p[1]), yaw))
                break
            d -= L
    return out


def run(world: str = "campus", frames: int = 100) -> dict:
    """Benchmark the simulator on `world` (name or file) with `frames` captures; return the figures."""
    from dataclasses import replace

    from eddie.obstacle_stop.obstacle_stop import obstacle_ahead
    from modules.perception.obstacles import LaserScan
    from wire.drive import DriveCommand
    from vehicle_sim.scene import Scene
    from vehicle_sim.sensors import CaptureRequest, capture
    from vehicle_sim.simulator import SimConfig, Simulator
    from vehicle_sim.worldfile import load_world

    frames = max(1, int(frames))
    w = load_world(world)
    t0 = time.perf_counter()
    scene = Scene(w, seed=0)
    build_s = time.perf_counter() - t0
    poses = path_poses(w, frames)
    rng = np.random.default_rng(0)
    capture(scene, poses[0], 0.0, rng=rng)  # warm caches (camera model, noise bank)
    render, render_cpu, laser, camera, check = [], [], [], [], []
    only_laser = CaptureRequest(camera=False)
    only_camera = CaptureRequest(laser=False)
    for i, pose in enumerate(poses):
        t, c = time.perf_counter(), time.process_time()
        capture(scene, pose, 0.5 * i, rng=rng)
        render.append((time.perf_counter() - t) * 1e3)
        render_cpu.append((time.process_time() - c) * 1e3)
    for pose in poses[: max(1, frames // 4)]:
        t = time.perf_counter()
        got = capture(scene, pose, 0.0, only_laser, rng=rng)
        laser.append((time.perf_counter() - t) * 1e3)
        scan = replace(LaserScan.from_capture(got), reflectance=None)
        # a path curving gently ahead (curvature 0.05 1/m, a point every 2 m to 20 m; `world` as `local`)
        arc = np.arange(11) * 2.0
        yaw = pose[2] + 0.05 * arc
        ahead = np.column_stack([pose[0] + np.cumsum(np.r_[0.0, 2.0 * np.cos(yaw[:-1])]),
                                 pose[1] + np.cumsum(np.r_[0.0, 2.0 * np.sin(yaw[:-1])])])
        t = time.perf_counter()
        obstacle_ahead(scan, path_local=ahead, pose_local=pose, speed=2.0)
        check.append((time.perf_counter() - t) * 1e3)
        t = time.perf_counter()
        capture(scene, pose, 0.0, only_camera, rng=rng)
        camera.append((time.perf_counter() - t) * 1e3)

    # physics step alone
    sim = Simulator(w, SimConfig(vehicle="navlab", physics_hz=100.0, seed=0))
    sim.submit(DriveCommand(speed=2.0, curvature=0.02, mode="queued", duration=30.0))
    steps = []
    t_loop = time.perf_counter()
    for _ in range(2000):
        t = time.perf_counter()
        sim.step()
        steps.append((time.perf_counter() - t) * 1e6)
    rtf_physics = 2000 * sim.dt / (time.perf_counter() - t_loop)

    # the pure simulator loop: physics at 100 Hz + a capture every 0.5 s sim
    sim = Simulator(w, SimConfig(vehicle="navlab", physics_hz=100.0, seed=1))
    sim.submit(DriveCommand(speed=2.0, curvature=0.02, mode="queued", duration=30.0))
    sim_seconds = min(30.0, max(5.0, frames * 0.5))
    every = int(round(0.5 / sim.dt))
    n_steps = int(round(sim_seconds / sim.dt))
    t = time.perf_counter()
    for k in range(n_steps):
        sim.step()
        if k % every == 0:
            s = sim.state
            capture(scene, (s.x, s.y, s.yaw), sim.t, vehicle="navlab", rng=rng)
    wall = time.perf_counter() - t
    return {
        "world": w.name,
        "frames": frames,
        "scene_build_s": round(build_s, 3),
        "render_ms_p50": percentile(render, 50, digits=2),
        "render_ms_p95": percentile(render, 95, digits=2),
        "render_cpu_ms_p50": percentile(render_cpu, 50, digits=2),
        "load_avg_1min": round(os.getloadavg()[0], 2),
        "laser_ms_p50": percentile(laser, 50, digits=2),
        "camera_ms_p50": percentile(camera, 50, digits=2),
        "obstacle_check_ms_p50": percentile(check, 50, digits=2),
        "step_us_p50": percentile(steps, 50, digits=1),
        "step_us_p95": percentile(steps, 95, digits=1),
        "rtf_reached": round(sim_seconds / wall, 1),
        "rtf_physics_only": round(rtf_physics, 1),
        "rtf_captures_hz_sim": 2.0,
    }
