"""Foxglove views of the system's messages: poses as `FrameTransform`, map and paths as `SceneUpdate`.

`derive_sample(rel_key, value, t)` and `derive_token(event, token, t)` return the Foxglove messages
(topic, schema name, message, sim stamp [s]) a recorded message implies, so that Foxglove Studio or
Rerun shows the run without Sidewalk's code. Frames: `world`; `local` and `vehicle` as the robot
estimates them (world→local from the PILOT or EDDIE's navigator, local→vehicle from the HELM or
EDDIE's controller); `vehicle_truth` for the simulator's true pose (evaluation only).
"""

from __future__ import annotations

from typing import Any, Iterable, NamedTuple

from pydantic import BaseModel

from sidewalk.mapdraw import drawable_features
from sidewalk.values import num as _num, points_of
from sidewalk.recording.foxglove import (
    CompressedImage, KeyValuePair, Pose, SceneEntity, SceneEntityDeletion, SceneUpdate, SpherePrimitive, TextPrimitive,
    Time, Vector3, frame_transform, line, rgba,
)

__all__ = ["Derived", "derive_sample", "derive_token", "map_scene", "annotation_scene", "route_scene", "segment_scene", "TF_TOPIC", "TRUTH_TF_TOPIC",
           "STATIC_TF_TOPIC", "annotation_points"]

TF_TOPIC = "/tf"
TRUTH_TF_TOPIC = "/tf/truth"
STATIC_TF_TOPIC = "/tf_static"
_FT = "foxglove.FrameTransform"
_SU = "foxglove.SceneUpdate"
_CI = "foxglove.CompressedImage"


class Derived(NamedTuple):
    """One Foxglove message to write: topic, schema name, message, sim stamp [s]."""

    topic: str
    schema: str
    message: BaseModel
    stamp: float


_UNIT_RGB = {"pending": rgba(1.0, 0.8, 0.1), "perceived": rgba(0.1, 0.8, 0.3), "failed": rgba(0.9, 0.1, 0.1),
             "cancelled": rgba(0.5, 0.5, 0.5, 0.5)}


def _entity(t: float, frame: str, eid: str, lines=(), texts=(), spheres=(), meta: dict | None = None) -> SceneEntity:
    return SceneEntity(timestamp=Time.of(t), frame_id=frame, id=eid, lines=tuple(lines), texts=tuple(texts),
                       spheres=tuple(spheres),
                       metadata=tuple(KeyValuePair(key=k, value=str(v)) for k, v in (meta or {}).items()))


def _scene(t: float, entities: Iterable[SceneEntity] = (), deletions: Iterable[str] = ()) -> SceneUpdate:
    return SceneUpdate(entities=tuple(entities),
                       deletions=tuple(SceneEntityDeletion(timestamp=Time.of(t), type=0, id=d) for d in deletions))


def map_scene(geojson: dict, t: float, *, truth: bool = False) -> SceneUpdate:
    """Return the map (or, with `truth`, the world) as outlines in `world` (one entity per feature)."""
    ents = []
    for f in drawable_features(geojson):
        c = rgba(*(v / 255.0 for v in f.rgb), 0.6 if truth else 1.0)
        if f.shape == "point":
            x, y = f.points[0]
            d = max(0.2, 2.0 * f.radius)
            ents.append(_entity(t, "world", f.id, spheres=[SpherePrimitive(
                pose=Pose(position=Vector3(x=x, y=y, z=0.0)), size=Vector3(x=d, y=d, z=0.2), color=c)],
                meta={"kind": f.kind, "role": f.role}))
        else:
            ents.append(_entity(t, "world", f.id, lines=[line(f.points, c, loop=f.shape == "polygon", thickness=0.08)],
                                meta={"kind": f.kind, "role": f.role}))
    return _scene(t, ents)


def annotation_scene(annotations: list[dict], t: float) -> SceneUpdate:
    """Return EDDIE's annotations (dicts with an id, a type and a point, line or polygon in `world`) as outlines."""
    ents = []
    for i, a in enumerate(annotations):
        pts = annotation_points(a)
        if not pts:
            continue
        c = rgba(0.6, 0.3, 0.9)
        aid = str(a.get("id", a.get("annotation_id", f"a{i}")))
        kind = str(a.get("type", a.get("kind", "")))
        ents.append(_entity(t, "world", aid, lines=[line(pts, c, loop=len(pts) > 2, thickness=0.1)],
                            texts=[TextPrimitive(pose=Pose(position=Vector3(x=pts[0][0], y=pts[0][1], z=0.5)), color=c,
                                                 text=kind)], meta={"type": kind}))
    return _scene(t, ents)


