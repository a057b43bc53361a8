"""PERCEPTION MONITOR: sensor and segmentation selection, view frame and resolution, image input
position, segmentation parameters.

Seed: Sidewalk 1986 §3.3 (3.3.1 selection; 3.3.2 view frame and resolution from the error allowance and
the processing time, Figure 9: V = D/T; 3.3.3 image input position by simulating the view frame along the
planned path; 3.3.4 colour types and minimum segment area from the predicted objects).

The colour types and their nominal colours come from the map; where the predicted objects say
which type a pixel must have (well inside an object, whatever the pose error), the monitor hands
those pixels to the PATCH MAKER to fit its colour classes to this frame (`colour_training`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
import shapely
from shapely.geometry import Polygon as ShapelyPolygon
from shapely import affinity

from modules.perception.patch_maker import ColourModel, Segmentation, SegmentationParams
from modules.perception.predicted import PredictedObject, vehicle_to_world, visible_regions
from modules.vocabulary import MapObject

__all__ = [
    "SENSORS",
    "SensorGeometry",
    "ViewPlan",
    "ResolutionTable",
    "InputPosition",
    "select_segmentation",
    "segmentation_params",
    "colour_model_for",
    "colour_training",
    "image_input_position",
]


@dataclass(frozen=True)
class SensorGeometry:
    """Laser scanner geometry in the vehicle frame: mount height [m], pitch down [rad], fields of view [rad]."""

    height: float = 2.0
    pitch_down: float = math.radians(15.0)
    hfov: float = math.radians(80.0)
    vfov: float = math.radians(30.0)
    rows: int = 64
    cols: int = 256
    range_step: float = 0.08  # range quantum [m]
    x_offset: float = 0.0  # scanner ahead of the vehicle origin [m]

    def row_ground_distance(self) -> np.ndarray:
        """Return (rows,) ground distance [m] ahead of the scanner for each row (inf above the horizon), top row first."""
        dphi = self.vfov / self.rows
        depression = self.pitch_down - self.vfov / 2 + (np.arange(self.rows) + 0.5) * dphi
        with np.errstate(divide="ignore"):
            d = np.where(depression > 1e-3, self.height / np.tan(np.maximum(depression, 1e-3)), np.inf)
        return d


@dataclass(frozen=True)
class ViewPlan:
    """The monitor's decision for one error allowance: resolution step, perception distance, view frame."""

    error_allowance: float  # [m]
    step: int  # every step-th row and column
    near: float  # [m] nearest ground distance seen
    distance: float  # perception distance D [m]
    time_s: float  # expected processing time T [s]
    speed: float  # V = D / T [m/s]
    view_frame: tuple[tuple[float, float], ...]  # vehicle frame polygon [m]


