"""A fast 2.5-D scene built once from a `World`: ground height field, materials, shadows, solids.

The ground is a raster of the top object per cell (the world's own footprint raster, so labels agree
with `World.label_at`) with heights computed analytically from each object's flat/slope/stairs shape
(so slopes are smooth planes and stairs have vertical risers). Standing objects are analytic solids:
buildings, hedges and benches are vertical prisms; posts and tree trunks are vertical cylinders; tree
crowns are ellipsoids with a vertical axis. Ground shadows of every solid are rasterised once from
the sun direction (parallel light, projected on the base height of the casting object).

`Scene.cast` renders a level azimuth/elevation grid of rays from one origin: each grid column is a
vertical half-plane, so the ground is found by marching the column's height profile once (the
first sample whose elevation angle reaches the ray's, a "voxel-space" renderer) and the solids are
intersected analytically per column. Frames: everything here is in the `world` frame (x east,
y north, z up) [m]; azimuths are math angles CCW from +x [rad].

In a world with terrain (`World.terrain_raster`) the terrain's bilinear height lies under every
ground material, and each standing object stands on the terrain at its centre (its heights are
above it). A sensor tilted by the vehicle's roll and pitch casts its own rays (`Scene.cast_rays`,
compiled in `vehicle_sim.ray_cast`) instead of a level grid.

Surfaces take their colour from each object's `appearance` (the world file's; an object without one
is drawn in its map colour). With the world's `weather`, ground covers also carry wet patches and
fallen leaves whose extent swings over the run (`Scene.albedo` at a sim time), seeded and
reproducible: fixed noise fields thresholded at a cover that depends on the time.
"""

from __future__ import annotations

import copy
import math
from dataclasses import dataclass

import cv2
import numpy as np
from scipy.ndimage import gaussian_filter
from scipy.special import ndtri

from vehicle_sim.markings import PaintRaster
from vehicle_sim.ray_cast import bin_solids, cast_rays
from vehicle_sim.solid_cast import cast_cylinders, cast_ellipsoids, cast_prisms
from vehicle_sim.voxel_march import march_ground

from typing import TYPE_CHECKING

from vehicle_sim.worldfile import (
    KINDS,
    FlatShape,
    PostShape,
    PrismShape,
    SlopeShape,
    StairsShape,
    TreeShape,
    World,
)
from wire.se2 import wrap_angle

if TYPE_CHECKING:
    from vehicle_sim.actors import ActorSet

__all__ = [
    "LABEL_NONE",
    "LABEL_SKY",
    "MATERIAL_SKY",
    "Hits",
    "Scene",
    "ground_samples",
]

#: Class index of "no object" ground.
LABEL_NONE: int = KINDS.index("none")
#: Class index for rays that hit nothing.
LABEL_SKY: int = KINDS.index("sky")
#: Material index for rays that hit nothing.
MATERIAL_SKY: int = -1

_TILE = 512  # texture noise tile size [cells]
_NONE_COLOUR = ((118.0, 104.0, 84.0), (10.0, 10.0, 9.0))  # bare earth where the world has nothing
_CROWN_COLOUR = ((46.0, 92.0, 38.0), (16.0, 20.0, 14.0))  # foliage when a tree's appearance gives no crown
_PLAIN_STD = (8.0, 8.0, 8.0)  # texture of an object drawn in its map colour (no appearance) [DN]
_PLAIN_REFLECTANCE = 0.5  # laser reflectance of an object without appearance
_WET_PATCH_M = 1.2  # wet patches: correlation length of the wetness field [m]
_LEAF_M = 0.12  # fallen leaves: correlation length of the leaf field [m]


def ground_samples(s_min: float = 0.3, s_max: float = 45.0) -> np.ndarray:
    """Return horizontal march distances [m] (S,) float32: 4 cm steps near, growing as 1.5 % of distance."""
    out = [s_min]
    s = s_min
    while s < s_max:
        s += min(max(0.04, 0.015 * s), 0.5)
        out.append(s)
    return np.asarray(out, dtype=np.float32)


@dataclass(frozen=True)
class Hits:
    """What each ray of a level az/el grid hit; arrays are (H, W[, k]) in grid order, world frame.

    `s` horizontal distance [m] (inf = nothing), `rng` 3-D range [m] (inf = nothing), `xyz` hit point
    [m] (NaN = nothing), `label` class index into `KINDS` (uint8, `LABEL_SKY` = nothing), `material`
    int32 index into the scene's materials (`MATERIAL_SKY` = nothing), `normal` unit surface normal
    (float32), `tex` texture noise coordinates (int32, (H, W, 2)), `riser` True where the ray hit a
    vertical ground step.
    """

    s: np.ndarray
    rng: np.ndarray
    xyz: np.ndarray
    label: np.ndarray
    material: np.ndarray
    normal: np.ndarray
    tex: np.ndarray
    riser: np.ndarray

    @property
    def hit(self) -> np.ndarray:
        """Return (H, W) bool: the ray hit a surface within range."""
        return self.material != MATERIAL_SKY


