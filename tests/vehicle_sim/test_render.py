"""Render writers and the `sidewalk sim render` command."""

from __future__ import annotations

import cv2
import numpy as np
from typer.testing import CliRunner

from sidewalk.cli import app
from tests.vehicle_sim.test_scene import synthetic_world
from vehicle_sim.render import LABEL_PALETTE, label_image, range_image, view_frames, write_render
from vehicle_sim.scene import Scene
from vehicle_sim.sensors import capture
from vehicle_sim.worldfile import KINDS

FILES = ("camera.png", "range.png", "labels.png", "colored_range.png", "map.png")


def test_write_render_writes_five_images(tmp_path) -> None:
    scene = Scene(synthetic_world(), seed=0)
    res = capture(scene, (0.0, 0.0, 0.0), 0.0, rng=np.random.default_rng(0))
    paths = {p.name: p for p in write_render(tmp_path, scene, res)}
    assert sorted(paths) == sorted(FILES)
    cam = cv2.imread(str(paths["camera.png"]))[..., ::-1]
    np.testing.assert_array_equal(cam, res.camera_image)
    lab = cv2.imread(str(paths["labels.png"]))[..., ::-1]
    np.testing.assert_array_equal(lab[:240], LABEL_PALETTE[res.camera_labels])
    assert cv2.imread(str(paths["range.png"])).shape == (288, 768, 3)
    m = cv2.imread(str(paths["map.png"]))
    assert m.shape[0] > 100 and m.shape[1] > 100
    # the vehicle marker (pure red in RGB) is drawn on the map
    assert ((m[..., 2] == 255) & (m[..., 1] == 0) & (m[..., 0] == 0)).sum() > 5


def test_range_image_and_palette() -> None:
    code = np.tile(np.arange(256, dtype=np.uint8), (4, 1))
    valid = np.ones_like(code, bool)
    valid[0, :10] = False
    img = range_image(code, valid)
    assert img.shape == (4, 256, 3) and (img[0, :10] == 0).all()
    assert img[1, 0, 2] > img[1, 0, 0] and img[1, 255, 0] > img[1, 255, 2]  # near blue, far red
    assert tuple(label_image(np.array([[KINDS.index("grass")]], np.uint8))[0, 0]) == tuple(LABEL_PALETTE[KINDS.index("grass")])


def test_view_frames_lie_ahead_of_the_vehicle() -> None:
    scene = Scene(synthetic_world(), seed=0)
    res = capture(scene, (1.0, 2.0, np.pi / 2), 0.0, rng=np.random.default_rng(0))
    frames = view_frames(res)
    for poly in (frames.laser, frames.camera):
        assert (poly[1:, 1] > 2.0).all()  # heading north: every footprint point is north of the vehicle
    assert frames.laser[1:, 1].max() < 2.0 + 1.6 + 20.48 + 0.1


def test_cli_render_and_errors(tmp_path) -> None:
    runner = CliRunner()
    out = tmp_path / "r"
    r = runner.invoke(app, ["sim", "render", "--world", "campus", "--pose", "63,50,90", "--out", str(out)])
    assert r.exit_code == 0, r.output
    for name in FILES:
        assert (out / name).stat().st_size > 1000
    r = runner.invoke(app, ["sim", "render", "--world", "campus", "--pose", "63,50,90", "--stereo", "--out", str(tmp_path / "s")])
    assert r.exit_code == 0, r.output
    left, right = (cv2.imread(str(tmp_path / "s" / f"stereo_{side}.png")) for side in ("left", "right"))
    assert left.shape == right.shape == (512, 512, 3) and not np.array_equal(left, right)
    r = runner.invoke(app, ["sim", "render", "--world", "campus", "--pose", "63,50", "--out", str(out)])
    assert r.exit_code == 2 and "--pose" in r.output
    r = runner.invoke(app, ["sim", "render", "--world", "campus", "--pose", "63,east,90", "--out", str(out)])
    assert r.exit_code == 2 and "--pose" in r.output
    r = runner.invoke(app, ["sim", "render", "--world", "atlantis", "--pose", "0,0,0", "--out", str(out)])
    assert r.exit_code == 2 and "atlantis" in r.output
    r = runner.invoke(app, ["sim", "render", "--world", "campus", "--pose", "0,0,0", "--vehicle", "bike", "--out", str(out)])
    assert r.exit_code == 2 and "--vehicle" in r.output
