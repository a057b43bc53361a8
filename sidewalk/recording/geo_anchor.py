"""The recording's geodetic anchor: `world` [m] (x east, y north) to WGS84 longitude/latitude [deg], as GeoJSON.

The simulated worlds have no geodetic reference; Foxglove's Map panel (topic schema `foxglove.GeoJSON`)
wants longitude/latitude. A recording places `world`'s origin at a nominal point near Schenley Park,
Pittsburgh (where the Terregator drove), with a local equirectangular projection — exact to
millimetres over a campus. The anchor is written into the recording's metadata (`geo_origin`).
"""

from __future__ import annotations

import json
import math
from typing import Any, Iterable, Sequence

from sidewalk.recording.foxglove import GeoJSON

__all__ = ["GEO_ORIGIN", "lonlat", "map_geojson", "annotations_geojson"]

#: (latitude, longitude) [deg] of `world`'s origin.
GEO_ORIGIN = (40.4432, -79.9428)
_R = 6378137.0  # WGS84 equatorial radius [m]


def lonlat(x: float, y: float, origin: tuple[float, float] = GEO_ORIGIN) -> list[float]:
    """Return [longitude, latitude] [deg] of `world` point (x east, y north) [m]."""
    lat0, lon0 = origin
    lat = lat0 + math.degrees(y / _R)
    lon = lon0 + math.degrees(x / (_R * math.cos(math.radians(lat0))))
    return [round(lon, 9), round(lat, 9)]


def _convert(coords: Any) -> Any:
    if isinstance(coords, (list, tuple)) and len(coords) >= 2 and all(isinstance(c, (int, float)) for c in coords[:2]):
        return lonlat(float(coords[0]), float(coords[1]))
    if isinstance(coords, (list, tuple)):
        return [_convert(c) for c in coords]
    return coords


def _collection(features: Iterable[dict]) -> GeoJSON:
    return GeoJSON(geojson=json.dumps({"type": "FeatureCollection", "features": list(features)}, separators=(",", ":")))


def map_geojson(geojson: dict) -> GeoJSON:
    """Return a map or world FeatureCollection (`world` [m]) in WGS84, every feature's properties kept."""
    out = []
    for f in geojson.get("features") or ():
        g = f.get("geometry") if isinstance(f, dict) else None
        if not isinstance(g, dict) or "coordinates" not in g:
            continue
        props = f.get("properties") if isinstance(f.get("properties"), dict) else {}
        out.append({"type": "Feature", "geometry": {"type": g.get("type"), "coordinates": _convert(g["coordinates"])},
                    "properties": {k: v for k, v in props.items() if isinstance(v, (str, int, float, bool))}})
    return _collection(out)


def annotations_geojson(annotations: Sequence[dict], points_of_annotation: Any) -> GeoJSON:
    """Return EDDIE's annotations in WGS84: a Point, LineString or Polygon each, with id, type, destination, text."""
    out = []
    for i, a in enumerate(annotations):
        pts = points_of_annotation(a)
        if not pts:
            continue
        ll = [lonlat(x, y) for x, y in pts]
        kind = a.get("kind")
        if len(ll) == 1:
            geom = {"type": "Point", "coordinates": ll[0]}
        elif kind == "polygon" or (kind is None and len(ll) > 2 and ll[0] == ll[-1]):
            geom = {"type": "Polygon", "coordinates": [ll if ll[0] == ll[-1] else ll + [ll[0]]]}
        else:
            geom = {"type": "LineString", "coordinates": ll}
        out.append({"type": "Feature", "geometry": geom,
                    "properties": {"id": str(a.get("id", f"a{i}")), "type": str(a.get("type", "")),
                                   "destination": str(a.get("destination", "")), "text": str(a.get("text", ""))}})
    return _collection(out)
