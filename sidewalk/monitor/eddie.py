"""The EDDIE adapter: EDDIE's published streams and its annotation query into the monitor's model.

The contract with the EDDIE modules (msgpack maps; extra fields are ignored, missing ones default):

- `eddie/pub/controller/state`: `stamp` [s sim], `x`, `y` [m], `yaw` [rad] of the vehicle in `local`,
  `v` [m/s], `curvature` [1/m], the active `client`, the `mode`;
- `eddie/pub/controller/path`: the path the controller tracks, `path` (or `poses`, `points`): [x, y]
  pairs or {x, y} maps [m] in `local` (or the `frame` it names);
- `eddie/pub/controller/events`: `stamp`, `kind` (accepted, refused, stop, …), `client`, `detail` — listed
  with the simulator's events;
- `eddie/pub/navigator/world_from_local`: `stamp`, `x`, `y`, `yaw`: world←local;
- `eddie/pub/map_manager/triggers` (`TriggerFired`): `stamp`, `annotation_id`, `trigger_type`, `destination`,
  world `x`, `y`, `text`, `event` (fired, skipped or rearmed), `via`;
- `eddie/svc/map_manager/query`: asked `{"type": null, "polygon": null}` (JSON: every annotation), answers
  `{"annotations": [...]}` (or a bare list), each with an id, a type and a point, line or polygon in
  `world` (see `sidewalk.recording.derive.annotation_points`), and its data base64-encoded.

The estimated pose is world←local ∘ the controller's pose. The route and the current route segment
are the mission's `route` annotations (`sidewalk.annotated_route`): the current one is the one
the estimated pose is on.
"""

from __future__ import annotations

import asyncio
import json
import logging
from typing import Any

from sidewalk.values import num as _f, points_of
from sidewalk.annotated_route import AnnotatedRoute, route_legs
from sidewalk.monitor.model import MonitorModel, XYPose
from sidewalk.recording.channels import decode_payload
from sidewalk.recording.derive import annotation_points
from wire.aio import Link
from wire.keys import EddieKeys

__all__ = ["EddieInterpreter", "EddieLive", "STREAMS", "LATEST_STREAMS"]

log = logging.getLogger(__name__)

#: (module, stream) pairs the monitor follows.
STREAMS = (("controller", "state"), ("controller", "path"), ("controller", "events"), ("navigator", "world_from_local"),
           ("map_manager", "triggers"))
#: Streams where only the newest sample matters (the others: every sample).
LATEST_STREAMS = (("controller", "state"), ("controller", "path"), ("navigator", "world_from_local"))


class EddieInterpreter:
    """Turn EDDIE's decoded stream samples and annotations into model updates."""

    #: the model's route key for EDDIE's route
    ROUTE_KEY = "eddie-route"

    def __init__(self, model: MonitorModel) -> None:
        self.model = model
        self.route = AnnotatedRoute()

    def on_sample(self, rel: str, v: Any) -> bool:
        """Handle a decoded sample of key `rel` (below `sidewalk/<ns>/`); return whether it was EDDIE's."""
        if not rel.startswith("eddie/pub/") or not isinstance(v, dict):
            return False
        stream = rel[len("eddie/pub/"):]
        m = self.model
        t = _f(v.get("stamp"), m.meta["sim_time"])
        if stream == "controller/state":
            m.set_controller({"t": t, "v": _f(v.get("v")), "curvature": _f(v.get("curvature")),
                              "client": str(v.get("client", v.get("active_client", ""))), "mode": str(v.get("mode", ""))})
            m.set_local_pose(XYPose(t=t, x=_f(v.get("x")), y=_f(v.get("y")), yaw=_f(v.get("yaw"))))
            self._follow_route()
        elif stream == "controller/path":
            m.controller_path(points_of(v.get("path") or v.get("poses") or v.get("points")), frame=str(v.get("frame", "local")))
        elif stream == "controller/events":
            m.event({"stamp": t, "kind": f"controller {v.get('kind', '?')}", "object_id": str(v.get("client", "")),
                     "detail": str(v.get("detail", ""))})
        elif stream == "navigator/world_from_local":
            m.set_world_from_local(XYPose(t=t, x=_f(v.get("x")), y=_f(v.get("y")), yaw=_f(v.get("yaw"))))
            self._follow_route()
        elif stream == "map_manager/triggers":
            m.trigger({"t": t, "annotation_id": str(v.get("annotation_id", v.get("id", ""))),
                       "type": str(v.get("trigger_type", v.get("type", ""))), "destination": str(v.get("destination", "")),
                       "x": _f(v.get("x")), "y": _f(v.get("y")), "text": str(v.get("text", "")),
                       "event": str(v.get("event", "fired")), "via": str(v.get("via", ""))})
        else:
            return False
        return True

    def on_annotations(self, anns: Any) -> None:
        """Set the annotations answered by the map manager's query (a list, or {"annotations": list})."""
        if isinstance(anns, dict):
            anns = anns.get("annotations", [])
        out = []
        for i, a in enumerate(anns if isinstance(anns, list) else []):
            if not isinstance(a, dict):
                continue
            pts = annotation_points(a)
            if pts:
                out.append({"id": str(a.get("id", a.get("annotation_id", f"a{i}"))), "type": str(a.get("type", a.get("kind", ""))),
                            "points": [[round(x, 3), round(y, 3)] for x, y in pts], "text": str(a.get("text", ""))})
        self.model.set_annotations(out)
        legs = route_legs([a for a in anns if isinstance(a, dict)] if isinstance(anns, list) else [])
        if [leg.id for leg in legs] != [leg.id for leg in self.route.legs]:
            self.route = AnnotatedRoute(legs)
            if legs:
                self.model.route_plan(self.ROUTE_KEY, self.route.polyline())
            else:
                self.model.drop_route(self.ROUTE_KEY)
            self._follow_route()

    def _follow_route(self) -> None:
        """Make the route leg the estimated pose is on the model's current segment (when it changed)."""
        est = self.model.estimate
        if est is None or not self.route.legs:
            return
        leg = self.route.locate(est.x, est.y)
        if leg is not None and (self.model.segment is None or self.model.segment.get("id") != leg.id):
            self.model.set_segment(self.route.as_dict(leg))


class EddieLive:
    """Ask EDDIE's map manager for its annotations now and then (the streams are subscribed by the caller)."""

    def __init__(self, model: MonitorModel, link: Link, ns: str, *, refresh_s: float = 10.0) -> None:
        self.interp = EddieInterpreter(model)
        self.link = link
        self.keys = EddieKeys(ns)
        self.refresh_s = refresh_s
        self.answered = 0

    async def run(self) -> None:
        """Query the annotations every `refresh_s` [s] wall (every 2 s until a first answer) until cancelled."""
        key = self.keys.service("map_manager", "query")
        body = json.dumps({"type": None, "polygon": None}).encode()
        while True:
            try:
                replies = await self.link.get(key, payload=body, timeout=5.0, as_json=True)
            except Exception as exc:  # noqa: BLE001 - a query that fails is asked again later
                log.debug("monitor: annotation query failed: %s", exc)
                replies = []
            ok = [r for r in replies if r.ok]
            if ok:
                self.answered += 1
                self.interp.on_annotations(decode_payload(ok[0].payload, ok[0].is_json))
            await asyncio.sleep(self.refresh_s if ok else 2.0)
