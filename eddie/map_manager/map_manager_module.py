"""The map manager as an EDDIE module: the `query` service, and triggers sent once to their destinations.

Service `query` answers an `AnnotationQuery` envelope with an `AnnotationList`, and the monitor's and
recorder's plain JSON `{"type": …, "polygon": …}` with JSON `{"annotations": [...]}` (same records).
A cycle runs on each controller `state` sample (the controller's rate, ≥ 10 Hz sim) once the
navigator's `world_from_local` (pushed stream) is known; a fired trigger's `TriggerMessage` goes to
its destination's inbox, and every outcome (fired, skipped, rearmed) is published on stream
`triggers` as a `TriggerFired`. `crossed_wall` is the wall time the crossing state reached the manager.

Service `mission` takes a submitted mission's trigger annotations from the mission service
(`MissionAnnotations`, compiled there by `eddie.missions`) and holds them in place of the last
mission's: a mission submitted at run time gets its speeds, dead reckoning and stops as one compiled
at launch does. With a state file they are kept beside it (`mission_file`) and taken up by a restart.

With a state file (`eddie.map_manager.state_file`) the used flags and the vehicle's last position
survive a restart: the first cycle after one asks the controller (`recorded_path`) for the path it
drove since that position and walks it, so triggers crossed while the manager was away fire then.
"""

from __future__ import annotations

import asyncio
import base64
import json
import logging
import time

from pydantic import ValidationError
from wire.aio import QueryAnswer, QueryRequest

from eddie.annotated_map.errors import AnnotatedMapError
from eddie.annotated_map.geojson_file import annotations_from_geojson, save_annotations
from eddie.errors import BadMessage, EddieError
from eddie.map_manager.map_manager import MapManager, TravelledCycle
from eddie.map_manager.state_file import SAVE_EVERY_S, ManagerState, save_state
from eddie.messages.controller import ControllerState, RecordedPath, RecordedPathQuery
from eddie.messages.map_manager import AnnotationQuery, MissionAnnotations, MissionInstalled, TriggerFired, TriggerMessage
from eddie.messages.navigator import WorldFromLocal
from eddie.toolkit.message import decode_envelope, encode_envelope, error_payload
from wire.ratelimit import warn_limited
from eddie.toolkit.module import Incoming, Module

__all__ = ["MapManagerModule", "mission_file", "resume_mission"]

log = logging.getLogger(__name__)


def mission_file(state_path: str) -> str:
    """Return where the installed mission's annotations are kept beside state file `state_path`."""
    return f"{state_path}.mission.geojson"


def resume_mission(mgr: MapManager, state_path: str) -> None:
    """Install the mission kept beside `state_path` by the manager's last life, if any (AnnotatedMapError names the file)."""
    path = mission_file(state_path)
    try:
        doc = json.loads(open(path, encoding="utf-8").read())
    except FileNotFoundError:
        return
    except ValueError as exc:
        raise AnnotatedMapError(f"{path}: not JSON ({exc}); delete it to start afresh") from None
    mgr.install(str(doc.get("name", "")) if isinstance(doc, dict) else "", annotations_from_geojson(doc, source=path))


