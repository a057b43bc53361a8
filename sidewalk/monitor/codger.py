"""The CODGER adapter: blackboard tokens and frames into the monitor's model.

Seed §2.3.8: "Whenever the data to be displayed appear on the BLACKBOARD, the NAVIGATION MONITOR
retrieves and displays them." The live adapter is an anonymous blackboard reader: one monitor on
the route plan, route segment, driving unit, perception result, local path plan and mission status
types, plus a few look-ups a second of `world←vehicle` (the estimated pose) and `world←local`
(for the local path plan, which is in `local`). Perception results stated in `vehicle` (at capture
time) or `local` are converted to `world` through a `FrameSource`: the blackboard live, the
recorded transforms in a replay.
"""

from __future__ import annotations

import asyncio
import logging
from typing import Iterable, Optional, Protocol

from blackboard import BlackboardClient, BlackboardError, Spec
from sidewalk.values import num as _f, points_of
from sidewalk.monitor.model import DrawnUnit, MonitorModel, Perceived, XYPose
from sidewalk.recording.recorder import token_dict
from wire.se2 import transform_points

__all__ = ["CodgerInterpreter", "CodgerLive", "FrameSource", "BlackboardFrames", "MONITORED_TYPES"]

log = logging.getLogger(__name__)

#: The token types the monitor draws.
MONITORED_TYPES = ("route_plan", "route_segment", "driving_unit", "perception_result", "local_path_plan", "mission_status")


class FrameSource(Protocol):
    """Where `world←frame` at a sim time comes from."""

    async def world_from(self, frame: str, stamp: float) -> Optional[tuple[float, float, float]]:
        """Return world←`frame`@`stamp` as (x [m], y [m], yaw [rad]), or None if unknown."""


class BlackboardFrames:
    """World←frame look-ups on the blackboard node."""

    def __init__(self, bb: BlackboardClient) -> None:
        self.bb = bb

    async def world_from(self, frame: str, stamp: float) -> Optional[tuple[float, float, float]]:
        """Return world←`frame`@`stamp` from the node's pose history (None when it cannot answer)."""
        try:
            p = await self.bb.lookup("world", stamp, frame, stamp)
        except (BlackboardError, asyncio.TimeoutError):
            return None
        return p.as_tuple()