class Scene:
    """A renderable scene built once from a `World` (see module docstring); pure, no network."""

    def __init__(self, world: World, *, seed: int = 0, max_range: float = 45.0) -> None:
        """Build the scene [m]: ground raster, materials, solids, shadows and a seeded texture."""
        self.world = world
        self.seed = int(seed)
        self.max_range = float(max_range)
        rng = np.random.default_rng([self.seed, 0x5CE4E])
        n = len(world.objects)
        self.res = float(world.raster_res)
        xmin, ymin, xmax, ymax = world.bounds(margin=1.0)
        self.origin = np.array([xmin, ymin], dtype=np.float64)
        w = int(math.ceil((xmax - xmin) / self.res)) + 1
        h = int(math.ceil((ymax - ymin) / self.res)) + 1
        self.shape = (h, w)
        # ground raster: object index + 1 per cell (0 = nothing), the world's own raster.
        grid = np.empty((h, w), dtype=np.int16 if n < 32000 else np.int32)
        xs = xmin + (np.arange(w) + 0.5) * self.res
        rows = max(1, 2_000_000 // max(w, 1))
        for r0 in range(0, h, rows):
            r1 = min(h, r0 + rows)
            yy = ymin + (np.arange(r0, r1) + 0.5) * self.res
            pts = np.column_stack([np.tile(xs, r1 - r0), np.repeat(yy, w)])
            grid[r0:r1] = (world.object_index_at(pts) + 1).reshape(r1 - r0, w)
        grid[0, :] = grid[-1, :] = 0  # the margin: nothing there, so clipped lookups read "nothing"
        grid[:, 0] = grid[:, -1] = 0
        self.grid = grid
        self._grid_flat = grid.ravel()

        # materials: 0 = none ground, 1..n = objects (tree objects: the trunk), n+1.. = tree crowns
        trunks = [i for i, o in enumerate(world.objects) if isinstance(o.shape, TreeShape)]
        m = n + 1 + len(trunks)
        self.mat_mean = np.zeros((m, 3), np.float32)
        self.mat_std = np.zeros((m, 3), np.float32)
        self.mat_refl = np.zeros(m, np.float32)
        self.mat_label = np.zeros(m, np.uint8)
        self.mat_mean[0], self.mat_std[0] = _NONE_COLOUR
        self.mat_refl[0], self.mat_label[0] = 0.35, LABEL_NONE
        for i, o in enumerate(world.objects):
            a = o.appearance
            self.mat_mean[i + 1] = a.mean if a is not None else o.colour.nominal
            self.mat_std[i + 1] = a.std if a is not None else _PLAIN_STD
            self.mat_refl[i + 1] = a.reflectance if a is not None else _PLAIN_REFLECTANCE
            self.mat_label[i + 1] = o.kind_index
        crown_mat = {}
        for j, i in enumerate(trunks):
            k = n + 1 + j
            crown_mat[i] = k
            a = world.objects[i].appearance
            cc = a.crown if a is not None else None
            if cc is not None:
                self.mat_mean[k], self.mat_std[k] = cc.mean, cc.std
            else:
                self.mat_mean[k], self.mat_std[k] = _CROWN_COLOUR
            self.mat_refl[k], self.mat_label[k] = 0.55, KINDS.index("tree")

        # analytic ground height per material (object): z = z0 + rise * g(t), t along the axis
        self._g_z0 = np.zeros(m, np.float32)
        self._g_rise = np.zeros(m, np.float32)
        self._g_ax = np.zeros((m, 2), np.float32)
        self._g_lo = np.zeros(m, np.float32)
        self._g_inv_len = np.zeros(m, np.float32)
        self._g_steps = np.zeros(m, np.float32)  # 0 = continuous
        for i, o in enumerate(world.objects):
            s = o.shape
            k = i + 1
            if isinstance(s, FlatShape):
                self._g_z0[k] = s.z
            elif isinstance(s, (SlopeShape, StairsShape)):
                lo, hi = o.axis_extent()
                a = math.radians(s.axis_deg)
                self._g_z0[k], self._g_rise[k] = s.z0, s.rise
                self._g_ax[k] = (math.cos(a), math.sin(a))
                self._g_lo[k] = lo
                self._g_inv_len[k] = 1.0 / max(hi - lo, 1e-9)
                if isinstance(s, StairsShape):
                    self._g_steps[k] = s.n_steps
            else:
                self._g_z0[k] = s.z0
        self._g_a0 = (self._g_ax[:, 0] * self._g_inv_len).astype(np.float32)
        self._g_a1 = (self._g_ax[:, 1] * self._g_inv_len).astype(np.float32)
        self._g_b = (self._g_lo * self._g_inv_len).astype(np.float32)
        self._g_tilted = self._g_rise != 0
        self._any_tilted = bool(self._g_tilted.any())
        # per-material ground normals: tread/flat/slope normal, and the riser normal (minus the axis)
        grad = self._g_rise[:, None] * self._g_inv_len[:, None] * self._g_ax
        grad[self._g_steps > 0] = 0.0
        nrm = np.concatenate([-grad, np.ones((m, 1), np.float32)], axis=1)
        self._g_normal = (nrm / np.linalg.norm(nrm, axis=1, keepdims=True)).astype(np.float32)
        self._g_riser_normal = np.concatenate([-self._g_ax, np.zeros((m, 1), np.float32)], axis=1).astype(np.float32)
        # terrain under every material (a world's optional raster); flat worlds carry a 2×2 placeholder never read
        self.terrain = world.terrain_raster
        self._has_terrain = self.terrain is not None
        if self.terrain is not None:
            self._t_z = np.ascontiguousarray(self.terrain.z, np.float32)
            self._t_org = (float(self.terrain.origin_x), float(self.terrain.origin_y), 1.0 / float(self.terrain.resolution))
        else:
            self._t_z = np.zeros((2, 2), np.float32)
            self._t_org = (0.0, 0.0, 1.0)

        # solids (in a terrain world, standing on the terrain at their centre)
        cyl, ell, prisms = [], [], []
        for i, o in enumerate(world.objects):
            s = o.shape
            if not isinstance(s, (TreeShape, PostShape, PrismShape)):
                continue
            base = 0.0
            if self.terrain is not None:
                cx, cy = o.center if o.center is not None else tuple(o.vertices.mean(axis=0))
                base = self.terrain.height_at(float(cx), float(cy))
            if isinstance(s, TreeShape):
                cx, cy = o.center  # type: ignore[misc]
                cyl.append((cx, cy, s.trunk_radius, base + s.z0, base + s.z0 + s.crown_base + 0.25 * (s.height - s.crown_base), i + 1))
                b = 0.5 * (s.height - s.crown_base)
                ell.append((cx, cy, base + s.z0 + s.crown_base + b, s.crown_radius, b, crown_mat[i]))
            elif isinstance(s, PostShape):
                cx, cy = o.center  # type: ignore[misc]
                cyl.append((cx, cy, float(o.radius), base + s.z0, base + s.z0 + s.height, i + 1))  # type: ignore[arg-type]
            else:
                prisms.append((o.vertices.astype(np.float64), base + s.z0, base + s.z0 + s.height, i + 1))
        self.cylinders = np.asarray(cyl, np.float64).reshape(-1, 6)
        self.ellipsoids = np.asarray(ell, np.float64).reshape(-1, 6)
        self.prisms = prisms
        self._prism_table = _PrismTable.pack(prisms)
        self._prism_centre = np.array([p[0].mean(axis=0) for p in prisms]).reshape(-1, 2)
        self._prism_radius = np.array([np.linalg.norm(p[0] - p[0].mean(axis=0), axis=1).max() for p in prisms]).reshape(-1)

        # sun and ground shadows
        self.sun = world.sun.direction().astype(np.float64)
        self.sunlit = self._shadow_raster()
        self._sunlit_flat = self.sunlit.ravel()
        # materials lit by the ground shadow raster: ground covers, posts and trunks (not crowns, prisms)
        flag = np.ones(m, bool)
        for i, o in enumerate(world.objects):
            if isinstance(o.shape, PrismShape):
                flag[i + 1] = False
        flag[n + 1:] = False  # crowns
        self._mat_ground_shadow = flag

        # texture noise tile (3, T, T), unit std, mildly smoothed
        # texture: unit-variance noise per channel, 64 % correlated across channels (surfaces vary
        # mostly in brightness, as concrete and grass do), mildly smoothed
        raw = rng.standard_normal((4, _TILE, _TILE)).astype(np.float32)
        for c in range(4):
            raw[c] = gaussian_filter(raw[c], 0.6, mode="wrap")
            raw[c] /= raw[c].std()
        tile = 0.8 * raw[3][None] + 0.6 * raw[:3]
        self.tile = tile
        self._tile_flat = np.ascontiguousarray(np.moveaxis(tile, 0, -1).reshape(-1, 3))
        self._samples = ground_samples(0.3, self.max_range)
        self._weather_setup(rng)
        # road markings: paint over road ground (None, and no cost at all, for worlds without markings)
        self.paint = PaintRaster.build(world.objects)
        self._mat_painted = np.zeros(m, bool)
        for i, o in enumerate(world.objects):
            self._mat_painted[i + 1] = o.kind == "road"

    # ---------------------------------------------------------------- weather

    def _weather_setup(self, rng: np.random.Generator) -> None:
        """Draw the wetness and leaf fields (unit-std noise tiles), per-object tile offsets and the phases."""
        self.weather = self.world.weather
        covers = np.zeros(len(self.mat_mean), bool)
        for i, o in enumerate(self.world.objects):
            covers[i + 1] = isinstance(o.shape, (FlatShape, SlopeShape, StairsShape))
        self._mat_cover = covers
        if self.weather is None or (self.weather.wet_cover <= 0.0 and self.weather.leaf_cover <= 0.0):
            self.weather = None
            return
        fields = []
        for length in (_WET_PATCH_M, _LEAF_M):
            f = gaussian_filter(rng.standard_normal((_TILE, _TILE)).astype(np.float32), length / self.res, mode="wrap")
            fields.append((f / f.std()).ravel())
        self._wet_field, self._leaf_field = fields
        # both fields interleaved per cell and read as one 8-byte item: one gather fetches both
        self._fields_pair = np.ascontiguousarray(np.stack(fields, axis=-1)).view(np.int64).reshape(-1)
        # each object reads the fields at its own offset, so neighbouring objects do not repeat each other
        self._field_offset = rng.integers(0, _TILE, size=(len(self.mat_mean), 2)).astype(np.int32)
        self._field_off_x = np.ascontiguousarray(self._field_offset[:, 0])
        self._field_off_y = np.ascontiguousarray(self._field_offset[:, 1])
        self._phases = rng.uniform(0.0, 2.0 * math.pi, size=2)

    def covers_at(self, stamp: float) -> tuple[float, float]:
        """Return the (wet, leaf) share of the ground covers [0–1] at sim time `stamp` [s]."""
        w = self.weather
        if w is None:
            return 0.0, 0.0
        t = 2.0 * math.pi * stamp / w.period_s
        wet = w.wet_cover * (1.0 + w.swing * math.sin(t + self._phases[0]))
        leaf = w.leaf_cover * (1.0 + w.swing * math.sin(t + self._phases[1]))
        return float(np.clip(wet, 0.0, 1.0)), float(np.clip(leaf, 0.0, 1.0))

    def _apply_weather(self, col: np.ndarray, hits: "Hits", noise: np.ndarray, stamp: float) -> None:
        """Darken wet patches and lay leaves on the ground covers of `col` (H, W, 3) in place, at sim time `stamp` [s]."""
        w = self.weather
        assert w is not None
        wet, leaf = self.covers_at(stamp)
        mat = hits.material.reshape(-1)
        sel = np.flatnonzero(np.take(self._mat_cover, np.maximum(mat, 0)) & (mat >= 0))
        if sel.size == 0:
            return
        m = np.take(mat, sel)
        tex = _take_pairs(hits.tex, sel)
        idx = (((tex[:, 1] + np.take(self._field_off_y, m)) & (_TILE - 1)) * _TILE
               + ((tex[:, 0] + np.take(self._field_off_x, m)) & (_TILE - 1)))
        fields = np.take(self._fields_pair, idx).view(np.float32).reshape(-1, 2)  # (n, 2) wet, leaf
        flat = col.reshape(-1, 3)
        # only the pixels a patch or a leaf actually touches are changed (a few per cent of the covers):
        # f > thr exactly where the clipped ramp (f − thr)·gain is above 0
        if wet > 0.0:
            f = fields[:, 0]
            thr = np.float32(ndtri(1.0 - wet))
            k = np.flatnonzero(f > thr)
            a = np.clip((np.take(f, k) - thr) * np.float32(4.0), 0.0, 1.0)
            flat[sel[k]] *= (1.0 - a * np.float32(1.0 - w.wet_brightness))[:, None]
        if leaf > 0.0:
            f = fields[:, 1]
            thr = np.float32(ndtri(1.0 - leaf))
            k = np.flatnonzero(f > thr)
            b = np.clip((np.take(f, k) - thr) * np.float32(6.0), 0.0, 1.0)
            at = sel[k]
            lc = np.asarray(w.leaves.mean, np.float32) + np.asarray(w.leaves.std, np.float32) * np.take(noise.reshape(-1, 3), at, axis=0)
            c = np.take(flat, at, axis=0)
            c += b[:, None] * (lc - c)
            flat[at] = c

    # ---------------------------------------------------------------- actors (objects not on the map)

    _actor_solids: tuple = ()
    _actor_table: "_PrismTable | None" = None
    _actor_mat: dict = {}

    def add_actors(self, actors: "ActorSet") -> None:
        """Give every actor of `actors` a material (colour, reflectance, label "rock"); call once, before `at_time`."""
        per_mat = ("mat_mean", "mat_std", "mat_refl", "mat_label", "_g_z0", "_g_rise", "_g_ax", "_g_lo", "_g_inv_len",
                   "_g_steps", "_g_a0", "_g_a1", "_g_b", "_g_tilted", "_g_normal", "_g_riser_normal", "_mat_ground_shadow",
                    "_mat_painted", "_mat_cover")
        m0 = len(self.mat_refl)
        k = len(actors.actors)
        for name in per_mat:
            a = getattr(self, name)
            setattr(self, name, np.concatenate([a, np.repeat(a[:1], k, axis=0)], axis=0))
        self._actor_mat = {}
        for j, a in enumerate(actors.actors):
            m = m0 + j
            self.mat_mean[m] = a.colour
            self.mat_std[m] = (12.0, 12.0, 12.0)
            self.mat_refl[m] = a.reflectance
            self.mat_label[m] = KINDS.index("rock")
            self._mat_ground_shadow[m] = False
            self._mat_cover[m] = False  # no wet patches or leaves on an actor
            self._actor_mat[a.id] = m
        self._any_tilted = bool(self._g_tilted.any())

    def at_time(self, actors: "ActorSet | None", t: float) -> "Scene":
        """Return a shallow copy of this scene with `actors` placed where they are at sim time `t` [s]."""
        if actors is None or not len(actors):
            return self
        out = copy.copy(self)
        solids = []
        for a, corners in actors.footprints(t):
            c = corners.mean(axis=0)
            zb = float(self.elevation(c[None])[0])
            solids.append((corners.astype(np.float64), zb, zb + a.box[2], self._actor_mat[a.id]))
        out._actor_solids = tuple(solids)
        out._actor_table = _PrismTable.pack(solids)
        return out

    # ---------------------------------------------------------------- ground queries

    def cell_of(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return (col, row, inside) integer cell indices of world points x, y [m]."""
        ix = np.floor((x - self.origin[0]) * (1.0 / self.res)).astype(np.int32)
        iy = np.floor((y - self.origin[1]) * (1.0 / self.res)).astype(np.int32)
        h, w = self.shape
        inside = (ix >= 0) & (ix < w) & (iy >= 0) & (iy < h)
        np.clip(ix, 0, w - 1, out=ix)
        np.clip(iy, 0, h - 1, out=iy)
        return ix, iy, inside

    def _flat_index(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Return flat cell indices of world points (outside points land on the empty border cells)."""
        h, w = self.shape
        ix = ((x - np.float32(self.origin[0])) * np.float32(1.0 / self.res)).astype(np.int32)
        iy = ((y - np.float32(self.origin[1])) * np.float32(1.0 / self.res)).astype(np.int32)
        np.clip(ix, 0, w - 1, out=ix)
        np.clip(iy, 0, h - 1, out=iy)
        iy *= w
        iy += ix
        return iy

    def ground_material(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Return the ground material (object index + 1; 0 = nothing) at world points x, y [m]."""
        return np.take(self._grid_flat, self._flat_index(x, y)).astype(np.int32)

    def ground_height(self, x: np.ndarray, y: np.ndarray, mat: np.ndarray | None = None) -> np.ndarray:
        """Return the ground height z [m] at world points x, y [m] (same shapes), float32."""
        if mat is None:
            mat = self.ground_material(x, y)
        z = np.take(self._g_z0, mat)
        if self._has_terrain:
            z = z + self.terrain.height(np.column_stack([np.ravel(x), np.ravel(y)])).reshape(np.shape(x)).astype(np.float32)  # type: ignore[union-attr]
        if not self._any_tilted:
            return z
        sel = np.nonzero(np.take(self._g_tilted, mat))
        if len(sel[0]) == 0:
            return z
        ms = mat[sel]
        t = x[sel] * self._g_a0[ms] + y[sel] * self._g_a1[ms] - self._g_b[ms]
        np.clip(t, 0.0, 1.0, out=t)
        n = self._g_steps[ms]
        stepped = (np.minimum(np.floor(t * n), n - 1.0) + 1.0) / np.maximum(n, 1.0)
        g = np.where(n > 0, stepped, t)
        z[sel] += (self._g_rise[ms] * g).astype(np.float32)
        return z

    def elevation(self, xy: np.ndarray) -> np.ndarray:
        """Return the ground height [m] at world points `xy` (N, 2) [m] → (N,) float64."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        return self.ground_height(xy[:, 0], xy[:, 1]).astype(np.float64)

    # ---------------------------------------------------------------- shadows

    def _shadow_raster(self) -> np.ndarray:
        """Return the sunlit fraction of each ground cell, (H, W) uint8 (255 = full sun)."""
        h, w = self.shape
        mask = np.zeros((h, w), np.uint8)
        sx, sy, sz = self.sun
        shadow = -np.array([sx, sy]) / max(sz, 1e-3)  # ground displacement per metre of height
        shift = 4
        scale = (1 << shift) / self.res

        def fill(poly_xy: np.ndarray) -> None:
            pts = np.round((poly_xy - self.origin) * scale - 0.5 * (1 << shift)).astype(np.int32)
            cv2.fillPoly(mask, [pts.reshape(-1, 1, 2)], 255, lineType=cv2.LINE_8, shift=shift)

        def hull(points: np.ndarray) -> np.ndarray:
            return cv2.convexHull(points.astype(np.float32)).reshape(-1, 2).astype(np.float64)

        circle = np.column_stack([np.cos(np.linspace(0, 2 * np.pi, 24, endpoint=False)),
                                  np.sin(np.linspace(0, 2 * np.pi, 24, endpoint=False))])
        for cx, cy, r, zb, zt, _ in self.cylinders:
            base = np.array([cx, cy]) + r * circle
            fill(hull(np.vstack([base, base + shadow * (zt - zb)])))
        # crown: the shadow of an ellipsoid under parallel light is an ellipse (exact, via a sphere)
        horiz = math.hypot(sx, sy)
        if horiz > 1e-9:
            along = -np.array([sx, sy]) / horiz
        else:
            along = np.array([1.0, 0.0])
        across = np.array([-along[1], along[0]])
        for cx, cy, zc, R, b, _ in self.ellipsoids:
            zg = float(self.ground_height(np.array([cx]), np.array([cy]))[0])
            centre = np.array([cx, cy]) + shadow * (zc - zg)
            lz = sz * R / b
            sin_el = lz / math.sqrt(horiz**2 + lz**2)
            major = R / max(sin_el, 1e-3)
            pts = centre + major * circle[:, :1] * along + R * circle[:, 1:] * across
            fill(pts)
        for verts, zb, zt, _ in self.prisms:
            fill(hull(np.vstack([verts, verts + shadow * (zt - zb)])))
        sunlit = 255 - mask
        return cv2.GaussianBlur(sunlit, (0, 0), 0.8)

    def sunlit_at(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Return the ground sunlit fraction [0–1] at world points x, y [m], float32."""
        ix, iy, inside = self.cell_of(x, y)
        return np.where(inside, self.sunlit[iy, ix], 255).astype(np.float32) * (1.0 / 255.0)

    # ---------------------------------------------------------------- ray casting

    def cast(self, origin: np.ndarray, az: np.ndarray, el: np.ndarray, reach: float | None = None) -> Hits:
        """Cast a level grid of rays from `origin` (3,) [m]: world azimuths `az` (W,) [rad], elevations `el` (H,) [rad].

        Returns `Hits` of shape (H, W): row i has elevation el[i], column j azimuth az[j]. The ground
        is marched out to `max_range` [m]; with a longer `reach` [m] (cameras) solids are intersected
        out to `reach` and the ground beyond the march is taken as the plane z = 0.
        """
        reach = self.max_range if reach is None else max(float(reach), self.max_range)
        ox, oy, oz = (float(v) for v in origin)
        az = np.asarray(az, np.float64)
        el = np.asarray(el, np.float64)
        H, W = len(el), len(az)
        ca, sa = np.cos(az).astype(np.float32), np.sin(az).astype(np.float32)
        tan_el = np.tan(el).astype(np.float32)
        S = self._samples

        # ---- ground: march every column's height profile once (compiled, without the GIL)
        s_buf = np.empty((H, W), np.float32)
        mat = np.empty((H, W), np.int32)
        normal = np.empty((H, W, 3), np.float32)
        tex = np.empty((H, W, 2), np.int32)
        riser = np.empty((H, W), np.bool_)
        h, w = self.shape
        march_ground(ox, oy, oz, ca, sa, tan_el, S, self._grid_flat, w, h, float(self.origin[0]), float(self.origin[1]),
                     1.0 / self.res, self._any_tilted, self._g_z0, self._g_tilted, self._g_a0, self._g_a1, self._g_b,
                     self._g_steps, self._g_rise, self._g_normal, self._g_riser_normal, s_buf, mat, normal, tex, riser,
                     self._has_terrain, self._t_z, *self._t_org)
        ground_mat = mat.copy()
        t = tan_el[:, None]

        # ---- solids, analytically per column
        rmax = reach
        az_mid = 0.5 * (float(az.max()) + float(az.min()))
        az_half = 0.5 * (float(az.max()) - float(az.min())) + 0.01
        ctx = _Ctx(ox, oy, oz, ca, sa, tan_el, -tan_el,
                   -az if W < 2 or bool(np.all(np.diff(az) < 0)) else None, az_mid,
                   s_buf, mat, normal, tex)
        if reach > self.max_range:  # far ground: the plane z = 0 beyond the march (with terrain: at the ground below)
            z_far = float(self.terrain.height_at(ox, oy)) if self.terrain is not None else 0.0
            far = (mat == MATERIAL_SKY) & (tan_el[:, None] < -1e-4) & (oz > z_far)
            if far.any():
                rr, cc = np.nonzero(far)
                sf = ((oz - z_far) / -tan_el[rr]).astype(np.float32)
                ok = (sf > self.max_range) & (sf <= reach)
                rr, cc, sf = rr[ok], cc[ok], sf[ok]
                fx, fy = ox + sf * ca[cc], oy + sf * sa[cc]
                s_buf[rr, cc] = sf
                mat[rr, cc] = self.ground_material(fx, fy)
                tex[rr, cc, 0] = (fx * np.float32(1.0 / self.res)).astype(np.int32)
                tex[rr, cc, 1] = (fy * np.float32(1.0 / self.res)).astype(np.int32)
        self._cast_solids(ctx, ox, oy, az_mid, az_half, rmax)

        riser &= ctx.mat == ground_mat  # the ground step still won its cell
        s_buf, mat = ctx.s, ctx.mat
        too_far = s_buf > rmax
        np.copyto(mat, MATERIAL_SKY, where=too_far)
        np.copyto(s_buf, np.float32(np.inf), where=too_far)
        hit = mat != MATERIAL_SKY
        miss = ~hit
        cos_el = np.cos(el).astype(np.float32)[:, None]
        rng3 = s_buf / cos_el
        s_fin = np.where(hit, s_buf, np.float32(0.0))
        xyz = np.empty((H, W, 3), np.float32)
        np.add(ox, s_fin * ca[None, :], out=xyz[..., 0])
        np.add(oy, s_fin * sa[None, :], out=xyz[..., 1])
        np.add(oz, s_fin * t, out=xyz[..., 2])
        np.copyto(xyz, np.float32(np.nan), where=miss[..., None])
        label = np.take(self.mat_label, np.maximum(mat, 0))
        np.copyto(label, np.uint8(LABEL_SKY), where=miss)
        riser &= hit
        return Hits(s=s_buf, rng=rng3, xyz=xyz, label=label,
                    material=mat, normal=ctx.normal, tex=ctx.tex, riser=riser)

    def cast_rays(self, origin: np.ndarray, directions: np.ndarray, reach: float | None = None) -> Hits:
        """Cast rays of any direction from `origin` (3,) [m]: `directions` (H, W, 3) or (N, 3), world frame (need not be unit).

        Returns `Hits` of the directions' leading shape. An (H, W) grid is an image (row 0 the top), marched
        column by column from the bottom row up (see `vehicle_sim.ray_cast`). For a tilted sensor (see `vehicle_sim.ray_cast`);
        the ground is marched out to `max_range` [m] and solids are intersected out to `reach` [m]
        (default `max_range`). `tex` holds the hit's ground cell (solids are not textured here).
        """
        reach = self.max_range if reach is None else float(reach)
        ox, oy, oz = (float(v) for v in origin)
        d = np.asarray(directions, np.float64)
        shape = d.shape[:-1]
        d = d.reshape(-1, 3)
        hn = np.maximum(np.hypot(d[:, 0], d[:, 1]), 1e-9)
        ca, sa, tan = d[:, 0] / hn, d[:, 1] / hn, d[:, 2] / hn
        az = np.arctan2(sa, ca)
        az_mid = float(np.arctan2(np.sin(az).mean(), np.cos(az).mean())) if len(az) else 0.0
        rel = wrap_angle(az - az_mid)
        az_lo = float(rel.min()) - 1e-6 if len(rel) else -np.pi
        n_bins = 256
        inv_bin = n_bins / max(float(rel.max()) + 1e-6 - az_lo, 1e-6) if len(rel) else 1.0
        solids = []
        for table, radius_col in ((self.cylinders, 2), (self.ellipsoids, 3)):
            near = table[np.hypot(table[:, 0] - ox, table[:, 1] - oy) - table[:, radius_col] < reach]
            near = np.ascontiguousarray(near)
            start, index = bin_solids(near[:, 0], near[:, 1], near[:, radius_col], ox, oy, az_mid, az_lo, inv_bin, n_bins)
            solids += [near, start, index]
        near = []
        for p in list(self.prisms) + list(self._actor_solids):
            c = p[0].mean(axis=0)
            r = float(np.linalg.norm(p[0] - c, axis=1).max())
            if math.hypot(c[0] - ox, c[1] - oy) - r < reach:
                near.append((p, c, r))
        prisms = _PrismTable.pack([p for p, _, _ in near])
        centre = np.array([c for _, c, _ in near], np.float64).reshape(-1, 2)
        p_start, p_index = bin_solids(centre[:, 0], centre[:, 1], np.array([r for _, _, r in near], np.float64),
                                      ox, oy, az_mid, az_lo, inv_bin, n_bins)
        n = len(ca)
        s_buf = np.empty(n, np.float64)
        mat = np.empty(n, np.int32)
        normal = np.empty((n, 3), np.float64)
        riser = np.empty(n, np.bool_)
        h, w = self.shape
        cast_rays(ox, oy, oz, ca, sa, tan, self._samples, self._grid_flat, w, h, float(self.origin[0]), float(self.origin[1]),
                  1.0 / self.res, self._any_tilted, self._g_z0, self._g_tilted, self._g_a0, self._g_a1, self._g_b,
                  self._g_steps, self._g_rise, self._g_normal, self._g_riser_normal, self._has_terrain, self._t_z, *self._t_org,
                  az_mid, az_lo, inv_bin, n_bins, *solids, prisms.verts, prisms.start, prisms.edges, prisms.edges_unit,
                  prisms.z_bottom, prisms.z_top, prisms.material, p_start, p_index, shape[0] if len(shape) == 2 else 1,
                  s_buf, mat, normal, riser)
        too_far = s_buf > reach
        mat[too_far] = MATERIAL_SKY
        s_buf[too_far] = np.inf
        hit = mat != MATERIAL_SKY
        s_fin = np.where(hit, s_buf, 0.0)
        xyz = np.column_stack([ox + s_fin * ca, oy + s_fin * sa, oz + s_fin * tan]).astype(np.float32)
        xyz[~hit] = np.nan
        tex = np.column_stack([np.floor(xyz[:, 0] / self.res), np.floor(xyz[:, 1] / self.res)])
        tex = np.where(hit[:, None], tex, 0).astype(np.int32)
        label = np.take(self.mat_label, np.maximum(mat, 0))
        label[~hit] = LABEL_SKY
        rng3 = np.where(hit, s_buf * np.sqrt(1.0 + tan * tan), np.inf)
        return Hits(s=s_buf.astype(np.float32).reshape(shape), rng=rng3.astype(np.float32).reshape(shape),
                    xyz=xyz.reshape(shape + (3,)), label=label.reshape(shape), material=mat.reshape(shape),
                    normal=normal.astype(np.float32).reshape(shape + (3,)), tex=tex.reshape(shape + (2,)),
                    riser=(riser & hit).reshape(shape))

    # solids -----------------------------------------------------------------------------

    def _cast_solids(self, ctx: "_Ctx", ox: float, oy: float, az_mid: float, az_half: float, rmax: float) -> None:
        """Intersect every solid in view [m, rad] into the depth buffer of `ctx` (in order: posts and trunks, crowns, prisms, actors)."""
        # thin solids matter less far away: posts and trunks to 60 m, crowns to 100 m, buildings to `reach`
        rays = (ctx.ox, ctx.oy, ctx.oz, ctx.ca, ctx.sa, ctx.tan, ctx.neg_tan)
        buffers = (ctx.s, ctx.mat, ctx.normal, ctx.tex)
        vis = self._visible(self.cylinders, self.cylinders[:, 2], ox, oy, az_mid, az_half, min(rmax, max(60.0, self.max_range)))
        cast_cylinders(*rays, np.ascontiguousarray(self.cylinders[vis]), *buffers)
        vis = self._visible(self.ellipsoids, self.ellipsoids[:, 3], ox, oy, az_mid, az_half, min(rmax, max(100.0, self.max_range)))
        cast_ellipsoids(*rays, np.ascontiguousarray(self.ellipsoids[vis]), *buffers)
        neg_az = ctx.neg_az if ctx.neg_az is not None else _NO_AZ
        if len(self.prisms):
            vis = self._visible(self._prism_centre, self._prism_radius, ox, oy, az_mid, az_half, rmax)
            self._prism_table.cast(rays, neg_az, ctx.az_mid, vis, buffers)
        if self._actor_table is not None:  # objects not on the map (vehicle_sim.actors)
            self._actor_table.cast(rays, neg_az, ctx.az_mid, np.arange(len(self._actor_solids)), buffers)

    def _visible(self, centres: np.ndarray, radii: np.ndarray, ox: float, oy: float,
                 az_mid: float, az_half: float, reach: float) -> np.ndarray:
        """Return indices of round-bounded solids within range and within the azimuth window [rad]."""
        if len(centres) == 0:
            return np.zeros(0, np.int64)
        dx = centres[:, 0] - ox
        dy = centres[:, 1] - oy
        d = np.hypot(dx, dy)
        bearing = np.arctan2(dy, dx)
        off = np.abs(wrap_angle(bearing - az_mid))
        spread = np.arcsin(np.clip(radii / np.maximum(d, 1e-9), 0.0, 1.0))
        keep = (d - radii < reach) & ((d <= radii) | (off <= az_half + spread))
        return np.flatnonzero(keep)

    # ---------------------------------------------------------------- appearance

    def albedo(self, hits: Hits, stamp: float = 0.0) -> np.ndarray:
        """Return the full-sun colour of every hit at sim time `stamp` [s], (H, W, 3) float32 sRGB [0–255] (sky: 0).

        Each surface's appearance with its texture; with weather, wet patches and leaves on the ground covers.
        """
        m = np.maximum(hits.material, 0)
        idx = (hits.tex[..., 1] & (_TILE - 1)) * _TILE + (hits.tex[..., 0] & (_TILE - 1))
        noise = np.take(self._tile_flat, idx, axis=0)  # (H, W, 3)
        col = np.take(self.mat_mean, m, axis=0)
        col += np.take(self.mat_std, m, axis=0) * noise
        if self.paint is not None:
            self.paint.paint(col, hits.xyz, np.take(self._mat_painted, m) & (hits.material != MATERIAL_SKY), noise)
        if self.weather is not None:
            self._apply_weather(col, hits, noise, stamp)
        np.copyto(col, np.float32(0.0), where=(hits.material == MATERIAL_SKY)[..., None])
        return col

    def sun_factor(self, hits: Hits) -> np.ndarray:
        """Return the direct-sun factor of every hit relative to flat open ground, (H, W) float32 [0–1.3].

        Every surface takes Lambert's cosine against the sun, normalised so flat ground in full sun
        gives 1; the ground and low solids (posts, trunks) also take the rasterised ground shadows.
        """
        sun = self.sun.astype(np.float32)
        lam = hits.normal @ (sun / np.float32(max(float(sun[2]), 1e-3)))
        np.clip(lam, 0.0, 1.3, out=lam)
        mat = hits.material.reshape(-1)
        sel = np.flatnonzero(np.take(self._mat_ground_shadow, np.maximum(mat, 0)) & (mat != MATERIAL_SKY))
        xyz = np.take(hits.xyz.reshape(-1, 3), sel, axis=0)
        flat = lam.reshape(-1)
        flat[sel] = np.take(flat, sel) * (np.take(self._sunlit_flat, self._flat_index(xyz[:, 0], xyz[:, 1])).astype(np.float32)
                                          * np.float32(1.0 / 255.0))
        return lam


_NO_AZ = np.zeros(0, np.float64)


@dataclass(frozen=True)
class _PrismTable:
    """Vertical prisms packed for `solid_cast.cast_prisms`: footprint k is `verts[start[k]:start[k + 1]]` [m]."""

    verts: np.ndarray  # (Σ M, 2) float64
    start: np.ndarray  # (n + 1,) int64
    edges: np.ndarray  # (Σ M, 2) edge vectors, vertex to next [m]
    edges_unit: np.ndarray  # (Σ M, 2)
    z_bottom: np.ndarray  # (n,) [m]
    z_top: np.ndarray  # (n,) [m]
    material: np.ndarray  # (n,) int32

    @classmethod
    def pack(cls, prisms: "list | tuple") -> "_PrismTable":
        """Pack (verts (M, 2), z_bottom, z_top, material) tuples."""
        verts = [np.asarray(p[0], np.float64).reshape(-1, 2) for p in prisms]
        edges = [_edges(v) for v in verts]
        cat = lambda xs: np.ascontiguousarray(np.concatenate(xs)) if xs else np.zeros((0, 2))  # noqa: E731
        return cls(cat(verts), np.concatenate([[0], np.cumsum([len(v) for v in verts])]).astype(np.int64),
                   cat([e[0] for e in edges]), cat([e[1] for e in edges]),
                   np.array([float(p[1]) for p in prisms], np.float64), np.array([float(p[2]) for p in prisms], np.float64),
                   np.array([int(p[3]) for p in prisms], np.int32))

    def cast(self, rays: tuple, neg_az: np.ndarray, az_mid: float, which: np.ndarray, buffers: tuple) -> None:
        """Intersect the prisms `which` (indices) with the rays into the depth buffers (see `cast_prisms`)."""
        cast_prisms(*rays, neg_az, float(az_mid), np.asarray(which, np.int64), self.verts, self.start, self.edges,
                    self.edges_unit, self.z_bottom, self.z_top, self.material, *buffers)


def _edges(verts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return a footprint's edge vectors (M, 2) [m] (vertex k to k+1) and the same as unit vectors."""
    e = np.roll(verts, -1, axis=0) - verts
    return e, e / np.linalg.norm(e, axis=1, keepdims=True)


def _take_pairs(a: np.ndarray, flat_idx: np.ndarray) -> np.ndarray:
    """Return the (n, 2) int32 pairs of an (..., 2) int32 array at flat cell indices (one 8-byte gather)."""
    return np.take(np.ascontiguousarray(a).view(np.int64).reshape(-1), flat_idx).view(np.int32).reshape(-1, 2)


@dataclass
class _Ctx:
    ox: float
    oy: float
    oz: float
    ca: np.ndarray
    sa: np.ndarray
    tan: np.ndarray
    neg_tan: np.ndarray
    neg_az: np.ndarray | None  # minus the world azimuths of the columns when they descend (ascending) [rad]
    az_mid: float
    s: np.ndarray
    mat: np.ndarray
    normal: np.ndarray
    tex: np.ndarray
