"""The annotation: the seed's uniform header (§3.2) plus opaque data the manager never interprets.

Header: `type`, `destination` module, `used` flag, `text` description, `location` (point / line /
polygon in `world` [m]), `next_id` / `previous_id` objects and the data size; `data` is bytes.
What makes an annotation a trigger is its `trigger` field:

- `none`: a plain map annotation (answered by queries only);
- `cross`: fires when the travelled line meets its location (a point within `reach` [m]);
- `enter` / `leave`: a polygon that fires when the vehicle passes from outside to inside / inside to
  outside.

`refire` lets a trigger fire again after the vehicle went back over it (see `triggers`).
"""

from __future__ import annotations

import math
from typing import Literal

import shapely
from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

__all__ = ["Location", "Annotation", "TriggerMode", "LocationKind"]

LocationKind = Literal["point", "line", "polygon"]
TriggerMode = Literal["none", "cross", "enter", "leave"]


class Location(BaseModel):
    """Where an annotation is, in `world` [m]: one point, a line (≥ 2 points) or a polygon ring (≥ 3 points, open)."""

    model_config = ConfigDict(frozen=True)

    kind: LocationKind
    points: tuple[tuple[float, float], ...]

    @model_validator(mode="after")
    def _check(self) -> "Location":
        need = {"point": 1, "line": 2, "polygon": 3}[self.kind]
        if self.kind == "point" and len(self.points) != 1:
            raise ValueError("a point location has exactly one point")
        if len(self.points) < need:
            raise ValueError(f"a {self.kind} location needs at least {need} points, got {len(self.points)}")
        if not all(math.isfinite(c) for p in self.points for c in p):
            raise ValueError("coordinates must be finite")
        return self

    @classmethod
    def point(cls, x: float, y: float) -> "Location":
        """Return a point location at (x, y) [m] `world`."""
        return cls(kind="point", points=((float(x), float(y)),))

    @classmethod
    def line(cls, pts) -> "Location":
        """Return a line location through `pts` [(x, y)] [m] `world`."""
        return cls(kind="line", points=tuple((float(x), float(y)) for x, y in pts))

    @classmethod
    def polygon(cls, pts) -> "Location":
        """Return a polygon location with ring `pts` [(x, y)] [m] `world` (open or closed)."""
        pts = [(float(x), float(y)) for x, y in pts]
        if len(pts) > 3 and pts[0] == pts[-1]:
            pts = pts[:-1]
        return cls(kind="polygon", points=tuple(pts))

    def geometry(self) -> shapely.Geometry:
        """Return the location as a shapely geometry in `world` [m]."""
        if self.kind == "point":
            return shapely.Point(self.points[0])
        if self.kind == "line":
            return shapely.LineString(self.points)
        return shapely.Polygon(self.points)

    def bounds(self) -> tuple[float, float, float, float]:
        """Return (xmin, ymin, xmax, ymax) [m] `world`."""
        xs = [p[0] for p in self.points]
        ys = [p[1] for p in self.points]
        return min(xs), min(ys), max(xs), max(ys)


class Annotation(BaseModel):
    """One annotation: the seed's uniform header and its opaque `data`."""

    model_config = ConfigDict(frozen=True)

    id: str = Field(min_length=1)
    type: str = Field(min_length=1)
    destination: str = ""
    used: bool = False
    text: str = ""
    location: Location
    next_id: str | None = None
    previous_id: str | None = None
    trigger: TriggerMode = "none"
    refire: bool = False
    reach: float = Field(default=0.0, ge=0.0)
    data: bytes = b""

    @property
    def data_size(self) -> int:
        """Return the size of `data` [bytes] (the header's data size)."""
        return len(self.data)

    @model_validator(mode="after")
    def _check(self) -> "Annotation":
        if self.trigger in ("enter", "leave") and self.location.kind != "polygon":
            raise ValueError(f"an {self.trigger} trigger needs a polygon location, not a {self.location.kind}")
        if self.trigger != "none" and not self.destination:
            raise ValueError("a trigger needs a destination module")
        return self

    @field_validator("reach")
    @classmethod
    def _finite_reach(cls, v: float) -> float:
        if not math.isfinite(v):
            raise ValueError("reach must be finite")
        return v

    def with_used(self, used: bool) -> "Annotation":
        """Return a copy with the `used` flag set to `used`."""
        return self.model_copy(update={"used": used})
