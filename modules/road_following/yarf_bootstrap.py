"""YARF's bootstrap (Navlab 1990 §5.5): the road located in one image without a prediction.

"When started, the system does not have a prediction of where to place trackers." The vanishing-point
Hough (`vanishing_point`) extracts the lines of the road's features band by band; given the model of
the road structure (the lane model's cross-section) the lines are labelled and the spine placed:

1. each line of the near bands is put on the flat ground at its segment's two ends (the band's top
   and bottom rows), and labelled yellow when its pixels in the camera image pass YARF's hue test
   (`yellow_mask`) and the ground `flank_m` to either side of it does not (a painted line is narrow;
   "some grass has a hue very close to the hue of yellow stripes", and grass is wide), else white
   (or an edge of the road);
2. the spine is the straight line (heading, offset) that puts the most line strength on features of
   the cross-section of the same kind — a yellow line on the yellow centre line, a white one on a
   white stripe, both ends within `match_m` — with the vehicle on the road (between the
   cross-section's outermost features) and at least two of the cross-section's features matched
   (else there is no road); strength, not the count of features, decides, so the faint lines of
   the verge's clutter cannot outvote the painted stripes. The bands' own vanishing points are not trusted for the heading:
   a short band's lines extrapolated to the horizon swing by degrees, where the lines' ends on the
   ground, 4 to 10 m ahead, hold it better;
3. the spine is then the least-squares line through the matched lines' ends, each moved onto the
   spine by its feature's offset (as YARF's own fit does): the grid search's steps and ties vanish.

The result is a straight spine (curvature 0) in `vehicle` from which YARF acquires the road with its
trackers as from any prior.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from modules.road_following.camera import CameraGeometry
from modules.road_following.spine_fit import Spine
from modules.road_following.vanishing_point import BandLines, VanishingConfig, vanishing_lines
from modules.road_following.yarf_trackers import yellow_mask

__all__ = ["BootstrapConfig", "GroundLine", "Bootstrap", "ground_lines", "bootstrap_spine"]


@dataclass(frozen=True)
class BootstrapConfig:
    """The bootstrap's settings: the Hough's image scale and settings, bands used, the search and its tolerances."""

    scale: float = 0.5  # the Hough runs on the blue band reduced by this factor
    hough: VanishingConfig = VanishingConfig()
    near_bands: int = 4  # the nearest bands whose lines are used
    yellow_share: float = 0.3  # a line whose pixels pass the hue test this often is yellow …
    flank_m: float = 0.6  # … unless the ground this far to either side of it passes it as often [m]
    match_m: float = 0.3  # a line lies on a feature when both its ends are within this [m]
    offset_step_m: float = 0.05
    max_heading_deg: float = 15.0  # the road's heading is searched within this of the vehicle's
    heading_step_deg: float = 0.5
    on_road_margin_m: float = 0.2  # the vehicle lies at most this outside the cross-section's outermost features [m]
    min_features: int = 2


@dataclass(frozen=True)
class GroundLine:
    """One extracted line on the ground: its segment's ends (2, 2) [m] in `vehicle`, strength, yellow."""

    ends: tuple[tuple[float, float], tuple[float, float]]
    strength: float
    yellow: bool


@dataclass(frozen=True)
class Bootstrap:
    """The bootstrap's answer: the spine (None: no road), the lines on the ground, features matched, the bands."""

    spine: Spine | None
    lines: tuple[GroundLine, ...]
    features_matched: int
    bands: tuple[BandLines, ...]


def _yellow_share(image: np.ndarray, camera: CameraGeometry, ground: np.ndarray, spread: int = 0) -> float:
    """Return the share of the pixels of `image` (full size) at ground points (N, 2) [m] (± `spread` px across) that pass the hue test."""
    u, v, front = camera.project_ground(ground)
    scale = image.shape[1] / camera.width
    ok = front & np.isfinite(u)
    if not ok.any():
        return 0.0
    cc = (np.round(u[ok] * scale)[:, None] + np.arange(-spread, spread + 1)[None, :]).astype(int)
    rr = np.broadcast_to(np.round(v[ok] * scale).astype(int)[:, None], cc.shape)
    inside = (cc >= 0) & (cc < image.shape[1]) & (rr >= 0) & (rr < image.shape[0])
    return float(yellow_mask(image[rr[inside], cc[inside]]).mean()) if inside.any() else 0.0


