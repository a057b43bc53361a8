"""Odometry drift follows the configured model; the same seed gives the same odometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wire.drive import DriveCommand
from vehicle_sim.odometry import PERFECT_ODOMETRY, NoiseSource, OdometryModel, OdometryState, odometry_step
from vehicle_sim.simulator import SimConfig, Simulator
from vehicle_sim.worldfile import load_world

MODEL = OdometryModel(scale_error=0.02, yaw_scale_error=0.0, heading_bias=0.001, distance_noise=0.02, heading_noise=0.002, turn_noise=0.01)


def drive_straight(model: OdometryModel, rng: np.random.Generator, metres: int, step_m: float = 0.5) -> OdometryState:
    noise = NoiseSource(rng)
    s = OdometryState()
    for _ in range(int(metres / step_m)):
        s = odometry_step(s, step_m, 0.0, 0.1, model, noise.pair())
    return s


def test_perfect_odometry_follows_the_truth():
    s = OdometryState()
    s = odometry_step(s, 2.0, 0.0, 1.0, PERFECT_ODOMETRY, (1.0, -1.0))
    s = odometry_step(s, math.pi, math.pi / 2, 1.0, PERFECT_ODOMETRY, (0.3, 0.3))  # quarter circle of radius 2
    assert (s.x, s.y, s.yaw) == pytest.approx((4.0, 2.0, math.pi / 2))
    assert s.distance == pytest.approx(2.0 + math.pi)


def test_drift_statistics_match_the_model():
    """Over N straight runs of D metres: distance error ~ N(scale·D, σd²·D), heading ~ N(bias·D, σh²·D)."""
    D, N = 100, 400
    rng = np.random.default_rng(42)
    runs = [drive_straight(MODEL, rng, D) for _ in range(N)]
    dist_err = np.array([r.distance for r in runs]) - D  # |ds_m| summed; noise ≪ step so no folding
    yaw = np.array([r.yaw for r in runs])
    sd_d = MODEL.distance_noise * math.sqrt(D)
    sd_h = MODEL.heading_noise * math.sqrt(D)
    assert dist_err.mean() == pytest.approx(MODEL.scale_error * D, abs=4 * sd_d / math.sqrt(N))
    assert dist_err.std(ddof=1) == pytest.approx(sd_d, rel=0.15)
    assert yaw.mean() == pytest.approx(MODEL.heading_bias * D, abs=4 * sd_h / math.sqrt(N))
    assert yaw.std(ddof=1) == pytest.approx(sd_h, rel=0.15)
    # the heading bias bends the path: lateral error ≈ bias·D²/2
    lateral = np.array([r.y for r in runs])
    assert lateral.mean() == pytest.approx(MODEL.heading_bias * D * D / 2, rel=0.1)


def test_turn_noise_and_yaw_scale_when_turning_in_place():
    model = OdometryModel(scale_error=0.0, yaw_scale_error=0.05, heading_bias=0.0, distance_noise=0.0, heading_noise=0.0, turn_noise=0.02)
    rng = np.random.default_rng(7)
    finals = []
    for _ in range(400):
        noise = NoiseSource(rng)
        s = OdometryState()
        total = 0.0
        for _ in range(40):
            s = odometry_step(s, 0.0, 0.05, 0.1, model, noise.pair())  # 2 rad in place, unwrapped below
            total += 0.05
        finals.append((s.yaw - total + math.pi) % (2 * math.pi) - math.pi)
        assert (s.x, s.y) == (0.0, 0.0)
    err = np.array(finals)
    assert err.mean() == pytest.approx(0.05 * 2.0, abs=4 * 0.02 * math.sqrt(2.0) / 20)
    assert err.std(ddof=1) == pytest.approx(0.02 * math.sqrt(2.0), rel=0.15)


def test_same_seed_same_odometry_different_seed_different():
    a = drive_straight(MODEL, np.random.default_rng(5), 50)
    b = drive_straight(MODEL, np.random.default_rng(5), 50)
    c = drive_straight(MODEL, np.random.default_rng(6), 50)
    assert (a.x, a.y, a.yaw) == (b.x, b.y, b.yaw)
    assert (a.x, a.y, a.yaw) != (c.x, c.y, c.yaw)


def test_simulator_odometry_starts_at_local_origin_and_drifts():
    world = load_world("campus")
    sim = Simulator(world, SimConfig(vehicle="terregator", seed=3))
    o = sim.odometry()
    assert (o.x, o.y, o.yaw, o.distance) == (0.0, 0.0, 0.0, 0.0)
    for _ in range(20):
        sim.submit(DriveCommand(speed=1.0, curvature=0.0))
        sim.advance(0.4)
    o, t = sim.odometry(), sim.truth()
    travelled = math.hypot(t.x - world.start.x, t.y - world.start.y)
    assert travelled > 6.0
    # local frame: x along the start heading; the odometer reads ~ (1 + scale) × the true distance
    assert o.x == pytest.approx(travelled * (1 + sim.config.odometry.scale_error), rel=0.02)
    assert o.x != pytest.approx(travelled, abs=1e-6)
