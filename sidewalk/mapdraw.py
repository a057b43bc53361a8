"""Map and world GeoJSON (as `sim/map` and `sim/world` serve it) as drawable outlines, for the monitor and recordings.

Coordinates stay in the `world` frame [m]; each feature keeps its id, kind, role and a display
colour (its mean colour where the file gives one, else one per kind).
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import BaseModel, ConfigDict

__all__ = ["DrawnFeature", "drawable_features", "KIND_RGB"]

#: Display colour [0–255] per kind, for features without a mean colour.
KIND_RGB: dict[str, tuple[int, int, int]] = {
    "sidewalk": (200, 200, 200), "road": (110, 110, 120), "intersection": (170, 170, 220), "grass": (80, 140, 70),
    "building": (160, 90, 70), "stairs": (220, 80, 200), "slope": (230, 170, 60), "tree": (40, 110, 40),
    "edge": (90, 140, 230), "node": (90, 140, 230), "driveway": (170, 140, 110),
}
_DEFAULT_RGB = (150, 150, 150)


class DrawnFeature(BaseModel):
    """One outline: `shape` polygon (ring, not closed), line, or point; points (x [m], y [m]) in `world`."""

    model_config = ConfigDict(frozen=True)

    id: str
    kind: str
    role: str = ""
    shape: Literal["polygon", "line", "point"]
    points: tuple[tuple[float, float], ...]
    rgb: tuple[int, int, int]
    radius: float = 0.0


def _rgb(props: dict[str, Any], kind: str) -> tuple[int, int, int]:
    mean = (props.get("colour") or {}).get("mean") if isinstance(props.get("colour"), dict) else None
    if kind in KIND_RGB or not (isinstance(mean, (list, tuple)) and len(mean) == 3):
        return KIND_RGB.get(kind, _DEFAULT_RGB)
    return tuple(int(max(0, min(255, c))) for c in mean)  # type: ignore[return-value]


def drawable_features(geojson: dict[str, Any]) -> list[DrawnFeature]:
    """Return the drawable outlines of a GeoJSON FeatureCollection (unknown geometry types skipped)."""
    out: list[DrawnFeature] = []
    for i, f in enumerate(geojson.get("features") or ()):
        if not isinstance(f, dict):
            continue
        g = f.get("geometry") or {}
        props = f.get("properties") or {}
        kind = str(props.get("kind", "?"))
        fid = str(props.get("id", f"f{i}"))
        role = str(props.get("role", ""))
        rgb = _rgb(props, kind)
        t, c = g.get("type"), g.get("coordinates")
        try:
            if t == "Polygon" and c:
                ring = [(float(p[0]), float(p[1])) for p in c[0]]
                if len(ring) > 1 and ring[0] == ring[-1]:
                    ring = ring[:-1]
                out.append(DrawnFeature(id=fid, kind=kind, role=role, shape="polygon", points=tuple(ring), rgb=rgb))
            elif t == "LineString" and c:
                out.append(DrawnFeature(id=fid, kind=kind, role=role, shape="line",
                                        points=tuple((float(p[0]), float(p[1])) for p in c), rgb=rgb))
            elif t == "Point" and c:
                r = props.get("radius", (props.get("shape") or {}).get("crown_radius", 0.3) if isinstance(props.get("shape"), dict) else 0.3)
                out.append(DrawnFeature(id=fid, kind=kind, role=role, shape="point", points=((float(c[0]), float(c[1])),),
                                        rgb=rgb, radius=float(r or 0.3)))
        except (TypeError, ValueError, IndexError):
            continue  # a malformed feature is not drawn
    # big areas first, so smaller objects are drawn over them
    order = {"grass": 0, "road": 1, "driveway": 1, "sidewalk": 2, "intersection": 2, "stairs": 3, "slope": 3}
    out.sort(key=lambda d: (0 if d.shape == "polygon" else 1, order.get(d.kind, 4)))
    return out