@dataclass
class ResolutionTable:
    """The monitor's table of optimal resolution and perception distance per error allowance (Figure 9).

    Processing time per resolution step starts from a model and is replaced by measurements (EMA).
    """

    sensor: SensorGeometry = field(default_factory=SensorGeometry)
    steps: tuple[int, ...] = (1, 2, 4)
    max_distance: float = 20.0  # the ambiguity interval bounds a trustworthy range [m]
    base_time_s: float = 0.004
    per_pixel_s: float = 1.5e-6
    _time: dict[int, float] = field(default_factory=dict)

    def time_for(self, step: int) -> float:
        """Return the expected processing time [s] at a resolution step."""
        if step in self._time:
            return self._time[step]
        n = (self.sensor.rows // step) * (self.sensor.cols // step)
        return self.base_time_s + self.per_pixel_s * n

    def record(self, step: int, seconds: float, alpha: float = 0.3) -> None:
        """Fold a measured processing time [s] at `step` into the table."""
        prev = self._time.get(step)
        self._time[step] = seconds if prev is None else (1 - alpha) * prev + alpha * seconds

    def pixel_error(self, distance: np.ndarray, step: int) -> np.ndarray:
        """Return the ground position error [m] of a pixel at `distance` [m] when every `step`-th row is used."""
        h = self.sensor.height
        dphi = step * self.sensor.vfov / self.sensor.rows
        spacing = dphi * (h * h + distance**2) / h
        return 0.5 * spacing + 0.5 * self.sensor.range_step

    def distance_for(self, error_allowance: float, step: int) -> float:
        """Return the largest perception distance D [m] whose pixel error stays within the allowance."""
        d = self.sensor.row_ground_distance()
        d = d[np.isfinite(d) & (d <= self.max_distance)]
        if d.size == 0:
            return 0.0
        ok = d[self.pixel_error(d, step) <= error_allowance]
        return float(ok.max()) if ok.size else float(d.min())

    def plan(self, error_allowance: float, speed: float | None = None) -> ViewPlan:
        """Pick the resolution step for this error allowance [m] (Figure 9, V = D / T).

        Without a `speed` [m/s]: the step with the highest V. With one: among the steps fast enough
        for it (V ≥ speed), the one that sees farthest — the widest view for the chance of finding
        landmarks; if none is fast enough, the fastest (the vehicle becomes short-sighted).
        """
        near = float(np.nanmin(self.sensor.row_ground_distance()))
        cands = []
        for s in self.steps:
            d = self.distance_for(error_allowance, s)
            t = self.time_for(s)
            v = d / t if t > 0 else 0.0
            cands.append(ViewPlan(error_allowance, s, near, d, t, v, self.view_frame(near, d)))
        fast = [c for c in cands if speed is not None and c.speed >= speed]
        if fast:
            return max(fast, key=lambda c: (c.distance, -c.step))
        return max(cands, key=lambda c: (c.speed, c.distance))

    def table(self, allowances: tuple[float, ...] = (0.1, 0.2, 0.3, 0.5, 0.75, 1.0), speed: float | None = None) -> list[ViewPlan]:
        """Return the table of plans for several error allowances [m] at a desired speed [m/s]."""
        return [self.plan(e, speed) for e in allowances]

    def view_frame(self, near: float, far: float) -> tuple[tuple[float, float], ...]:
        """Return the ground trapezoid seen between `near` and `far` [m] (vehicle frame)."""
        t = math.tan(self.sensor.hfov / 2)
        x0 = self.sensor.x_offset
        return ((x0 + near, -near * t), (x0 + far, -far * t), (x0 + far, far * t), (x0 + near, near * t))


#: where each vehicle carries its sensors
SENSORS: dict[str, SensorGeometry] = {
    "navlab": SensorGeometry(height=2.3, pitch_down=math.radians(14.0), x_offset=1.6),
    "terregator": SensorGeometry(height=1.6, pitch_down=math.radians(14.0), x_offset=0.7),
}


def select_segmentation(objects: tuple[MapObject, ...] | list[MapObject]) -> Segmentation:
    """Choose colour when the ground is flat (sidewalks, intersections, lawns) and colored-range when slopes
    or stairs are expected (§3.3.1). Standing objects (trees, posts, buildings) do not decide: they are
    landmarks the fix uses when range is on anyway."""
    if all(o.shape.type in ("flat", "prism", "tree", "post") for o in objects):
        return Segmentation.COLOUR
    return Segmentation.COLORED_RANGE


def _tilt_deg(o: MapObject) -> float | None:
    if o.shape.type not in ("slope", "stairs") or o.polygon is None:
        return None
    ax = math.radians(o.shape.axis_deg)  # type: ignore[union-attr]
    pts = np.asarray(o.polygon)
    proj = pts @ np.array([math.cos(ax), math.sin(ax)])
    length = float(proj.max() - proj.min())
    if length <= 0:
        return None
    return math.degrees(math.atan2(abs(o.shape.rise), length))  # type: ignore[union-attr]


def segmentation_params(objects: tuple[MapObject, ...] | list[MapObject], base: SegmentationParams = SegmentationParams()) -> SegmentationParams:
    """Derive minimum segment area and range thresholds from the predicted objects (§3.3.4)."""
    areas = []
    for o in objects:
        if o.polygon is not None and o.shape.type in ("flat", "slope", "stairs"):
            areas.append(ShapelyPolygon(o.polygon).area)
    small_standing = any(o.center is not None for o in objects)
    min_area = base.min_area_m2
    if areas:
        min_area = float(np.clip(0.05 * min(areas), 0.1, 1.0))
    if small_standing:
        min_area = min(min_area, 0.1)
    rp = base.range
    tilts = [t for o in objects if o.shape.type == "slope" and (t := _tilt_deg(o)) is not None]
    if tilts:
        rp = replace(rp, flat_max_deg=float(np.clip(0.5 * min(tilts), 2.0, 6.0)))
    rises = [o.shape.step_rise for o in objects if o.shape.type == "stairs"]  # type: ignore[union-attr]
    if rises:
        rp = replace(rp, rough_sigma=float(np.clip(0.6 * min(rises) / math.sqrt(12.0), 0.015, 0.05)))
    return replace(base, min_area_m2=min_area, range=rp)


def colour_model_for(objects: tuple[MapObject, ...] | list[MapObject]) -> ColourModel:
    """Build the colour classes (types such as GRAY and GREEN, from the map's nominal colours) for the predicted ground objects."""
    cols = [(o.colour.type, o.colour.nominal) for o in objects if o.colour is not None and o.shape.type in ("flat", "slope", "stairs")]
    if not cols:
        cols = [(o.colour.type, o.colour.nominal) for o in objects if o.colour is not None]
    if not cols:
        raise ValueError("no predicted object has a colour; colour segmentation needs at least one")
    return ColourModel.from_map(cols)


#: Regions shrunk by a margin, prepared, per (region id, margin [m]); the region is held with its entry
#: (visible regions are kept per set of objects, so the same region comes back frame after frame).
_INNER: dict[tuple[int, float], tuple[object, object]] = {}


def _inner(region, margin: float):
    """Return `region` shrunk by `margin` [m], prepared for point tests."""
    key = (id(region), margin)
    if key not in _INNER:
        inner = region.buffer(-margin)
        shapely.prepare(inner)
        if len(_INNER) >= 64:
            _INNER.pop(next(iter(_INNER)))
        _INNER[key] = (region, inner)
    return _INNER[key][1]


def colour_training(
    predicted: list[PredictedObject] | tuple[PredictedObject, ...],
    xy: np.ndarray,
    usable: np.ndarray,
    types: tuple[str, ...],
    prior_pose: tuple[float, float, float],
    margin: float,
    max_pixels: int = 6000,
) -> np.ndarray:
    """Return the colour type each pixel must have, (H, W) int16 (1-based into `types`, 0 = unknown).

    `xy` (H, W, 2) [m] are the pixels' ground points in the vehicle frame, `usable` (H, W) bool the
    pixels to consider; `prior_pose` is world←vehicle. A pixel gets a type when its ground point lies
    inside where a predicted ground object of that type shows (`visible_regions`), at least `margin`
    [m] — the error allowance — from that region's edge, so a prior pose that far off still holds.
    At most about `max_pixels` evenly spread pixels are labelled (plenty for 3×3 colour statistics).
    """
    out = np.zeros(usable.shape, np.int16)
    pick = np.flatnonzero(usable & np.isfinite(xy[..., 0]) & np.isfinite(xy[..., 1]))
    if pick.size > max_pixels:
        pick = pick[:: pick.size // max_pixels]
    if pick.size == 0:
        return out
    rows, cols = np.divmod(pick, usable.shape[1])
    world = vehicle_to_world(xy[rows, cols].astype(np.float64), prior_pose)
    flat = out.reshape(-1)
    for (ctype, _), region in visible_regions(predicted, Segmentation.COLOUR).items():
        if ctype not in types or region.is_empty:
            continue
        inner = _inner(region, margin)
        if inner.is_empty:
            continue
        inside = shapely.contains_xy(inner, world[:, 0], world[:, 1])
        flat[pick[inside]] = types.index(ctype) + 1
    return out


@dataclass(frozen=True)
class InputPosition:
    """Where to take the image: arc length along the path [m], the pose there (path frame) and coverage (0–1)."""

    arc_length: float
    pose: tuple[float, float, float]
    coverage: float


def image_input_position(
    path: np.ndarray,
    region: ShapelyPolygon,
    view_frame: tuple[tuple[float, float], ...],
    *,
    step: float = 0.25,
    fraction_of_best: float = 0.9,
) -> InputPosition:
    """Simulate the view frame along the planned path (N, 2) and return the first pose that sees the region.

    "Sees" means covering at least `fraction_of_best` of the best coverage reachable along the path.
    Path, region and the returned pose share one frame (local or world).
    """
    pts = np.asarray(path, dtype=np.float64)
    if pts.ndim != 2 or pts.shape[0] < 2:
        raise ValueError(f"image_input_position: path needs at least 2 points, got shape {pts.shape}")
    seg = np.diff(pts, axis=0)
    seglen = np.linalg.norm(seg, axis=1)
    cum = np.concatenate([[0.0], np.cumsum(seglen)])
    total = float(cum[-1])
    vf = ShapelyPolygon(view_frame)
    area = max(region.area, 1e-9)
    samples = []
    for s in np.arange(0.0, total + 1e-9, step):
        i = int(min(np.searchsorted(cum, s, side="right") - 1, len(seg) - 1))
        t = (s - cum[i]) / max(seglen[i], 1e-12)
        xy = pts[i] + t * seg[i]
        yaw = math.atan2(seg[i, 1], seg[i, 0])
        w = affinity.translate(affinity.rotate(vf, yaw, origin=(0, 0), use_radians=True), xy[0], xy[1])
        cov = float(w.intersection(region).area / area)
        samples.append((float(s), (float(xy[0]), float(xy[1]), yaw), cov))
    best = max(c for _, _, c in samples)
    for s, pose, c in samples:
        if c >= fraction_of_best * best and c > 0:
            return InputPosition(s, pose, c)
    s, pose, c = samples[0]
    return InputPosition(s, pose, c)
