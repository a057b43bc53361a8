"""One render per sensor per sim instant (issue 39): a capture asked again at the same stamp is served, bit for bit, from the first."""

from __future__ import annotations

import json
import math
import threading
from dataclasses import fields

import numpy as np
import pytest

from vehicle_sim.instant_captures import InstantCaptures, covers, restrict
from vehicle_sim.node import NodeConfig, SimKeys, SimNode
from vehicle_sim.scene import Scene
from vehicle_sim.sensors import CaptureRequest, capture
from vehicle_sim.worldfile import load_world
from wire.capture import CaptureResult, decode_capture
from wire.network import NetworkConfig
from wire.ports import free_port
from wire.session import open_session

POSE = (0.3, -28.0, math.pi / 2)
FULL = CaptureRequest(camera_width=160, camera_height=120)
LASER = CaptureRequest(camera=False, camera_width=160, camera_height=120)
CAMERA = CaptureRequest(laser=False, camera_width=160, camera_height=120)


@pytest.fixture(scope="module")
def scene() -> Scene:
    return Scene(load_world("campus"), seed=3)


def _same(a: CaptureResult, b: CaptureResult) -> None:
    for f in fields(CaptureResult):
        x, y = getattr(a, f.name), getattr(b, f.name)
        assert (x is None) == (y is None), f.name
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and np.array_equal(x, y, equal_nan=True), f.name
        else:
            assert x == y, f.name


def test_a_laser_scan_asked_after_a_full_capture_at_the_same_stamp_is_the_one_a_scan_alone_gives(scene: Scene) -> None:
    cache, renders = InstantCaptures(), []

    def render(req: CaptureRequest) -> CaptureResult:
        renders.append(req)
        return capture(scene, POSE, 4.0, req, vehicle="terregator")

    full, fresh = cache.get(4.0, FULL, render)
    scan, again = cache.get(4.0, LASER, render)
    assert fresh and not again and renders == [FULL] and (cache.hits, cache.renders) == (1, 1)
    _same(scan, capture(scene, POSE, 4.0, LASER, vehicle="terregator"))
    assert scan.camera_image is None and scan.colored_range is None and full.camera_image is not None


def test_what_a_capture_cannot_give_to_the_bit_is_rendered_anew(scene: Scene) -> None:
    cache, renders = InstantCaptures(), []

    def render(req: CaptureRequest) -> CaptureResult:
        renders.append(req)
        return capture(scene, POSE, 5.0, req, vehicle="terregator")

    cache.get(5.0, LASER, render)
    full, fresh_full = cache.get(5.0, FULL, render)  # the laser-only capture has no camera
    cam, fresh_cam = cache.get(5.0, CAMERA, render)  # a camera alone draws its noise first: not the full capture's
    big, fresh_big = cache.get(5.0, CaptureRequest(), render)  # another camera size
    assert fresh_full and fresh_cam and fresh_big and renders == [LASER, FULL, CAMERA, CaptureRequest()]
    _same(cam, capture(scene, POSE, 5.0, CAMERA, vehicle="terregator"))
    assert not np.array_equal(cam.camera_image, full.camera_image)
    # another instant is never served from this one
    cache.get(5.5, LASER, render)
    assert renders[-1] == LASER and cache.hits == 0


def test_covering_follows_the_order_of_the_noise_draws() -> None:
    stereo_full = CaptureRequest(stereo=True, stereo_size=128)  # at the default camera size, as the two below
    assert covers(FULL, LASER) and covers(FULL, FULL) and not covers(LASER, FULL)
    assert not covers(FULL, CAMERA) and not covers(FULL, CaptureRequest()) and not covers(FULL, CaptureRequest(camera=False))
    assert covers(stereo_full, CaptureRequest()) and not covers(stereo_full, CaptureRequest(stereo=True, stereo_size=64))
    assert not covers(stereo_full, CaptureRequest(camera=False, stereo=True, stereo_size=128))


def test_restrict_leaves_out_only_what_was_not_asked(scene: Scene) -> None:
    full = capture(scene, POSE, 6.0, FULL, vehicle="terregator")
    assert restrict(full, FULL) is full
    cam = restrict(full, CAMERA)
    assert cam.laser_range is None and cam.colored_range is None and cam.camera_image is full.camera_image


def test_the_cache_keeps_only_the_newest_instants(scene: Scene) -> None:
    cache = InstantCaptures(keep=2)
    n = [0]

    def render(req: CaptureRequest) -> CaptureResult:
        n[0] += 1
        return capture(scene, POSE, 7.0, req, vehicle="terregator")

    for t in (1.0, 2.0, 3.0):
        cache.get(t, LASER, render)
    cache.get(1.0, LASER, render)  # forgotten: rendered again
    cache.get(3.0, LASER, render)  # kept
    assert n[0] == 4 and cache.hits == 1


def test_two_modules_asking_at_one_instant_cost_the_simulator_one_render() -> None:
    """A lock-step node holds at sim time 0 until released: two captures asked there are of one instant."""
    port = free_port()
    node = SimNode(load_world("campus"), NodeConfig(vehicle="terregator", seed=2, lockstep=True),
                   NetworkConfig(namespace="instanttest", listen=(f"tcp/127.0.0.1:{port}",)))
    node.start()
    z = open_session(NetworkConfig(namespace="instanttest", connect=(f"tcp/127.0.0.1:{port}",)))
    try:
        k = SimKeys("instanttest")
        alive = threading.Event()
        z.liveliness_subscribe(k.alive, lambda _k, up: up and alive.set(), history=True)
        assert alive.wait(10.0)
        got = []
        for req in ({"camera_width": 160, "camera_height": 120}, {"camera": False, "camera_width": 160, "camera_height": 120}):
            (r,) = z.get_blocking(k.capture, json.dumps(req).encode(), as_json=True, timeout=30.0)
            assert r.ok
            got.append(decode_capture(r.payload))
        assert got[0].stamp == got[1].stamp == 0.0
        assert np.array_equal(got[0].laser_range, got[1].laser_range) and got[1].camera_image is None
        assert (node.captures_served, node.instants.renders, node.instants.hits) == (1, 1, 1)
    finally:
        z.close()
        node.stop()
    assert node.error is None


def test_a_slow_consumer_takes_the_newest_earlier_capture_young_enough_else_one_of_its_own(scene: Scene) -> None:
    cache, renders = InstantCaptures(), []

    def render_at(t: float):
        def render(req: CaptureRequest) -> CaptureResult:
            renders.append((t, req))
            return capture(scene, POSE, t, req, vehicle="terregator")
        return render

    slow = LASER.model_copy(update={"max_age_s": 0.2})
    for t in (1.0, 1.2):
        cache.get(t, FULL, render_at(t))
    scan, fresh = cache.get(1.35, slow, render_at(1.35))
    assert not fresh and scan.stamp == 1.2 and cache.older == 1
    _same(scan, capture(scene, POSE, 1.2, LASER, vehicle="terregator"))
    # the full capture of its own instant, heard first, is not taken over an earlier one: the order of askers must not matter
    cache.get(1.4, FULL, render_at(1.4))
    scan, _ = cache.get(1.4, slow, render_at(1.4))
    assert scan.stamp == 1.2
    # too old: one of its own instant
    scan, fresh = cache.get(1.7, slow, render_at(1.7))
    assert fresh and scan.stamp == 1.7 and renders[-1] == (1.7, slow)
