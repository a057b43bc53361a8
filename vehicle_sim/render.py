"""Image writers for captures: false-colour range, labels, colored-range, and a top-down map.

Arrays returned here are RGB uint8; `write_render` writes PNG files (camera.png, range.png,
labels.png, colored_range.png, map.png, and with the stereo pair stereo_left.png, stereo_right.png)
into a directory. The map is drawn north up, world frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from vehicle_sim.scene import Scene
from vehicle_sim.sensors.camera import CameraConfig, camera_model
from vehicle_sim.sensors.capture import CaptureResult
from vehicle_sim.worldfile import KINDS, PostShape, PrismShape, TreeShape

__all__ = [
    "LABEL_PALETTE",
    "range_image",
    "label_image",
    "colored_range_image",
    "ViewFrames",
    "view_frames",
    "map_image",
    "write_render",
]

#: RGB colour per class index of `worldfile.KINDS`.
_PALETTE = {
    "none": (60, 50, 40), "grass": (60, 170, 60), "road": (90, 90, 100), "driveway": (170, 140, 110),
    "sidewalk": (200, 200, 200), "intersection": (150, 150, 230), "slope": (240, 170, 40), "stairs": (230, 40, 200),
    "building": (170, 60, 40), "tree": (20, 100, 20), "mailbox": (40, 70, 230), "lamp_post": (250, 250, 80),
    "bench": (140, 90, 40), "hedge": (40, 130, 90), "sign": (250, 40, 40), "hydrant": (250, 120, 0),
    "wall": (120, 110, 150), "rock": (130, 130, 110), "sky": (180, 220, 250),
}
LABEL_PALETTE: np.ndarray = np.zeros((256, 3), np.uint8)
for _i, _k in enumerate(KINDS):
    LABEL_PALETTE[_i] = _PALETTE.get(_k, (255, 0, 255))

_LASER_DISPLAY = (768, 288)  # 256×64 scaled to square angles (0.31°/col, 0.47°/row)


def range_image(code: np.ndarray, valid: np.ndarray, *, bits: int = 8, xyz: np.ndarray | None = None) -> np.ndarray:
    """Return a false-colour RGB image of a range code image (near = blue … far = red; no return = black).

    With the measured points `xyz` (rows, cols, 3) [m] the colours are shaded by the surface
    orientation (horizontal surfaces bright, vertical ones darker), which shows stair risers.
    """
    scaled = (code.astype(np.float32) * (255.0 / ((1 << bits) - 1))).astype(np.uint8)
    rgb = cv2.applyColorMap(scaled, cv2.COLORMAP_JET)[..., ::-1].astype(np.float32)
    if xyz is not None:
        rgb *= _up_shading(xyz, valid)[..., None]
    rgb[~valid] = 0
    return np.clip(rgb, 0, 255).astype(np.uint8)


def _up_shading(xyz: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Return a shade factor [0.45–1] per pixel from |n_z| of normals of the smoothed point image."""
    p = np.where(valid[..., None], xyz, 0.0).astype(np.float32)
    w = cv2.blur(valid.astype(np.float32), (3, 3))
    p = cv2.blur(p, (3, 3)) / np.maximum(w, 1e-6)[..., None]
    du = np.zeros_like(p)
    dv = np.zeros_like(p)
    du[:, 1:-1] = p[:, 2:] - p[:, :-2]
    dv[1:-1] = p[2:] - p[:-2]
    n = np.cross(du, dv)
    nz = np.abs(n[..., 2]) / np.maximum(np.linalg.norm(n, axis=-1), 1e-9)
    return (0.45 + 0.55 * nz).astype(np.float32)


def label_image(labels: np.ndarray) -> np.ndarray:
    """Return the RGB palette image of a label image (class indices into `KINDS`)."""
    return LABEL_PALETTE[labels]


