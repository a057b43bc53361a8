"""EDDIE's current route segment for a recording: the `route` annotation the believed pose is on, as `/scene/segment`.

The believed pose is the navigator's world←local ∘ the controller's local pose (the newest of each,
as the recorder hears them); the segment is chosen by `sidewalk.annotated_route.AnnotatedRoute`.
"""

from __future__ import annotations

from typing import Optional

from sidewalk.annotated_route import AnnotatedRoute, route_legs
from sidewalk.recording.derive import Derived, segment_scene
from sidewalk.values import num
from wire.se2 import compose

__all__ = ["EddieSegment"]


class EddieSegment:
    """Follow EDDIE's route along its streams; say when the current segment changes."""

    def __init__(self) -> None:
        self.route = AnnotatedRoute()
        self._w: Optional[tuple[float, float, float]] = None
        self._current: Optional[str] = None

    def set_annotations(self, annotations: list[dict]) -> None:
        """Take the map manager's annotations (the `route` ones are the route)."""
        self.route = AnnotatedRoute(route_legs(annotations))

    def on_stream(self, stream: str, v: dict, t: float) -> list[Derived]:
        """Handle EDDIE stream `stream` (e.g. "controller/state") at sim time `t` [s]; return a new segment, if any."""
        if stream == "navigator/world_from_local":
            self._w = (num(v.get("x")), num(v.get("y")), num(v.get("yaw")))
            return []
        if stream != "controller/state" or self._w is None or not self.route.legs:
            return []
        x, y, _ = compose(self._w, (num(v.get("x")), num(v.get("y")), num(v.get("yaw"))))
        leg = self.route.locate(float(x), float(y))
        if leg is None or leg.id == self._current:
            return []
        self._current = leg.id
        return [Derived("/scene/segment", "foxglove.SceneUpdate", segment_scene(leg.points, leg.width_m, t,
                                                                                 meta={"segment_id": leg.id, "mode": leg.mode}), t)]