class CodgerInterpreter:
    """Turn token events (wire dicts, attrs as dicts) and estimated poses into model updates."""

    def __init__(self, model: MonitorModel, frames: FrameSource) -> None:
        self.model = model
        self.frames = frames
        self._segment_id: Optional[str] = None
        self._route_rev: dict[str, int] = {}

    async def _to_world(self, pts: list[tuple[float, float]], frame: str, stamp: float) -> tuple[tuple[float, float], ...]:
        if not pts or frame == "world":
            return tuple(pts)
        T = await self.frames.world_from(frame, stamp)
        if T is None:
            return ()
        return tuple(map(tuple, transform_points(list(T), pts).tolist()))  # type: ignore[arg-type]

    async def on_token(self, event: str, tok: dict) -> None:
        """Handle one token event: new, updated, deleted or present (already there)."""
        ttype = tok.get("type")
        a = tok.get("attrs") if isinstance(tok.get("attrs"), dict) else {}
        deleted = event == "deleted"
        m = self.model
        if ttype == "route_plan":
            key = f"{a.get('mission_id', '?')}/{a.get('step_index', 0)}"
            rev = int(a.get("revision", 0) or 0)
            if deleted:
                m.drop_route(key)
            elif rev >= self._route_rev.get(key, -1):
                self._route_rev[key] = rev
                m.route_plan(key, points_of(a.get("polyline")), mission_id=str(a.get("mission_id", "")),
                             step=int(a.get("step_index", 0) or 0), revision=rev)
        elif ttype == "route_segment":
            sid = str(a.get("segment_id", tok.get("id")))
            if deleted or a.get("state") == "cancelled":
                if sid == self._segment_id:
                    self._segment_id = None
                    m.set_segment(None)
            else:
                self._segment_id = sid
                m.set_segment({"id": sid, "centreline": points_of(a.get("centreline")), "width_m": _f(a.get("width_m"), 1.0),
                               "mode": a.get("mode", ""), "index": a.get("segment_index", 0)})
        elif ttype == "driving_unit":
            uid = str(a.get("unit_id", tok.get("id")))
            status = str(a.get("status", "pending"))
            if deleted or status == "cancelled":
                m.drop_unit(uid)
                return
            m.unit(DrawnUnit(id=uid, index=int(a.get("unit_index", 0) or 0), status=status, mode=str(a.get("mode", "")),
                             region=tuple(points_of(a.get("region"))), centreline=tuple(points_of(a.get("centreline")))))
        elif ttype == "perception_result":
            if not deleted:
                await self._perceived(a)
        elif ttype == "local_path_plan":
            if not deleted:
                m.local_plan(points_of(a.get("poses")), frame=str(a.get("frame", "local")))
        elif ttype == "mission_status":
            if not deleted:
                m.mission(a)

    async def _perceived(self, r: dict) -> None:
        frame = str(r.get("frame", "world"))
        at = _f(r.get("captured_at"))
        nav = await self._to_world(points_of(r.get("navigable_region")), frame, at)
        view = await self._to_world(points_of(r.get("view_frame")), frame, at)
        detected = []
        for d in r.get("detected") or ():
            if isinstance(d, dict):
                o = await self._to_world(points_of(d.get("outline")), frame, at)
                if len(o) >= 3:
                    detected.append(o)
        self.model.perception(Perceived(unit_id=str(r.get("unit_id", "?")), status=str(r.get("status", "")),
                                        sensor=str(r.get("sensor", "")), captured_at=at, navigable_region=nav,
                                        view_frame=view, detected=tuple(detected)))

    def on_estimate(self, t: float, x: float, y: float, yaw: float) -> None:
        """The estimated vehicle pose world←vehicle at sim time `t` [s]."""
        self.model.set_estimate(XYPose(t=t, x=x, y=y, yaw=yaw))

    def on_world_from_local(self, t: float, x: float, y: float, yaw: float) -> None:
        """The newest world←local correction."""
        self.model.set_world_from_local(XYPose(t=t, x=x, y=y, yaw=yaw))


class CodgerLive:
    """Feed the interpreter from a live blackboard: one monitor, then look-ups at `pose_hz` [Hz] wall."""

    def __init__(self, model: MonitorModel, bb: BlackboardClient, *, pose_hz: float = 5.0, lag_s: float = 0.25) -> None:
        self.bb = bb
        self.model = model
        self.interp = CodgerInterpreter(model, BlackboardFrames(bb))
        self.period = 1.0 / pose_hz
        self.lag_s = lag_s
        self.lookups = 0

    def spec(self, types: Iterable[str] = MONITORED_TYPES) -> Spec:
        """Return the monitor's specification: any of the drawn types."""
        return Spec(any_of=tuple(Spec(type=t) for t in types))

    async def run(self) -> None:
        """Register the monitor, draw what is already there, then follow events and poses until cancelled."""
        spec = self.spec()
        mon = self.bb.monitor(spec)
        await mon.start()
        poses = asyncio.ensure_future(self._poses())
        try:
            try:
                for tok in await self.bb.retrieve(spec):
                    await self.interp.on_token("present", token_dict(tok))
            except BlackboardError as exc:
                log.warning("monitor: cannot read the blackboard: %s", exc)
            async for ev in mon:
                await self.interp.on_token(ev.kind, token_dict(ev.token))
        finally:
            poses.cancel()
            await mon.close()

    async def _poses(self) -> None:
        while True:
            await asyncio.sleep(self.period)  # a few look-ups a second: the monitor must not load the node
            t = self.model.meta["sim_time"] - self.lag_s  # the HELM's poses trail the simulator's clock a little
            if t <= 0:
                continue
            try:
                p = await self.bb.lookup("world", t, "vehicle", t)
                self.interp.on_estimate(t, p.x, p.y, p.yaw)
                w = await self.bb.lookup("world", None, "local", None)
                self.interp.on_world_from_local(t, w.x, w.y, w.yaw)
                self.lookups += 2
            except (BlackboardError, asyncio.TimeoutError) as exc:
                log.debug("monitor: no pose at %.2f: %s", t, exc)
