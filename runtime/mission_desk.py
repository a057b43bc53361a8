"""The mission desk: where both architectures take missions in, queue them, answer their status and cancel them.

One implementation of the mission contract (`wire.mission`, keys `wire.keys.MissionKeys`) for the
CAPTAIN under CODGER and EDDIE's mission service: the `submit`, `status/<id>` and `cancel`
queryables, the queue (one mission runs at a time, the others wait in order), the `events` stream
that carries every status as it changes, and the rejections with their wire codes (`invalid_mission`,
`no_route`, `unknown_mission`, `finished`, `bad_request`). What differs between the architectures is
a `MissionRoom`: how a submitted payload becomes a mission (and what is checked before it is
accepted), what is stored besides the stream (the CAPTAIN's status token on the blackboard), how a
running mission is cancelled, and where a running mission is (its progress).
"""

from __future__ import annotations

import asyncio
from collections import deque
from typing import Callable, Generic, Protocol, TypeVar

from pydantic import BaseModel

from runtime.errors import ModuleRuntimeError
from wire.aio import Link, QueryAnswer, QueryRequest
from wire.keys import MissionKeys
from wire.mission import MissionRequestError, Rejection, SubmitAccepted, new_mission_id, parse_cancel

__all__ = ["MissionDesk", "MissionEntry", "MissionRejected", "MissionRoom", "MissionState"]


class MissionState(Protocol):
    """What the desk reads of a mission's status (the vocabulary's `MissionStatus`)."""

    mission_id: str
    name: str
    state: str
    step_count: int

    @property
    def terminal(self) -> bool: ...

    def model_dump_json(self) -> str: ...


class MissionEntry(Protocol):
    """One mission a room keeps: its status, and how it is cancelled while it waits in the queue."""

    @property
    def status(self) -> MissionState: ...

    def cancel(self, now: float, reason: str) -> None: ...


E = TypeVar("E", bound=MissionEntry)


class MissionRejected(ModuleRuntimeError):
    """A submitted mission refused before it was queued; carries the contract's `Rejection`."""

    def __init__(self, rejection: Rejection) -> None:
        super().__init__(rejection.message)
        self.rejection = rejection


class MissionRoom(Protocol[E]):
    """What an architecture adds to the desk."""

    #: how rejections name the service ("CAPTAIN", "mission service")
    noun: str

    async def admit(self, payload: bytes) -> E:
        """Return the entry of a submitted mission (YAML or JSON text); raise `MissionRejected`."""

    async def accepted(self, entry: E, ahead: int) -> None:
        """Prepare an accepted mission before it is queued, with `ahead` missions before it."""

    async def stored(self, entry: E) -> None:
        """Keep the entry's changed status wherever the architecture keeps it besides the stream."""

    def answered(self, entry: E) -> BaseModel:
        """Return the entry's status as a status query is answered (a running mission's with its progress)."""

    async def cancel_running(self, entry: E, reason: str) -> None:
        """Cancel the running mission `entry` (its status may turn `cancelled` later, when the run loop sees it)."""


