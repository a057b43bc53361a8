"""PERCEPTION's road method for follow-road driving units (issue 13): a road follower's road as the navigable region.

With `--road-method scarf|yarf|alvinn` the colored-range pipeline still matches the map objects
and calibrates the position; the road the follower finds in the same capture replaces the
pipeline's navigable region of a follow-road unit. The follower is kept across units and starts
afresh on each new route segment (a new road after an intersection), bootstrapped on where the
vehicle stands across the map's road (the seed's one external input). Polygons are in the
`vehicle` frame at capture, as the pipeline's are.
"""

from __future__ import annotations

import dataclasses

from shapely.ops import unary_union
from shapely.geometry import Polygon as ShapelyPolygon

from modules.perception.pipeline import PipelineOutput
from modules.perception.sensor_frame import SensorFrame
from modules.road_following import CameraGeometry, CameraRoadFollower, RoadObservation, cross_section, road_region
from modules.vocabulary import DrivingUnitDescription

__all__ = ["RoadMethodPerception"]


class RoadMethodPerception:
    """A road follower serving PERCEPTION's follow-road units (see module docstring)."""

    def __init__(self, follower: CameraRoadFollower, *, near_m: float = 1.0, far_m: float = 20.0) -> None:
        """Use `follower`; the region reaches from `near_m` to `far_m` [m] ahead of the vehicle at capture."""
        self.follower = follower
        self.near_m, self.far_m = near_m, far_m
        self.segment_id: str | None = None
        self.half_width_m = follower.road_width_m / 2.0

    def _bootstrap(self, unit: DrivingUnitDescription, prior: tuple[float, float, float]) -> None:
        roads = [ShapelyPolygon(o.polygon) for o in unit.objects if o.kind == "road" and o.polygon is not None]
        cut = cross_section(unary_union(roads), prior) if roads else None
        if cut is not None:
            self.follower.road_width_m = cut[1]
            self.half_width_m = cut[1] / 2.0
        self.follower.reset(0.0 if cut is None else cut[0])
        self.segment_id = unit.segment_id

    def observe(self, unit: DrivingUnitDescription, frame: SensorFrame, prior: tuple[float, float, float]) -> RoadObservation:
        """Return the follower's road in the capture; `prior` is world←vehicle at capture."""
        if unit.segment_id != self.segment_id:
            self._bootstrap(unit, prior)
        return self.follower.observe(frame.camera_image, CameraGeometry.from_capture(frame), prior, stamp=frame.stamp)

    def replace_navigable(self, out: PipelineOutput, obs: RoadObservation) -> PipelineOutput:
        """Return the pipeline's output with the follower's road as its navigable region; NoRoadSeen when it saw none."""
        region = road_region(obs, half_width_m=self.half_width_m, near_m=self.near_m, far_m=self.far_m)
        return dataclasses.replace(out, navigable=region, failure="")