def route_scene(eid: str, points: list[tuple[float, float]], t: float, *, meta: dict | None = None) -> SceneUpdate:
    """Return a route polyline (`world` [m]) as entity `eid` of topic `/scene/route`."""
    return _scene(t, [_entity(t, "world", eid, lines=[line(points, rgba(0.2, 0.4, 1.0), thickness=0.15)], meta=meta)])


def segment_scene(points: list[tuple[float, float]] | tuple, width_m: float, t: float, *, meta: dict | None = None) -> SceneUpdate:
    """Return the current route segment's centreline (`world` [m]) drawn `width_m` [m] wide, as entity "segment"."""
    return _scene(t, [_entity(t, "world", "segment", lines=[line(points, rgba(0.0, 0.9, 1.0), thickness=max(0.1, width_m))],
                              meta=meta)])


def annotation_points(a: dict) -> list[tuple[float, float]]:
    """Return the outline (x, y) [m] of an EDDIE annotation, wherever its location is (tolerant of field names)."""
    for k in ("polygon", "points", "line", "location", "geometry"):
        v = a.get(k)
        if isinstance(v, dict):
            if "points" in v:
                return points_of(v["points"])
            if "coordinates" in v:  # GeoJSON geometry
                c = v["coordinates"]
                if v.get("type") == "Polygon" and c:
                    return points_of(c[0])
                if v.get("type") == "Point":
                    return points_of([c])
                return points_of(c)
            if "x" in v and "y" in v:
                return points_of([v])
        elif isinstance(v, (list, tuple)) and v:
            pts = points_of(v)
            if pts:
                return pts
    if "x" in a and "y" in a:
        return points_of([a])
    return []


def derive_sample(rel_key: str, v: Any, t: float) -> list[Derived]:
    """Return the Foxglove messages implied by a sample of key `rel_key` (below `sidewalk/<ns>/`) with value `v`."""
    out: list[Derived] = []
    if rel_key == "sim/truth" and isinstance(v, dict):
        s = _num(v.get("stamp"), t)
        out.append(Derived(TRUTH_TF_TOPIC, _FT, frame_transform(s, "world", "vehicle_truth", _num(v.get("x")), _num(v.get("y")),
                                                                  _num(v.get("yaw")), _num(v.get("z"))), s))
    elif rel_key.startswith("bb/write/") and isinstance(v, (list, tuple)) and len(v) == 2 and isinstance(v[1], (list, tuple)):
        for op in v[1]:
            if not isinstance(op, dict) or op.get("op") not in ("pose", "static"):
                continue
            pose = op.get("pose")
            if not (isinstance(pose, (list, tuple)) and len(pose) == 3):
                continue
            static = op["op"] == "static"
            s = t if static else _num(op.get("stamp"), t)
            out.append(Derived(STATIC_TF_TOPIC if static else TF_TOPIC, _FT,
                               frame_transform(s, str(op.get("parent")), str(op.get("child")), *map(_num, pose)), s))
    elif rel_key == "sim/preview" and isinstance(v, dict):
        s = _num(v.get("stamp"), t)
        for name, frame in (("camera", "camera"), ("colored_range", "laser")):
            img = v.get(name)
            if isinstance(img, dict) and isinstance(img.get("data"), (bytes, bytearray)):
                out.append(Derived(f"/{name}/image", _CI, CompressedImage.of(s, frame, bytes(img["data"]), str(img.get("format", "jpeg"))), s))
    elif rel_key.startswith("eddie/pub/") and isinstance(v, dict):
        out += _derive_eddie(rel_key[len("eddie/pub/"):], v, t)
    return out


def _derive_eddie(stream: str, v: dict, t: float) -> list[Derived]:
    s = _num(v.get("stamp"), t)
    if stream == "navigator/world_from_local":
        return [Derived(TF_TOPIC, _FT, frame_transform(s, "world", "local", _num(v.get("x")), _num(v.get("y")), _num(v.get("yaw"))), s)]
    if stream == "controller/state":
        return [Derived(TF_TOPIC, _FT, frame_transform(s, "local", "vehicle", _num(v.get("x")), _num(v.get("y")), _num(v.get("yaw"))), s)]
    if stream == "controller/path":
        pts = points_of(v.get("path") or v.get("poses") or v.get("points"))
        if len(pts) >= 2:
            return [Derived("/scene/controller_path", _SU, _scene(s, [_entity(s, str(v.get("frame", "local")), "path",
                                                                               lines=[line(pts, rgba(1.0, 0.4, 0.0), thickness=0.12)])]), s)]
        return [Derived("/scene/controller_path", _SU, _scene(s, deletions=["path"]), s)]  # no path any more
    if stream == "map_manager/triggers":
        x, y = _num(v.get("x")), _num(v.get("y"))
        aid = str(v.get("annotation_id", v.get("id", "trigger")))
        c = rgba(1.0, 0.2, 0.6)
        text = f"{v.get('trigger_type', v.get('type', 'trigger'))} → {v.get('destination', '?')}: {v.get('text', '')}"
        return [Derived("/scene/triggers", _SU, _scene(s, [_entity(
            s, "world", f"{aid}@{s:.2f}", spheres=[SpherePrimitive(pose=Pose(position=Vector3(x=x, y=y)), size=Vector3(x=0.8, y=0.8, z=0.8), color=c)],
            texts=[TextPrimitive(pose=Pose(position=Vector3(x=x, y=y, z=1.0)), color=c, text=text)])]), s)]
    return []