def colored_range_image(colour: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Return the colored-range image as RGB, unregistered pixels magenta-black checked for visibility."""
    out = colour.copy()
    yy, xx = np.indices(valid.shape)
    out[~valid] = np.where(((yy + xx) % 2 == 0)[~valid][:, None], [40, 0, 40], [0, 0, 0])
    return out


def _laser_display(rgb: np.ndarray) -> np.ndarray:
    return cv2.resize(rgb, _LASER_DISPLAY, interpolation=cv2.INTER_NEAREST)


@dataclass(frozen=True)
class ViewFrames:
    """Ground footprints of the sensors' fields of view, world frame, (N, 2) [m] polygons (first point: the sensor)."""

    laser: np.ndarray
    camera: np.ndarray | None


def view_frames(result: CaptureResult) -> ViewFrames:
    """Return the ground footprints of the sensors' fields of view (world frame) [m].

    The laser footprint is cut at the ambiguity interval, the camera's at 30 m (flat ground at the
    vehicle's height).
    """
    x, y, yaw = (float(v) for v in result.truth_pose)
    T = result.T_vehicle_laser
    oz = T[2, 3]
    az, el = result.laser_az.astype(np.float64), result.laser_el.astype(np.float64)
    border = np.concatenate([
        np.stack([az, np.full_like(az, el[-1])], 1),
        np.stack([np.full_like(el, az[-1]), el[::-1]], 1),
        np.stack([az[::-1], np.full_like(az, el[0])], 1),
        np.stack([np.full_like(el, az[0]), el], 1),
    ])
    laser = _footprint(x, y, yaw, T[0, 3], T[1, 3], oz, border, result.ambiguity)
    camera = None
    if result.camera_K is not None:
        K = result.camera_K
        w, h = int(round(K[0, 2] * 2 + 1)), int(round(K[1, 2] * 2 + 1))
        pitch = -math.degrees(math.asin(float(np.clip(result.T_vehicle_camera[2, 2], -1.0, 1.0))))
        cfg = CameraConfig(width=w, height=h, hfov_deg=math.degrees(2 * math.atan(0.5 * w / K[0, 0])))
        m = camera_model(cfg, pitch)
        ring = np.concatenate([
            np.stack([m.pixel_az[-1, :], m.pixel_el[-1, :]], 1), np.stack([m.pixel_az[::-1, -1], m.pixel_el[::-1, -1]], 1),
            np.stack([m.pixel_az[0, ::-1], m.pixel_el[0, ::-1]], 1), np.stack([m.pixel_az[:, 0], m.pixel_el[:, 0]], 1),
        ]).astype(np.float64)
        Tc = result.T_vehicle_camera
        camera = _footprint(x, y, yaw, Tc[0, 3], Tc[1, 3], Tc[2, 3], ring, 30.0)
    return ViewFrames(laser=laser, camera=camera)


def _footprint(x: float, y: float, yaw: float, sx: float, sy: float, sz: float, az_el: np.ndarray, reach: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    ox, oy = x + c * sx - s * sy, y + s * sx + c * sy
    a, e = az_el[:, 0], az_el[:, 1]
    with np.errstate(divide="ignore"):
        d = np.where(np.tan(e) < -1e-6, sz / -np.tan(e), np.inf)
    d = np.minimum(d, reach * np.cos(e))
    pts = np.stack([ox + d * np.cos(yaw + a), oy + d * np.sin(yaw + a)], 1)
    return np.vstack([[ox, oy], pts])


def map_image(scene: Scene, result: CaptureResult | None = None, *, px_per_m: float | None = None,
              max_px: int = 1100) -> np.ndarray:
    """Return a top-down RGB map of the scene (north up): ground colours with shadows, solids, and,
    with a capture, the vehicle pose and the sensor view frames."""
    h, w = scene.shape
    res = scene.res
    if px_per_m is None:
        px_per_m = min(4.0, max_px / (max(h, w) * res))
    step = max(1, int(round(1.0 / (px_per_m * res))))
    grid = scene.grid[::step, ::step]
    lit = scene.sunlit[::step, ::step].astype(np.float32)[..., None] / 255.0
    col = scene.mat_mean[grid] * (0.45 + 0.55 * lit)
    img = np.clip(col, 0, 255).astype(np.uint8)[::-1].copy()  # north up
    ppm = 1.0 / (step * res)
    H = img.shape[0]

    def to_px(xy: np.ndarray) -> np.ndarray:
        p = (np.asarray(xy, np.float64) - scene.origin) * ppm
        p[:, 1] = H - p[:, 1]
        return np.round(p * 16).astype(np.int32)

    for i, o in enumerate(scene.world.objects):
        colour = tuple(int(v) for v in scene.mat_mean[i + 1] * 0.8)
        if isinstance(o.shape, PrismShape):
            cv2.fillPoly(img, [to_px(o.vertices).reshape(-1, 1, 2)], colour, cv2.LINE_AA, shift=4)
            cv2.polylines(img, [to_px(o.vertices).reshape(-1, 1, 2)], True, (30, 30, 30), 1, cv2.LINE_AA, shift=4)
        elif isinstance(o.shape, TreeShape):
            crown = o.appearance.crown.mean if o.appearance is not None and o.appearance.crown is not None else (46.0, 92.0, 38.0)
            colour = tuple(int(v * 0.8) for v in crown)
            c = to_px(np.array([o.center]))[0]
            overlay = img.copy()
            cv2.circle(overlay, tuple(int(v) for v in c), int(o.shape.crown_radius * ppm * 16), colour, -1, cv2.LINE_AA, shift=4)
            img = cv2.addWeighted(overlay, 0.6, img, 0.4, 0)
            cv2.circle(img, tuple(int(v) for v in c), max(int(o.shape.trunk_radius * ppm * 16), 16), (70, 50, 30), -1, cv2.LINE_AA, shift=4)
        elif isinstance(o.shape, PostShape):
            c = to_px(np.array([o.center]))[0]
            cv2.circle(img, tuple(int(v) for v in c), max(int(o.radius * ppm * 16), 24), colour, -1, cv2.LINE_AA, shift=4)
    if result is not None:
        frames = view_frames(result)
        for poly, colour in ((frames.laser, (255, 60, 60)), (frames.camera, (255, 230, 0))):
            if poly is not None:
                cv2.polylines(img, [to_px(poly).reshape(-1, 1, 2)], True, colour, 1, cv2.LINE_AA, shift=4)
        x, y, yaw = (float(v) for v in result.truth_pose)
        L = max(3.0, 12.0 / ppm)
        tri = np.array([[x + L * math.cos(yaw), y + L * math.sin(yaw)],
                        [x + 0.5 * L * math.cos(yaw + 2.4), y + 0.5 * L * math.sin(yaw + 2.4)],
                        [x + 0.5 * L * math.cos(yaw - 2.4), y + 0.5 * L * math.sin(yaw - 2.4)]])
        cv2.fillPoly(img, [to_px(tri).reshape(-1, 1, 2)], (255, 0, 0), cv2.LINE_AA, shift=4)
        cv2.polylines(img, [to_px(tri).reshape(-1, 1, 2)], True, (0, 0, 0), 1, cv2.LINE_AA, shift=4)
    return img


def write_render(out_dir: str | Path, scene: Scene, result: CaptureResult) -> list[Path]:
    """Write camera.png, range.png, labels.png, colored_range.png, map.png (and the stereo pair's two images) into
    `out_dir`; return the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    images: dict[str, np.ndarray] = {}
    if result.camera_image is not None:
        images["camera.png"] = result.camera_image
    if result.laser_code is not None:
        images["range.png"] = _laser_display(range_image(result.laser_code, result.laser_valid, xyz=result.laser_xyz))
    labels = []
    if result.camera_labels is not None:
        labels.append(label_image(result.camera_labels))
    if result.laser_labels is not None:
        lab = _laser_display(label_image(result.laser_labels))
        if labels:
            lab = cv2.resize(lab, (labels[0].shape[1], int(round(lab.shape[0] * labels[0].shape[1] / lab.shape[1]))),
                             interpolation=cv2.INTER_NEAREST)
            labels.append(np.full((4, lab.shape[1], 3), 255, np.uint8))
        labels.append(lab)
    if labels:
        images["labels.png"] = np.vstack(labels)
    if result.colored_range is not None:
        images["colored_range.png"] = _laser_display(colored_range_image(result.colored_range, result.colored_range_valid))
    images["map.png"] = map_image(scene, result)
    if result.stereo_left is not None and result.stereo_right is not None:
        images["stereo_left.png"], images["stereo_right.png"] = result.stereo_left, result.stereo_right
    paths = []
    for name, rgb in images.items():
        p = out / name
        if not cv2.imwrite(str(p), np.ascontiguousarray(rgb[..., ::-1])):
            raise OSError(f"cannot write {p}")
        paths.append(p)
    return sorted(paths)