class MapManagerModule:
    """Run a `MapManager` on endpoint `m`, following modules `controller` and `navigator`."""

    def __init__(self, m: Module, mgr: MapManager, *, controller: str = "controller", navigator: str = "navigator",
                 state_path: str | None = None, map_name: str = "", resume: ManagerState | None = None) -> None:
        """Follow `controller` and `navigator`; keep the state in `state_path` (None: none), resuming from `resume`."""
        self.m = m
        self.mgr = mgr
        self.state_path = state_path
        self.map_name = map_name
        #: the state a restart resumes from (its used flags are set at once; its position waits for the first cycle)
        self._resume = resume
        if resume is not None:
            mgr.restore_used(resume.used)
        self._saved_at: float | None = None
        self.controller = controller
        self.navigator = navigator
        self._state: tuple[ControllerState, float] | None = None
        self._w: WorldFromLocal | None = None
        self._wake = asyncio.Event()
        #: triggers sent to their destinations
        self.sent = 0

    def _on_state(self, st: ControllerState) -> None:
        self._state = (st, time.time())
        self._wake.set()

    def _on_w(self, w: WorldFromLocal) -> None:
        self._w = w
        self._wake.set()

    async def _answer(self, req: QueryRequest) -> QueryAnswer:
        where = f"{self.m.name}/query"
        if req.is_json:
            try:
                body = json.loads(req.payload or b"{}")
                q = AnnotationQuery.model_validate(body if isinstance(body, dict) else {})
            except (ValueError, ValidationError) as exc:
                first = str(exc).splitlines()[0]
                return QueryAnswer(ok=False, payload=error_payload("bad_query", f"{where}: bad JSON query: {first}"), as_json=True)
            ans = self.mgr.query(q)
            payload = {"annotations": [r.model_dump(mode="json") for r in ans.annotations]}
            return QueryAnswer(ok=True, payload=json.dumps(payload).encode(), as_json=True)
        try:
            env, msg = decode_envelope(req.payload, where=where)
            if not isinstance(msg, AnnotationQuery):
                raise BadMessage(f"{where}: expected an AnnotationQuery, got {type(msg).__name__}", sender=env.sender,
                                 field="type")
        except BadMessage as exc:
            warn_limited(log, "bad-query", "%.200s", exc)
            return QueryAnswer(ok=False, payload=error_payload("bad_message", str(exc)), as_json=True)
        return QueryAnswer(ok=True, payload=encode_envelope(self.m.name, self.mgr.query(msg), self.m.now()))

    async def _install(self, inc: Incoming) -> MissionInstalled:
        """Answer `mission`: hold the mission's annotations in place of the last mission's (kept beside the state file)."""
        msg = inc.message
        if not isinstance(msg, MissionAnnotations):
            raise BadMessage(f"{self.m.name}/mission: expected MissionAnnotations, got {type(msg).__name__}", sender=inc.sender,
                             field="type")
        try:
            doc = json.loads(msg.geojson)
        except ValueError as exc:
            raise BadMessage(f"{self.m.name}/mission: mission {msg.mission_id}: annotations not JSON: {exc}", sender=inc.sender,
                             field="geojson") from None
        annotations = annotations_from_geojson(doc, source=f"mission {msg.mission_id}")
        self.mgr.install(msg.mission_id, annotations)
        if self.state_path is not None:
            try:
                save_annotations(mission_file(self.state_path), annotations, name=msg.mission_id)
            except OSError as exc:
                warn_limited(log, "mission-file", "map_manager: cannot keep the mission's annotations: %s", exc)
        log.info("map_manager: mission %s (%s): %d annotations installed", msg.mission_id, msg.name, len(annotations))
        return MissionInstalled(mission_id=msg.mission_id, count=len(annotations))

    async def _recorded_since(self, resume: ManagerState, st: ControllerState) -> list[tuple[float, float]]:
        """Return the path [m `local`] from the position saved before a restart to `st`'s, as the controller recorded it."""
        path = [(resume.x, resume.y)]
        if st.odometer < resume.odometer:
            log.warning("map_manager: the controller's odometer (%.1f m) is behind the saved state's (%.1f m): it restarted too; "
                        "taking up from its position now", st.odometer, resume.odometer)
            return [(st.x, st.y)]
        try:
            rec = await self.m.request(self.controller, "recorded_path",
                                       RecordedPathQuery(odometer_from=resume.odometer, odometer_to=st.odometer),
                                       reply_type=RecordedPath)
            path += [(float(x), float(y)) for x, y in rec.points]
        except EddieError as exc:
            log.warning("map_manager: no recorded path from the controller (%s): a straight line from the saved position", exc)
        log.info("map_manager: resuming after a restart: %.1f m driven meanwhile (%d recorded points), %d annotations used",
                 st.odometer - resume.odometer, len(path) - 1, len(resume.used))
        return path + [(st.x, st.y)]

    def _save(self, st: ControllerState, changed: bool) -> None:
        """Write the state file on a trigger event, else at most every SAVE_EVERY_S [s] sim."""
        if self.state_path is None or (not changed and self._saved_at is not None and st.stamp - self._saved_at < SAVE_EVERY_S):
            return
        try:
            save_state(self.state_path, ManagerState(annotated_map=self.map_name, used=self.mgr.used(), odometer=max(st.odometer, 0.0),
                                                     x=st.x, y=st.y, stamp=st.stamp))
            self._saved_at = st.stamp
        except OSError as exc:
            warn_limited(log, "state-file", "map_manager: cannot write the state file %s: %s", self.state_path, exc)

    async def _cycle(self) -> None:
        if self._state is None or self._w is None:
            return
        st, wall = self._state
        if self._resume is not None:
            resume, self._resume = self._resume, None
            out: TravelledCycle = self.mgr.catch_up(await self._recorded_since(resume, st), self._w)
        else:
            out = self.mgr.cycle(st.x, st.y, self._w)
        await self._dispatch(st, wall, out)
        self._save(st, bool(out.events))

    async def _dispatch(self, st: ControllerState, wall: float, out: TravelledCycle) -> None:
        """Send each fired trigger to its destination and publish every event."""
        for ev in out.events:
            a = ev.annotation
            if ev.kind == "fired":
                await self.m.send(a.destination, TriggerMessage(
                    annotation_id=a.id, trigger_type=a.type, text=a.text, x=ev.x, y=ev.y, stamp=st.stamp,
                    crossed_wall=wall, data_base64=base64.b64encode(a.data).decode("ascii")))
                self.sent += 1
                log.info("map_manager: t=%.2f %s → %s at (%.1f, %.1f): %s", st.stamp, a.id, a.destination, ev.x, ev.y, a.text)
            else:
                log.warning("map_manager: t=%.2f %s %s (%s) at (%.1f, %.1f)", st.stamp, a.id, ev.kind, ev.via, ev.x, ev.y)
            self.m.publish("triggers", TriggerFired(stamp=st.stamp, annotation_id=a.id, trigger_type=a.type,
                                                    destination=a.destination, x=ev.x, y=ev.y, text=a.text,
                                                    event=ev.kind, via=ev.via))

    async def run(self) -> None:
        """Serve queries and fire triggers until cancelled."""
        m = self.m
        m.subscribe(self.controller, "state", ControllerState, self._on_state)
        m.subscribe(self.navigator, "world_from_local", WorldFromLocal, self._on_w)
        # declared after the subscriptions: a client that gets an answer knows they are declared too
        m.link.queryable(m.keys.service(m.name, "query"), self._answer)
        m.serve("mission", self._install)
        m.ready()
        while True:
            await self._wake.wait()
            self._wake.clear()
            await self._cycle()