def _line_of(attrs: dict, key: str) -> list[tuple[float, float]]:
    return points_of(attrs.get(key))


def derive_token(event: str, tok: dict, t: float) -> list[Derived]:
    """Return the Foxglove messages implied by a blackboard token event (`tok` as on the wire, attrs a dict)."""
    ttype = tok.get("type")
    a = tok.get("attrs") if isinstance(tok.get("attrs"), dict) else {}
    deleted = event == "deleted"
    if ttype == "route_plan":
        eid = f"route-{a.get('mission_id', '?')}-{a.get('step_index', 0)}"
        pts = _line_of(a, "polyline")
        if deleted or len(pts) < 2:
            return [Derived("/scene/route", _SU, _scene(t, deletions=[eid]), t)] if deleted else []
        return [Derived("/scene/route", _SU, route_scene(eid, pts, t, meta={"revision": a.get("revision", 0)}), t)]
    if ttype == "route_segment":
        pts = _line_of(a, "centreline")
        if deleted or a.get("state") == "cancelled" or len(pts) < 2:
            return [Derived("/scene/segment", _SU, _scene(t, deletions=["segment"]), t)]
        return [Derived("/scene/segment", _SU, segment_scene(pts, _num(a.get("width_m"), 1.0), t,
                                                             meta={"segment_id": a.get("segment_id", ""), "mode": a.get("mode", "")}), t)]
    if ttype == "driving_unit":
        uid = str(a.get("unit_id", tok.get("id")))
        status = str(a.get("status", "pending"))
        if deleted or status == "cancelled":
            return [Derived("/scene/driving_units", _SU, _scene(t, deletions=[uid]), t)]
        lines = []
        region = _line_of(a, "region")
        if len(region) >= 3:
            lines.append(line(region, _UNIT_RGB.get(status, _UNIT_RGB["pending"]), loop=True, thickness=0.1, z=0.02))
        cl = _line_of(a, "centreline")
        if len(cl) >= 2:
            lines.append(line(cl, rgba(1.0, 1.0, 1.0, 0.7), thickness=0.05, z=0.03))
        return [Derived("/scene/driving_units", _SU, _scene(t, [_entity(t, "world", uid, lines=lines,
                                                                       meta={"status": status, "mode": a.get("mode", "")})]), t)]
    if ttype == "perception_result":
        uid = str(a.get("unit_id", tok.get("id")))
        if deleted:
            return [Derived("/scene/perception", _SU, _scene(t, deletions=[uid]), t)]
        frame = str(a.get("frame", "world"))
        at = _num(a.get("captured_at"), t)
        lines = []
        vf = _line_of(a, "view_frame")
        if len(vf) >= 3:
            lines.append(line(vf, rgba(0.3, 0.9, 1.0, 0.8), loop=True, thickness=0.05, z=0.05))
        nr = _line_of(a, "navigable_region")
        if len(nr) >= 3:
            lines.append(line(nr, rgba(0.2, 1.0, 0.2), loop=True, thickness=0.1, z=0.06))
        for d in a.get("detected") or ():
            o = points_of(d.get("outline") if isinstance(d, dict) else None)
            if len(o) >= 3:
                lines.append(line(o, rgba(1.0, 0.5, 0.0, 0.8), loop=True, thickness=0.05, z=0.07))
        if not lines:
            return []
        return [Derived("/scene/perception", _SU, _scene(t, [_entity(at, frame, uid, lines=lines,
                                                                     meta={"status": a.get("status", ""), "sensor": a.get("sensor", "")})]), t)]
    if ttype == "local_path_plan":
        pts = points_of(a.get("poses"))
        if deleted or len(pts) < 2:
            return []
        return [Derived("/scene/local_path", _SU, _scene(t, [_entity(t, str(a.get("frame", "local")), "plan",
                                                                     lines=[line(pts, rgba(1.0, 0.3, 0.9), thickness=0.1, z=0.1)],
                                                                     meta={"seq": a.get("seq", 0)})]), t)]
    return []