def ground_lines(image: np.ndarray, camera: CameraGeometry, bands: tuple[BandLines, ...], cfg: BootstrapConfig) -> list[GroundLine]:
    """Return the lines of the near bands on the ground (`camera`: the reduced image's; `image`: the full camera image)."""
    out = []
    for b in bands[-cfg.near_bands:]:
        if not math.isfinite(b.vp):
            continue
        rows = np.linspace(b.rows[0], b.rows[1] - 1, 8)
        for vp, theta, strength in b.lines:
            g = camera.ground_points(vp + (rows - camera.horizon_row) / math.tan(theta), rows)
            if not np.isfinite(g).all():
                continue
            d = g[-1] - g[0]
            side = np.array([-d[1], d[0]]) / max(float(np.hypot(*d)), 1e-9) * cfg.flank_m
            yellow = (_yellow_share(image, camera, g, spread=2) >= cfg.yellow_share
                      and max(_yellow_share(image, camera, g + side), _yellow_share(image, camera, g - side)) < cfg.yellow_share)
            out.append(GroundLine(ends=((float(g[0, 0]), float(g[0, 1])), (float(g[-1, 0]), float(g[-1, 1]))),
                                  strength=float(strength), yellow=yellow))
    return out


def bootstrap_spine(image: np.ndarray, camera: CameraGeometry, features: tuple[tuple[str, float], ...],
                    cfg: BootstrapConfig = BootstrapConfig()) -> Bootstrap:
    """Locate the road in `image` (H, W, 3) uint8 of `camera` from the cross-section `features` ((kind, offset [m]), …)."""
    w, h = max(16, int(round(camera.width * cfg.scale))), max(16, int(round(camera.height * cfg.scale)))
    small = camera.scaled(w, h)
    blue = cv2.resize(np.ascontiguousarray(image[..., 2]), (w, h), interpolation=cv2.INTER_AREA)
    bands = vanishing_lines(blue, small.horizon_row, cfg.hough)
    lines = ground_lines(image, small, bands, cfg)
    if not lines:
        return Bootstrap(None, (), 0, bands)
    ends = np.array([ln.ends for ln in lines])  # (L, 2, 2)
    strength = np.array([ln.strength for ln in lines])
    yellow = np.array([ln.yellow for ln in lines])
    reach = max(abs(f) for _, f in features) + cfg.on_road_margin_m
    offsets = np.arange(-reach, reach + 1e-9, cfg.offset_step_m)
    kinds = [(f, yellow == (kind == "yellow")) for kind, f in features]
    best = (-1.0, 0, 0.0, 0.0)  # strength, features matched, heading [rad], offset across the road [m]

    def on_features(psi: float, o: float) -> list[tuple[np.ndarray, float]]:
        """Return (matched line, its feature's offset) for the spine (psi, o)."""
        across = ends[..., 1] * math.cos(psi) - ends[..., 0] * math.sin(psi)
        return [(i, f) for f, same in kinds for i in np.flatnonzero((np.abs(across - (o + f)) <= cfg.match_m).all(axis=1) & same)]

    for psi in np.radians(np.arange(-cfg.max_heading_deg, cfg.max_heading_deg + 1e-9, cfg.heading_step_deg)):
        across = ends[..., 1] * math.cos(psi) - ends[..., 0] * math.sin(psi)  # (L, 2) square to the road, + left
        matched = np.zeros(len(offsets), int)
        score = np.zeros(len(offsets))
        for f, same in kinds:
            on = (np.abs(across[None, :, :] - (offsets[:, None, None] + f)) <= cfg.match_m).all(axis=2) & same[None, :]
            matched += on.any(axis=1)
            score += on.astype(float) @ strength
        score[matched < cfg.min_features] = -1.0
        i = int(np.argmax(score))
        if score[i] > best[0]:
            best = (float(score[i]), int(matched[i]), float(psi), float(offsets[i]))
    _, matched_n, psi, o = best
    if matched_n < cfg.min_features:
        return Bootstrap(None, tuple(lines), matched_n, bands)
    pairs = on_features(psi, o)
    x = np.concatenate([ends[i, :, 0] for i, _ in pairs])
    y = np.concatenate([ends[i, :, 1] - f / math.cos(psi) for i, f in pairs])
    wt = np.repeat([strength[i] for i, _ in pairs], 2)
    if np.ptp(x) > 1.0:
        slope, offset = np.polyfit(x, y, 1, w=np.sqrt(wt))
        return Bootstrap(Spine(offset=float(offset), slope=float(slope)), tuple(lines), matched_n, bands)
    # the offset is measured square to the road; the spine's is along the vehicle's y axis
    return Bootstrap(Spine(offset=o / math.cos(psi), slope=math.tan(psi)), tuple(lines), matched_n, bands)
