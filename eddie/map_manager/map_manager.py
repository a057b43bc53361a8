"""The map manager's cycle, pure: the travelled line = controller pose (`local`) through world←local, over the trigger walker.

A cycle takes the controller's pose in `local` and the navigator's world←local. When world←local is
unchanged the vehicle travelled from the last world position to the new one (`advance`). When the
navigator moved world←local since the last cycle (a fix), the vehicle first travelled under the old
transform, then its world position jumped from there to the new one (seed Figure 3.3): that jump
goes through the walker's position-jump policy (`TriggerWalker.jump`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from eddie.annotated_map.annotation import Annotation
from eddie.annotated_map.database import AnnotationDatabase
from eddie.annotated_map.triggers import TriggerEvent, TriggerWalker
from eddie.messages.map_manager import AnnotationList, AnnotationQuery, AnnotationRecord
from eddie.messages.navigator import WorldFromLocal

__all__ = ["MapManager", "TravelledCycle", "world_of", "record_of"]


def world_of(w: WorldFromLocal, x: float, y: float) -> tuple[float, float]:
    """Return the `world` point [m] of `local` point (x, y) [m] through world←local `w`."""
    c, s = math.cos(w.yaw), math.sin(w.yaw)
    return w.x + c * x - s * y, w.y + s * x + c * y


@dataclass(frozen=True)
class TravelledCycle:
    """One cycle's outcome: the world position [m] reached and the trigger events in travel order."""

    x: float
    y: float
    events: tuple[TriggerEvent, ...]


def record_of(a) -> AnnotationRecord:
    """Return annotation `a` as the query's answer record (header, `world` location, data base64)."""
    import base64

    return AnnotationRecord(id=a.id, type=a.type, destination=a.destination, used=a.used, text=a.text,
                            kind=a.location.kind, points=a.location.points, next_id=a.next_id, previous_id=a.previous_id,
                            trigger=a.trigger, data_size=a.data_size, data_base64=base64.b64encode(a.data).decode("ascii"))


class MapManager:
    """The annotation database, its trigger walker, the last world←local used and the running mission's annotations.

    The database holds the annotated map the manager started with and, on top, the annotations of one
    mission (`install`): a mission submitted at run time is compiled by the mission service and handed
    over here, replacing the previous mission's.
    """

    def __init__(self, db: AnnotationDatabase) -> None:
        self.db = db
        self.walker = TriggerWalker(db)
        self._w: WorldFromLocal | None = None
        #: the mission whose annotations are installed ("" before any) and their ids
        self.mission_id = ""
        self.mission_ids: tuple[str, ...] = ()

    def install(self, mission_id: str, annotations: list[Annotation]) -> None:
        """Hold mission `mission_id`'s annotations in place of the last mission's (DuplicateAnnotation on a clash: nothing changes)."""
        old = [self.db.remove(aid) for aid in self.mission_ids]
        added: list[str] = []
        try:
            for a in annotations:
                self.db.add(a)
                added.append(a.id)
        except Exception:
            for aid in added:
                self.db.remove(aid)
            for a in old:
                self.db.add(a)
            raise
        self.walker.changed(added, [a.id for a in old])
        self.mission_id, self.mission_ids = mission_id, tuple(added)

    def used(self) -> tuple[str, ...]:
        """Return the ids of the annotations whose `used` flag is set, sorted."""
        return tuple(sorted(a.id for a in self.db if a.used))

    def restore_used(self, ids: tuple[str, ...]) -> None:
        """Set the `used` flag of annotations `ids` (a state saved before a restart)."""
        for aid in ids:
            self.db.set_used(aid)

    def catch_up(self, path_local: list[tuple[float, float]], w: WorldFromLocal) -> TravelledCycle:
        """Travel the path (≥ 1 point, [m] `local`) driven while the manager was away, under world←local `w`.

        The walk starts at the path's first point without firing (as a first cycle does), then fires
        every unused trigger the path meets, in travel order.
        """
        self._w = w
        x, y = world_of(w, *path_local[0])
        events = self.walker.reset(x, y)
        for px, py in path_local[1:]:
            x, y = world_of(w, px, py)
            events += self.walker.advance(x, y)
        return TravelledCycle(x=x, y=y, events=tuple(events))

    def query(self, q: AnnotationQuery) -> AnnotationList:
        """Answer `q`: every annotation of its type within its polygon [m `world`]."""
        return AnnotationList(annotations=tuple(record_of(a) for a in self.db.query(q.type, q.polygon)))

    def cycle(self, local_x: float, local_y: float, w: WorldFromLocal) -> TravelledCycle:
        """Travel to controller position (local_x, local_y) [m `local`] under world←local `w`; return the events."""
        prev = self._w
        self._w = w
        events: list[TriggerEvent] = []
        if prev is not None and (prev.x, prev.y, prev.yaw) != (w.x, w.y, w.yaw):
            events += self.walker.advance(*world_of(prev, local_x, local_y))
            x, y = world_of(w, local_x, local_y)
            events += self.walker.jump(x, y)
        else:
            x, y = world_of(w, local_x, local_y)
            events += self.walker.advance(x, y)
        return TravelledCycle(x=x, y=y, events=tuple(events))