class MissionDesk(Generic[E]):
    """Missions in, statuses out, on one namespace's mission keys; one mission at a time, the others queued."""

    def __init__(self, link: Link, keys: MissionKeys, room: MissionRoom[E], now: Callable[[], float], *,
                 keep_finished: int = 100) -> None:
        """Serve on `link` at `keys` for `room`; `now()` is sim time [s]; keep at most `keep_finished` finished missions."""
        self.link = link
        self.keys = keys
        self.room = room
        self.now = now
        self.keep_finished = keep_finished
        self.entries: dict[str, E] = {}
        self.queue: deque[str] = deque()
        self._wake = asyncio.Event()

    def declare(self) -> None:
        """Declare the submit, status and cancel queryables on the link."""
        self.link.queryable(self.keys.submit, self.on_submit)
        self.link.queryable(self.keys.status("*"), self.on_status)
        self.link.queryable(self.keys.cancel, self.on_cancel)

    # ---- the queue ------------------------------------------------------------------------

    def unique_id(self, mission_id: str, name: str) -> str:
        """Return `mission_id`, or a fresh id when it is empty or already taken."""
        return mission_id if mission_id and mission_id not in self.entries else new_mission_id(name)

    def ahead(self) -> int:
        """Return how many missions a mission accepted now would wait for (queued, and the one running)."""
        return len(self.queue) + sum(1 for e in self.entries.values() if e.status.state == "running")

    async def accept(self, entry: E) -> SubmitAccepted:
        """Queue an admitted mission after its room prepared it; announce its status on the stream."""
        st = entry.status
        ahead = self.ahead()
        await self.room.accepted(entry, ahead)
        self.entries[st.mission_id] = entry
        self.announce(entry)
        # queued only once it is prepared: a waiting run loop picks a queued mission up at once
        self.queue.append(st.mission_id)
        self._wake.set()
        self._prune()
        return SubmitAccepted(mission_id=st.mission_id, name=st.name, steps=st.step_count, queued_behind=ahead)

    async def next(self) -> E:
        """Wait for the next queued mission that is not finished, and return it."""
        while True:
            while not self.queue:
                self._wake.clear()
                await self._wake.wait()
            e = self.entries.get(self.queue.popleft())
            if e is not None and not e.status.terminal:
                return e

    def _prune(self) -> None:
        done = [k for k, e in self.entries.items() if e.status.terminal]
        for k in done[: max(0, len(done) - self.keep_finished)]:
            del self.entries[k]

    # ---- statuses -------------------------------------------------------------------------

    def announce(self, entry: E) -> None:
        """Put the entry's status on the events stream (`z_sub -k sidewalk/<ns>/mission/events` follows it)."""
        self.link.put(self.keys.events, entry.status.model_dump_json().encode(), as_json=True)

    async def publish(self, entry: E) -> None:
        """Announce the entry's changed status and let the room store it."""
        self.announce(entry)
        await self.room.stored(entry)

    async def cancel(self, mission_id: str, reason: str = "cancelled by request") -> MissionState:
        """Cancel a queued or running mission; raise KeyError (unknown) or ValueError (already finished)."""
        e = self.entries.get(mission_id)
        if e is None:
            raise KeyError(mission_id)
        if e.status.terminal:
            raise ValueError(f"mission {mission_id} already {e.status.state}")
        if mission_id in self.queue:
            self.queue.remove(mission_id)
            e.cancel(self.now(), reason)
            await self.publish(e)
        else:
            await self.room.cancel_running(e, reason)
        return e.status

    # ---- the queryables -------------------------------------------------------------------

    def _unknown(self, mission_id: str) -> QueryAnswer:
        return QueryAnswer(as_json=True, ok=False, payload=Rejection(
            error="unknown_mission", message=f"no mission {mission_id[:80]!r} known to this {self.room.noun}").to_bytes())

    async def on_submit(self, req: QueryRequest) -> QueryAnswer:
        """Answer a submission: YAML or JSON text → the accepted mission's id, or a rejection naming lines and fields."""
        try:
            entry = await self.room.admit(req.payload)
        except MissionRejected as exc:
            return QueryAnswer(as_json=True, ok=False, payload=exc.rejection.to_bytes())
        acc = await self.accept(entry)
        return QueryAnswer(as_json=True, ok=True, payload=acc.model_dump_json().encode())

    async def on_status(self, req: QueryRequest) -> QueryAnswer:
        """Answer `…/mission/status/<id>` (or `*`) with MissionStatus JSON (a running mission's with its progress)."""
        mid = req.key.rsplit("/", 1)[-1]
        if mid in ("*", "**"):
            return QueryAnswer(as_json=True, ok=True, replies=tuple(
                (self.keys.status(k), self.room.answered(e).model_dump_json().encode()) for k, e in self.entries.items()))
        e = self.entries.get(mid)
        if e is None:
            return self._unknown(mid)
        return QueryAnswer(as_json=True, ok=True, payload=self.room.answered(e).model_dump_json().encode(), key=self.keys.status(mid))

    async def on_cancel(self, req: QueryRequest) -> QueryAnswer:
        """Answer a cancel request (mission id text or JSON) with the mission's status, or a rejection."""
        try:
            creq = parse_cancel(req.payload)
            st = await self.cancel(creq.mission_id, creq.reason)
        except MissionRequestError as exc:
            return QueryAnswer(as_json=True, ok=False, payload=Rejection(error="bad_request", message=str(exc)).to_bytes())
        except KeyError as exc:
            return self._unknown(str(exc.args[0]))
        except ValueError as exc:
            return QueryAnswer(as_json=True, ok=False, payload=Rejection(error="finished", message=str(exc)).to_bytes())
        return QueryAnswer(as_json=True, ok=True, payload=st.model_dump_json().encode())
