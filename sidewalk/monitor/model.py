"""What the monitor page shows: one model, written by the sources (live CODGER, live EDDIE, or a recording),
read by the web server section by section.

Everything is in the `world` frame [m] except what is stored in `local` (the CODGER local path plan,
EDDIE's controller path and pose), which is drawn through the newest `world←local`. Each section has a
version; a reader sends only the sections whose version changed (latest value wins: a reader that
falls behind skips versions, it never queues them). Methods run on the event loop only.
"""

from __future__ import annotations

import bisect
import json
import math
import time
from collections import deque
from typing import Any, Callable, Iterable, Literal, Optional

import numpy as np
from pydantic import BaseModel, ConfigDict

from sidewalk.health import HeardBeat, ModuleHealth
from sidewalk.mapdraw import DrawnFeature
from sidewalk.recording.channels import jsonable
from wire.health import Heartbeat
from wire.se2 import PoseFields, transform_points

__all__ = ["MonitorModel", "SECTIONS", "DrawnUnit", "Perceived", "ModuleRow", "Image", "XYPose"]

#: The sections of the page, in the order a first frame sends them.
SECTIONS = ("meta", "map", "world", "route", "segment", "units", "perceived", "plan", "controller", "estimate", "truth",
            "trails", "modules", "mission", "images", "series", "annotations", "triggers", "events")

_F = ConfigDict(frozen=True)
Pt = tuple[float, float]


class XYPose(PoseFields, BaseModel):
    """A planar pose at sim time `t` [s]: x, y [m], yaw [rad] in `world` (unless said otherwise)."""

    model_config = _F
    t: float
    x: float
    y: float
    yaw: float


class DrawnUnit(BaseModel):
    """A driving unit as drawn: its region and centreline (world [m]), status, mode, index."""

    model_config = _F
    id: str
    index: int = 0
    status: str = "pending"
    mode: str = ""
    region: tuple[Pt, ...] = ()
    centreline: tuple[Pt, ...] = ()


class Perceived(BaseModel):
    """What PERCEPTION reported for a unit, in world [m]: navigable region, sensor view frame, detected outlines."""

    model_config = _F
    unit_id: str
    status: str = ""
    sensor: str = ""
    captured_at: float = 0.0
    navigable_region: tuple[Pt, ...] = ()
    view_frame: tuple[Pt, ...] = ()
    detected: tuple[tuple[Pt, ...], ...] = ()


class ModuleRow(BaseModel):
    """One process as the page lists it: liveness, health state, heartbeat age [s] wall, pid, host."""

    model_config = _F
    name: str
    alive: bool
    state: str
    age_s: Optional[float] = None
    pid: Optional[int] = None
    host: str = ""


class Image(BaseModel):
    """The newest image of one sensor: encoded bytes, format, size [px], capture sim stamp [s], a version."""

    model_config = _F
    data: bytes
    format: Literal["jpeg", "png"] = "jpeg"
    width: int = 0
    height: int = 0
    stamp: float = 0.0
    version: int = 0


def _pts(v: Iterable[Any]) -> tuple[Pt, ...]:
    return tuple((round(float(p[0]), 3), round(float(p[1]), 3)) for p in v)


def _apply(T: tuple[float, float, float], pts: Iterable[Pt]) -> list[list[float]]:
    """Return points [m] of the child frame in the parent frame of T (child → parent)."""
    return transform_points(np.asarray(T, dtype=float), np.asarray(list(pts), dtype=float).reshape(-1, 2)).round(3).tolist()


