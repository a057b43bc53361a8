"""The blackboard client's frames: poses posted, lookups and point transforms, and the optional frame cache.

`post_pose` and `set_static_frame` are writes like any other (queued, batched, acknowledged). A
lookup asks the node (`bb/lookup`), or, with `frame_cache=True`, is answered here from a copy of the
node's frame tree (`blackboard.frame_cache`) whenever the copy can; the copy is filled on open, kept
current by the node's frame updates, and filled again after a gap or the node's return. Points are
mapped with the one SE(2) kernel, `wire.se2.transform_points`.

`_Frames` is one part of `blackboard.client.BlackboardClient`.
"""

from __future__ import annotations

import asyncio
import logging

import numpy as np

from blackboard._client_transport import _unpackb
from blackboard.errors import BadRequestError, BlackboardError
from blackboard.frame_cache import FrameCache
from blackboard.geometry import Pose2D
from blackboard.ops import LookupRequest, PoseOp, StaticOp
from blackboard.replies import FrameListing
from blackboard.token import _trusted
from wire.ratelimit import warn_limited
from wire.se2 import transform_points

__all__: list[str] = []

log = logging.getLogger("blackboard.client")
_POSE_FIELDS = {"x", "y", "yaw"}


class _Frames:
    """The client's side of the frame tree: poses and static frames posted, lookups, transforms, the frame cache."""

    def _init_frames(self, frame_cache: bool) -> None:
        """Keep a frame cache (`frame_cache`) or ask the node for every lookup."""
        #: a copy of the node's frame tree answering lookups here (`blackboard.frame_cache`; None: ask the node)
        self.frame_cache: FrameCache | None = FrameCache() if frame_cache else None
        self._prime_task: asyncio.Task | None = None
        self._frames_change = asyncio.Event()

    # ------------------------------------------------------------------ frame cache
    def _on_frames_update(self, payload: bytes) -> None:
        cache = self.frame_cache
        assert cache is not None
        try:
            msg = _unpackb(payload)
        except Exception:  # noqa: BLE001 - a malformed update: the cache fetches the whole tree again
            warn_limited(log, "malformed-frames", "malformed frame update on %s", self.keys.frame_updates)
            msg = None
        if not cache.update(msg):
            self._start_prime()

    def _start_prime(self) -> None:
        if self._closed or not self._node_alive or (self._prime_task is not None and not self._prime_task.done()):
            return
        assert self._loop is not None
        self._prime_task = self._loop.create_task(self._prime_frames())

    async def _prime_frames(self) -> None:
        """Fetch the node's whole frame tree into the cache; lookups go to the node until it holds one."""
        cache = self.frame_cache
        assert cache is not None
        for _ in range(5):  # a fetch overtaken by a gap in the updates is fetched again
            if self._closed or not self._node_alive:
                return
            try:
                history = await self._query(self.keys.frame_history, None)
                if cache.prime(history):
                    change, self._frames_change = self._frames_change, asyncio.Event()
                    change.set()
                    return
            except BlackboardError as exc:
                warn_limited(log, "frame-history", "%s: frame cache not filled, lookups go to the node: %s", self.source, exc)
                return
        log.warning("%s: frame cache: updates kept breaking off while fetching the tree; lookups go to the node", self.source)

    async def wait_frame_cache(self, primes: int, *, timeout: float | None = None) -> None:
        """Return once the frame cache holds a tree fetched `primes` times in all; TimeoutError after `timeout` [s] wall."""
        cache = self.frame_cache
        if cache is None:
            raise BadRequestError("this client keeps no frame cache (frame_cache=False)")
        async with asyncio.timeout(timeout):
            while not (cache.ready and cache.stats.primes >= primes):
                await self._frames_change.wait()

    # ------------------------------------------------------------------ frames
    def post_pose(self, *, parent: str, child: str, pose: Pose2D, stamp: float, hold: float | None = 0.0) -> "asyncio.Future[None]":
        """Record child's pose in parent at `stamp` [s]; `hold` [s] keeps the newest valid that long (None: forever).

        Queued when called, like `post`; await the returned future for the ack.
        """
        return self._write(PoseOp.trusted({"op": "pose", "parent": parent, "child": child, "pose": pose.as_tuple(),
                                           "stamp": stamp, "hold": hold}))

    def set_static_frame(self, *, parent: str, child: str, pose: Pose2D) -> "asyncio.Future[None]":
        """Fix `child` in `parent` for all times (e.g. a sensor on the vehicle); await the ack."""
        return self._write(StaticOp.trusted({"op": "static", "parent": parent, "child": child, "pose": pose.as_tuple()}))

    async def lookup(self, target: str, target_stamp: float | None, source: str, source_stamp: float | None) -> Pose2D:
        """Return T_{target@target_stamp ← source@source_stamp} (None stamp: newest).

        With a frame cache (`frame_cache=True`) answered here when the cached tree can, else by the node.
        """
        if self.frame_cache is not None:
            T = self.frame_cache.lookup(target, target_stamp, source, source_stamp)
            if T is not None:
                return _trusted(Pose2D, {"x": T[0], "y": T[1], "yaw": T[2]}, _POSE_FIELDS)
        x, y, yaw = await self._node_lookup(target, target_stamp, source, source_stamp)
        return _trusted(Pose2D, {"x": x, "y": y, "yaw": yaw}, _POSE_FIELDS)

    async def _node_lookup(self, target: str, target_stamp: float | None, source: str, source_stamp: float | None) -> tuple[float, float, float]:
        x, y, yaw = await self._request(self.keys.lookup, LookupRequest.trusted(
            {"target": target, "target_stamp": target_stamp, "source": source, "source_stamp": source_stamp}).wire())
        return (x, y, yaw)

    async def lookup_pose(self, *, parent: str, child: str, stamp: float | None = None) -> Pose2D:
        """Return the pose of `child` in `parent` at `stamp` [s] (None: newest)."""
        if stamp is None:
            return await self.lookup(parent, None, child, None)
        return await self.lookup(parent, stamp, child, stamp)

    async def transform(
        self,
        points: np.ndarray,
        *,
        src_frame: str,
        src_stamp: float | None,
        dst_frame: str,
        dst_stamp: float | None = None,
    ) -> np.ndarray:
        """Map (N,2) float64 points [m] from `src_frame@src_stamp` to `dst_frame@dst_stamp` (None: src_stamp)."""
        dst_at = src_stamp if dst_stamp is None else dst_stamp
        if self.frame_cache is not None:
            T3 = self.frame_cache.lookup(dst_frame, dst_at, src_frame, src_stamp)
            if T3 is not None:
                return transform_points(T3, points)
        return transform_points(await self._node_lookup(dst_frame, dst_at, src_frame, src_stamp), points)

    async def frames(self) -> FrameListing:
        """Return the node's frame tree (edges; oldest and newest stamps [s] of moving ones)."""
        return FrameListing.model_validate(await self._query(self.keys.frames, None))
