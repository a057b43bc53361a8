"""DRIVING MONITOR core: break a route segment's path into driving units PERCEPTION can see at once.

All geometry is in the `world` frame [m]. A driving unit says where (a stretch of the path, its
corridor polygon, the pose to look from) and what (the ids of the objects expected in it) —
never how to detect them (seed: Sidewalk §2.3.3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from pydantic import BaseModel, ConfigDict, Field
from shapely.geometry import LineString
from shapely.geometry.base import BaseGeometry

from modules.pilot.polyline import PathLine

__all__ = ["DrivingUnitConfig", "DrivingUnitSpan", "ExpectedObject", "split_segment"]


class DrivingUnitConfig(BaseModel):
    """How the DRIVING MONITOR cuts a segment: unit length [m], corridor half-width [m], view offset [m]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    unit_length: float = Field(6.0, gt=0.5, description="nominal driving unit length along the path [m]")
    min_length: float = Field(2.0, gt=0.0, description="a shorter tail is merged into the previous unit [m]")
    corridor_half_width: float = Field(6.0, gt=0.0, description="half-width of the window clipping the path region [m]")
    view_offset: float = Field(4.0, ge=0.0, description="look from this far before the unit's near edge [m]")
    object_range: float = Field(8.0, ge=0.0, description="objects this close to the unit are expected in it [m]")


@dataclass(frozen=True)
class ExpectedObject:
    """An object the segment description names, as the DRIVING MONITOR sees it: id and world geometry."""

    object_id: str
    geometry: BaseGeometry


@dataclass(frozen=True)
class DrivingUnitSpan:
    """One driving unit: index, arc-length span [m], centerline (M,2) [m], region polygon, view pose, objects."""

    index: int
    s_start: float
    s_end: float
    centerline: np.ndarray
    region: BaseGeometry
    view_pose: tuple[float, float, float]
    far_pose: tuple[float, float, float]
    object_ids: tuple[str, ...]
    last: bool

    @property
    def length(self) -> float:
        """Return the unit's length along the path [m]."""
        return self.s_end - self.s_start


def _breaks(length: float, cfg: DrivingUnitConfig) -> list[float]:
    n = max(1, int(math.floor(length / cfg.unit_length)))
    if length - n * cfg.unit_length >= cfg.min_length:
        n += 1
    n = max(1, n)
    # Equal pieces, each within [min_length, unit_length + min_length).
    return [length * i / n for i in range(n + 1)]


def split_segment(
    path: PathLine,
    region: BaseGeometry,
    objects: tuple[ExpectedObject, ...] = (),
    cfg: DrivingUnitConfig = DrivingUnitConfig(),
) -> list[DrivingUnitSpan]:
    """Split a segment's path (world [m]) into driving units over its navigable `region` polygon."""
    bks = _breaks(path.length, cfg)
    units: list[DrivingUnitSpan] = []
    for i in range(len(bks) - 1):
        s0, s1 = bks[i], bks[i + 1]
        cl = path.slice(s0, s1)
        window = LineString(cl).buffer(cfg.corridor_half_width, cap_style="flat")
        # A little beyond the far edge so consecutive unit regions overlap (no seams for the planner).
        ext = LineString(path.slice(max(0.0, s0 - 0.5), min(path.length, s1 + 0.5))).buffer(
            cfg.corridor_half_width, cap_style="flat"
        )
        if i == 0 or i == len(bks) - 2:
            # The segment's ends: keep the region beyond them (round caps), so a goal at the very
            # end still fits once the margin is taken off.
            ext = shapely.union(ext, LineString(cl).buffer(cfg.corridor_half_width))
        piece = shapely.intersection(region, shapely.union(window, ext))
        if piece.is_empty:
            piece = window
        sv = max(0.0, s0 - cfg.view_offset)
        pv = path.point_at(sv)
        pf = path.point_at(s1)
        near = LineString(cl).buffer(cfg.object_range)
        ids = tuple(o.object_id for o in objects if o.geometry.intersects(near))
        units.append(
            DrivingUnitSpan(
                index=i,
                s_start=s0,
                s_end=s1,
                centerline=cl,
                region=piece,
                view_pose=(float(pv[0]), float(pv[1]), path.heading_at(sv)),
                far_pose=(float(pf[0]), float(pf[1]), path.heading_at(max(0.0, s1 - 1e-6))),
                object_ids=ids,
                last=i == len(bks) - 2,
            )
        )
    return units
