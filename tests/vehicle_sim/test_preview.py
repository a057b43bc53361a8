"""The simulator's sensor preview: small images of each capture it serves, published without pose or truth."""

from __future__ import annotations

import json
import math
import queue
import threading

import cv2
import numpy as np
import pytest

from vehicle_sim.node import NodeConfig, SimKeys, SimNode
from vehicle_sim.preview import PREVIEW_WIDTH, make_preview
from vehicle_sim.scene import Scene
from vehicle_sim.sensors import CaptureRequest, capture
from vehicle_sim.worldfile import load_world
from wire.network import NetworkConfig
from wire.ports import free_port
from wire.preview import PreviewError, SimPreview, decode_preview, encode_preview
from wire.session import open_session


def _decoded(img) -> np.ndarray:
    a = cv2.imdecode(np.frombuffer(img.data, np.uint8), cv2.IMREAD_COLOR)
    assert a is not None
    return a


def test_preview_is_small_jpegs_and_no_pose():
    world = load_world("campus")
    res = capture(Scene(world, seed=1), (0.3, -28.0, math.pi / 2), 3.0, CaptureRequest(), vehicle="terregator")
    p = make_preview(res, seq=5)
    assert p.stamp == 3.0 and p.seq == 5 and p.vehicle == "terregator"
    cam, cr = _decoded(p.camera), _decoded(p.colored_range)
    assert cam.shape[1] == PREVIEW_WIDTH and cam.shape[0] == p.camera.height == 192
    assert cr.shape[1] == PREVIEW_WIDTH and cr.shape[0] == p.colored_range.height == 96
    assert (p.camera.source_width, p.camera.source_height) == (320, 240)
    assert cam.std() > 5.0  # an image, not a blank
    wire = encode_preview(p)
    assert len(wire) < 40_000
    back = decode_preview(wire)
    assert back == p
    fields = set(SimPreview.model_fields) | {f for f in type(p.camera).model_fields}
    assert not fields & {"x", "y", "yaw", "pose", "truth_pose", "labels", "camera_labels", "laser_labels"}
    with pytest.raises(PreviewError, match="not msgpack|invalid preview"):
        decode_preview(b"\xc1garbage")


def test_node_publishes_a_preview_for_every_capture_it_serves():
    port = free_port()
    node = SimNode(load_world("campus"), NodeConfig(vehicle="terregator", rtf=5.0, seed=2),
                   NetworkConfig(namespace="previewtest", listen=(f"tcp/127.0.0.1:{port}",)))
    node.start()
    z = open_session(NetworkConfig(namespace="previewtest", connect=(f"tcp/127.0.0.1:{port}",)))
    got: queue.Queue = queue.Queue()
    try:
        k = SimKeys("previewtest")
        z.subscribe_payload(k.preview, lambda _k, b: got.put(b))
        alive = threading.Event()
        z.liveliness_subscribe(k.alive, lambda _k, up: up and alive.set(), history=True)
        assert alive.wait(10.0)
        previews = []
        for i in range(2):
            (r,) = z.get_blocking(k.capture, json.dumps({"camera_width": 160, "camera_height": 120}).encode(), as_json=True, timeout=30.0)
            assert r.ok
            previews.append(decode_preview(got.get(timeout=30.0)))
        assert [p.seq for p in previews] == [1, 2] and node.captures_served == 2
        assert previews[0].camera.source_width == 160 and previews[0].colored_range is not None
    finally:
        z.close()
        node.stop()
    assert node.error is None