class MonitorModel:
    """The page's state: sections with versions, listeners woken on change (see module docstring)."""

    def __init__(self, *, arch: str = "auto", replay: bool = False, wall: Callable[[], float] = time.time,
                 series_len: int = 900, trail_len: int = 4000) -> None:
        self.wall = wall
        self.started = wall()
        self.versions: dict[str, int] = {s: 0 for s in SECTIONS}
        self._cache: dict[str, tuple[int, str]] = {}
        self._listeners: set[Any] = set()
        self.meta: dict[str, Any] = {"arch": arch, "replay": replay, "sim_time": 0.0, "rtf": None, "progress": None,
                                     "namespace": "", "source": ""}
        self.map: list[DrawnFeature] = []
        self.world: list[DrawnFeature] = []
        self.routes: dict[str, dict] = {}
        self.segment: Optional[dict] = None
        self.units: dict[str, DrawnUnit] = {}
        self.perceived: dict[str, Perceived] = {}
        self.plan_local: tuple[Pt, ...] = ()
        self.plan_world: tuple[Pt, ...] = ()
        self.controller: dict[str, Any] = {}
        self.controller_path_local: tuple[Pt, ...] = ()
        self.world_from_local: Optional[XYPose] = None
        self.local_pose: Optional[XYPose] = None
        self.estimate: Optional[XYPose] = None
        self.truth: Optional[XYPose] = None
        self.truth_v = 0.0
        self.trail_est: deque[Pt] = deque(maxlen=trail_len)
        self.trail_truth: deque[Pt] = deque(maxlen=trail_len)
        self._truth_hist: deque[tuple[float, float, float]] = deque(maxlen=2000)
        self.alive: dict[str, bool] = {}
        self.heard: dict[str, HeardBeat] = {}
        self.missions: dict[str, dict] = {}
        self.images: dict[str, Image] = {}
        self.speed: deque[tuple[float, float]] = deque(maxlen=series_len)
        self.pos_error: deque[tuple[float, float]] = deque(maxlen=series_len)
        self.annotations: list[dict] = []
        self.triggers: deque[dict] = deque(maxlen=200)
        self.events: deque[dict] = deque(maxlen=30)
        self._last_speed_t = -1e9
        self.updates = 0

    # ---- versions and listeners ---------------------------------------------------------------

    def touch(self, *sections: str) -> None:
        """Mark sections changed and wake every reader."""
        for s in sections:
            self.versions[s] += 1
        self.updates += 1
        for ev in self._listeners:
            ev.set()

    def listen(self, event: Any) -> None:
        """Register an object with `set()` (an asyncio.Event) to be woken on every change."""
        self._listeners.add(event)

    def unlisten(self, event: Any) -> None:
        """Stop waking `event`."""
        self._listeners.discard(event)

    # ---- writers: meta ------------------------------------------------------------------------

    def set_meta(self, **kw: Any) -> None:
        """Update meta fields (arch, namespace, source, progress …)."""
        self.meta.update(kw)
        self.touch("meta")

    def sim_time(self, t: float, rtf: Optional[float] = None) -> None:
        """Record the newest sim time [s] (and the real-time factor reached)."""
        if t >= self.meta["sim_time"]:
            self.meta["sim_time"] = float(t)
            if rtf is not None:
                self.meta["rtf"] = round(float(rtf), 2)
            self.touch("meta")

    # ---- writers: maps ------------------------------------------------------------------------

    def set_map(self, features: list[DrawnFeature], *, truth: bool = False) -> None:
        """Set the map (what the robot is told) or, with `truth`, the world (evaluation only)."""
        if truth:
            self.world = list(features)
            self.touch("world")
        else:
            self.map = list(features)
            self.touch("map")

    # ---- writers: CODGER tokens ---------------------------------------------------------------

    def route_plan(self, key: str, points: Iterable[Any], *, mission_id: str = "", step: int = 0, revision: int = 0) -> None:
        """Set one route (a mission step's newest plan) as a polyline [m] in world."""
        self.routes[key] = {"id": key, "mission_id": mission_id, "step": step, "revision": revision, "points": _pts(points)}
        self.touch("route")

    def drop_route(self, key: str) -> None:
        """Remove a route."""
        if self.routes.pop(key, None) is not None:
            self.touch("route")

    def set_segment(self, seg: Optional[dict]) -> None:
        """Set the current route segment (`{id, centreline, width_m, mode}`, world) or clear it."""
        self.segment = None if seg is None else {**seg, "centreline": _pts(seg.get("centreline", ()))}
        self.touch("segment")

    def unit(self, u: DrawnUnit) -> None:
        """Add or replace a driving unit."""
        self.units[u.id] = u
        self.touch("units")

    def drop_unit(self, uid: str) -> None:
        """Remove a driving unit (cancelled or deleted) and its perception."""
        a = self.units.pop(uid, None)
        b = self.perceived.pop(uid, None)
        if a is not None or b is not None:
            self.touch("units", "perceived")

    def perception(self, p: Perceived) -> None:
        """Add or replace what PERCEPTION saw for a unit (world [m])."""
        self.perceived[p.unit_id] = p
        self.touch("perceived")

    def local_plan(self, points: Iterable[Any], *, frame: str = "local") -> None:
        """Set the local path plan: points [m] in `local` (drawn through world←local) or `world`."""
        pts = _pts(points)
        if frame == "world":
            self.plan_world, self.plan_local = pts, ()
        else:
            self.plan_local, self.plan_world = pts, ()
        self.touch("plan")

    # ---- writers: poses -----------------------------------------------------------------------

    def set_world_from_local(self, p: XYPose) -> None:
        """Set the newest world←local correction (the perceived vehicle position's frame)."""
        self.world_from_local = p
        self.touch("plan", "controller")
        if self.local_pose is not None:
            self._estimate_from_local()

    def set_local_pose(self, p: XYPose) -> None:
        """Set the vehicle's pose in `local` (EDDIE's controller); the estimate is world←local ∘ it."""
        self.local_pose = p
        self._estimate_from_local()

    def _estimate_from_local(self) -> None:
        w, lp = self.world_from_local, self.local_pose
        if w is None or lp is None:
            return
        self.set_estimate(XYPose.from_pose2d(w.to_pose2d().compose(lp.to_pose2d()), t=lp.t))

    def set_estimate(self, p: XYPose) -> None:
        """Set the estimated vehicle pose (world); adds a position-error sample against the truth at its time."""
        if self.estimate is not None and p.t < self.estimate.t:
            return
        self.estimate = p
        if not self.trail_est or math.hypot(p.x - self.trail_est[-1][0], p.y - self.trail_est[-1][1]) > 0.25:
            self.trail_est.append((round(p.x, 2), round(p.y, 2)))
        err = self._error_at(p)
        if err is not None and (not self.pos_error or p.t - self.pos_error[-1][0] >= 0.2):
            self.pos_error.append((round(p.t, 2), round(err, 3)))
            self.touch("series")
        self.touch("estimate", "trails")

    def set_truth(self, p: XYPose, v: float = 0.0) -> None:
        """Set the true vehicle pose (world; evaluation only) and speed [m/s]."""
        if self.truth is not None and p.t < self.truth.t:
            return
        self.truth = p
        self.truth_v = float(v)
        self._truth_hist.append((p.t, p.x, p.y))
        if not self.trail_truth or math.hypot(p.x - self.trail_truth[-1][0], p.y - self.trail_truth[-1][1]) > 0.25:
            self.trail_truth.append((round(p.x, 2), round(p.y, 2)))
        if p.t - self._last_speed_t >= 0.25:
            self._last_speed_t = p.t
            self.speed.append((round(p.t, 2), round(float(v), 3)))
            self.touch("series")
        self.sim_time(p.t)
        self.touch("truth", "trails")

    def _error_at(self, p: XYPose) -> Optional[float]:
        h = self._truth_hist
        if not h or p.t < h[0][0] - 1e-6 or p.t > h[-1][0] + 0.5:
            return None
        ts = [r[0] for r in h]
        i = bisect.bisect_left(ts, p.t)
        if i <= 0:
            x, y = h[0][1], h[0][2]
        elif i >= len(h):
            x, y = h[-1][1], h[-1][2]
        else:
            (t0, x0, y0), (t1, x1, y1) = h[i - 1], h[i]
            a = 0.0 if t1 <= t0 else (p.t - t0) / (t1 - t0)
            x, y = x0 + a * (x1 - x0), y0 + a * (y1 - y0)
        return math.hypot(p.x - x, p.y - y)

    # ---- writers: EDDIE -----------------------------------------------------------------------

    def set_controller(self, state: dict) -> None:
        """Set the EDDIE controller's state (speed, curvature, active client, mode …)."""
        self.controller = {**self.controller, **state}
        self.touch("controller")

    def controller_path(self, points: Iterable[Any], *, frame: str = "local") -> None:
        """Set the path the EDDIE controller tracks ([m] in `local`, or `world`)."""
        pts = _pts(points)
        self.controller_path_local = pts
        self.controller["path_frame"] = frame
        self.touch("controller")

    def set_annotations(self, anns: list[dict]) -> None:
        """Set EDDIE's annotations: `{id, type, points (world [m]), text}`."""
        self.annotations = list(anns)
        self.touch("annotations")

    def trigger(self, trig: dict) -> None:
        """Add a trigger that fired (`{t, annotation_id, type, destination, x, y, text}`)."""
        self.triggers.append(trig)
        self.touch("triggers")

    # ---- writers: health, mission, images, events -----------------------------------------------

    def liveliness(self, name: str, alive: bool) -> None:
        """Record that a process's liveliness token appeared (alive) or went."""
        self.alive[name] = alive
        self.touch("modules")

    def heartbeat(self, hb: Heartbeat, received: Optional[float] = None) -> None:
        """Record a heartbeat received at wall time `received` [s] (default: now)."""
        self.heard[hb.module] = HeardBeat(beat=hb, received=self.wall() if received is None else received)
        self.alive.setdefault(hb.module, True)
        self.touch("modules")

    def mission(self, status: dict) -> None:
        """Record a mission status (the CAPTAIN's MissionStatus as a dict)."""
        mid = str(status.get("mission_id", "?"))
        self.missions[mid] = status
        self.touch("mission")

    def image(self, name: str, data: bytes, *, fmt: str = "jpeg", width: int = 0, height: int = 0, stamp: float = 0.0) -> None:
        """Set the newest image of `name` ("camera" or "colored_range")."""
        old = self.images.get(name)
        self.images[name] = Image(data=data, format="png" if fmt == "png" else "jpeg", width=width, height=height,
                                  stamp=stamp, version=(old.version + 1) if old else 1)
        self.touch("images")

    def event(self, ev: dict) -> None:
        """Add a simulator event (collision, off-path …)."""
        self.events.append(ev)
        self.touch("events")

    # ---- readers ------------------------------------------------------------------------------

    def modules(self) -> list[ModuleRow]:
        """Return every process seen, judged now (a live one silent for 3 s is wedged)."""
        now = self.wall()
        rows = []
        for name in sorted(set(self.alive) | set(self.heard)):
            alive = self.alive.get(name, False)
            h = ModuleHealth.judge(name, self.heard.get(name), now, listened_s=now - self.started)
            rows.append(ModuleRow(name=name, alive=alive, state=h.state if alive else "gone", age_s=h.heartbeat_age_s,
                                  pid=h.pid, host=h.host))
        return rows

    def section(self, name: str) -> Any:
        """Return one section as JSON-ready values."""
        wl = self.world_from_local
        T = wl.to_pose2d().as_tuple() if wl is not None else None
        if name == "meta":
            return {**self.meta, "updates": self.updates}
        if name in ("map", "world"):
            return [f.model_dump() for f in (self.map if name == "map" else self.world)]
        if name == "route":
            return list(self.routes.values())
        if name == "segment":
            return self.segment
        if name == "units":
            return sorted((u.model_dump() for u in self.units.values()), key=lambda u: u["index"])
        if name == "perceived":
            return [p.model_dump() for p in self.perceived.values()]
        if name == "plan":
            if self.plan_world:
                return {"points": self.plan_world, "frame": "world"}
            if self.plan_local and T is not None:
                return {"points": _apply(T, self.plan_local), "frame": "local"}
            return {"points": [], "frame": "local"}
        if name == "controller":
            pts = self.controller_path_local
            frame = self.controller.get("path_frame", "local")
            path = list(pts) if frame == "world" else (_apply(T, pts) if T is not None and pts else [])
            return {**{k: v for k, v in self.controller.items() if k != "path_frame"}, "path": path}
        if name == "estimate":
            return None if self.estimate is None else self.estimate.model_dump()
        if name == "truth":
            return None if self.truth is None else {**self.truth.model_dump(), "v": self.truth_v}
        if name == "trails":
            return {"estimate": list(self.trail_est), "truth": list(self.trail_truth)}
        if name == "modules":
            return [m.model_dump() for m in self.modules()]
        if name == "mission":
            ms = list(self.missions.values())
            return ms[-1] if ms else None
        if name == "images":
            return {k: {"version": v.version, "stamp": v.stamp, "width": v.width, "height": v.height, "format": v.format}
                    for k, v in self.images.items()}
        if name == "series":
            return {"speed": list(self.speed), "pos_error": list(self.pos_error)}
        if name == "annotations":
            return self.annotations
        if name == "triggers":
            return list(self.triggers)
        if name == "events":
            return list(self.events)
        raise KeyError(name)

    def section_json(self, name: str) -> str:
        """Return one section as JSON text (cached per version)."""
        v = self.versions[name]
        hit = self._cache.get(name)
        if hit is not None and hit[0] == v and name != "modules":
            return hit[1]
        value = self.section(name)
        try:
            text = json.dumps(value, separators=(",", ":"), allow_nan=False)
        except (ValueError, TypeError):  # a NaN, an infinity or bytes somewhere
            text = json.dumps(jsonable(value), separators=(",", ":"), allow_nan=False)
        self._cache[name] = (v, text)
        return text
