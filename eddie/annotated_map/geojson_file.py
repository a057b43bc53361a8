"""Annotated map files: a GeoJSON FeatureCollection, one feature per annotation.

Plain RFC 7946 that QGIS or any GeoJSON tool opens. Coordinates are **not** longitude/latitude:
they are the `world` frame in metres (x east, y north), as in the world and map files; no `crs`
member is written (RFC 7946 dropped it), so a GIS shows them as a local planar layer. The header
fields are the feature's properties (`id`, `type`, `destination`, `used`, `text`, `next_id`,
`previous_id`, `trigger`, `refire`, `reach`, `data_size`) and the opaque data is `data_base64`.
A Point / LineString / Polygon geometry is the location (a polygon's ring is closed in the file).
Every error names the file, the feature (index and id) and the field.
"""

from __future__ import annotations

import base64
import binascii
import json
from pathlib import Path
from typing import Any, Iterable

from pydantic import ValidationError

from eddie.annotated_map.annotation import Annotation, Location
from eddie.annotated_map.errors import AnnotationFileError

__all__ = ["load_annotations", "save_annotations", "annotations_to_geojson", "annotations_from_geojson"]

_GEOM = {"point": "Point", "line": "LineString", "polygon": "Polygon"}
_KIND = {v: k for k, v in _GEOM.items()}
_PROPS = ("id", "type", "destination", "used", "text", "next_id", "previous_id", "trigger", "refire", "reach")


def _feature(a: Annotation) -> dict[str, Any]:
    pts = [list(p) for p in a.location.points]
    if a.location.kind == "point":
        coords: Any = pts[0]
    elif a.location.kind == "line":
        coords = pts
    else:
        coords = [pts + [pts[0]]]
    props = {k: getattr(a, k) for k in _PROPS}
    props["data_size"] = a.data_size
    props["data_base64"] = base64.b64encode(a.data).decode("ascii")
    return {"type": "Feature", "id": a.id, "geometry": {"type": _GEOM[a.location.kind], "coordinates": coords},
            "properties": props}


def annotations_to_geojson(annotations: Iterable[Annotation], *, name: str = "") -> dict[str, Any]:
    """Return the annotations as a GeoJSON FeatureCollection (coordinates: `world` [m])."""
    fc: dict[str, Any] = {"type": "FeatureCollection", "features": [_feature(a) for a in annotations]}
    if name:
        fc["name"] = name
    return fc


def save_annotations(path: str | Path, annotations: Iterable[Annotation], *, name: str = "") -> None:
    """Write the annotations to GeoJSON file `path` (atomically: a temporary file, then rename)."""
    p = Path(path)
    tmp = p.with_name(p.name + ".tmp")
    tmp.write_text(json.dumps(annotations_to_geojson(annotations, name=name), indent=1) + "\n")
    tmp.replace(p)


def _location(src: str, i: int, fid: str | None, geom: Any) -> Location:
    def bad(text: str, field: str = "geometry") -> AnnotationFileError:
        return AnnotationFileError(src, text, feature=i, feature_id=fid, field=field)

    if not isinstance(geom, dict):
        raise bad("missing or not an object")
    kind = _KIND.get(geom.get("type"))  # type: ignore[arg-type]
    if kind is None:
        raise bad(f"type {geom.get('type')!r} is not Point, LineString or Polygon", "geometry.type")
    c = geom.get("coordinates")
    try:
        if kind == "point":
            pts = [c]
        elif kind == "line":
            pts = list(c)
        else:
            if not isinstance(c, list) or not c:
                raise TypeError
            if len(c) > 1:
                raise bad("polygons with holes are not annotations", "geometry.coordinates")
            pts = list(c[0])
        xy = [(float(p[0]), float(p[1])) for p in pts]
    except AnnotationFileError:
        raise
    except (TypeError, ValueError, IndexError, KeyError):
        raise bad(f"coordinates are not a {geom.get('type')} of [x, y] numbers", "geometry.coordinates") from None
    try:
        if kind == "point":
            return Location.point(*xy[0])
        return Location.line(xy) if kind == "line" else Location.polygon(xy)
    except ValidationError as e:
        raise bad(e.errors()[0]["msg"], "geometry.coordinates") from None


def annotations_from_geojson(doc: Any, *, source: str = "<annotated map>") -> list[Annotation]:
    """Return the annotations of a parsed GeoJSON FeatureCollection (errors name `source`, feature and field)."""
    if not isinstance(doc, dict) or doc.get("type") != "FeatureCollection":
        raise AnnotationFileError(source, "not a GeoJSON FeatureCollection", field="type")
    feats = doc.get("features")
    if not isinstance(feats, list):
        raise AnnotationFileError(source, "missing or not a list", field="features")
    out: list[Annotation] = []
    seen: dict[str, int] = {}
    for i, f in enumerate(feats):
        if not isinstance(f, dict) or f.get("type") != "Feature":
            raise AnnotationFileError(source, "not a GeoJSON Feature", feature=i, field="type")
        props = f.get("properties")
        if not isinstance(props, dict):
            raise AnnotationFileError(source, "missing or not an object", feature=i, field="properties")
        fid = props.get("id", f.get("id"))
        fid = str(fid) if fid is not None else None
        if fid is None:
            raise AnnotationFileError(source, "every annotation needs an id", feature=i, field="properties.id")
        if fid in seen:
            raise AnnotationFileError(source, f"id also used by feature {seen[fid]}", feature=i, feature_id=fid,
                                      field="properties.id")
        seen[fid] = i
        loc = _location(source, i, fid, f.get("geometry"))
        raw = props.get("data_base64", "")
        try:
            data = base64.b64decode(raw if isinstance(raw, str) else "\0", validate=True)
        except (binascii.Error, ValueError):
            raise AnnotationFileError(source, "not valid base64", feature=i, feature_id=fid,
                                      field="properties.data_base64") from None
        if "data_size" in props and props["data_size"] != len(data):
            raise AnnotationFileError(source, f"says {props['data_size']} but the data holds {len(data)} bytes",
                                      feature=i, feature_id=fid, field="properties.data_size")
        fields = {k: props[k] for k in _PROPS if k in props and props[k] is not None}
        fields["id"] = fid
        try:
            out.append(Annotation(location=loc, data=data, **fields))
        except ValidationError as e:
            err = e.errors()[0]
            loc_f = ".".join(str(p) for p in err["loc"])
            raise AnnotationFileError(source, err["msg"], feature=i, feature_id=fid,
                                      field=f"properties.{loc_f}" if loc_f else "properties") from None
    return out


def load_annotations(path: str | Path) -> list[Annotation]:
    """Read the annotations of GeoJSON file `path` (raises AnnotationFileError naming file, feature and field)."""
    src = str(path)
    try:
        text = Path(path).read_text()
    except OSError as e:
        raise AnnotationFileError(src, f"cannot read: {e.strerror or e}") from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as e:
        raise AnnotationFileError(src, f"not JSON: {e.msg} at line {e.lineno}, column {e.colno}") from None
    return annotations_from_geojson(doc, source=src)
