"""A client's copy of the node's frame tree, so that a frame conversion costs no round trip.

The blackboard converts between coordinate frames with the vehicle's pose history (`frames`). A
client that converts often (PERCEPTION mapping every driving unit, a bench converting 10,000 points)
pays a node round trip per lookup; ROS's tf2 answers the same need with a listener that keeps the
tree in each process. This is that listener, kept exact:

- the node publishes every commit that changed frames on `bb/frames/updates` as
  `[epoch, seq, changes]` (`epoch` names the node's life, `seq` counts such commits), before
  acknowledging the commit or sending its monitor events; a change is
  `["p", parent, child, x, y, yaw, stamp, hold]` or `["s", parent, child, x, y, yaw]` ([m], [rad], [s]);
- the cache subscribes first, then asks `bb/frames/history` for the whole tree with the `[epoch, seq]`
  it is current to, and applies the updates held meanwhile that are newer;
- a gap in `seq`, a new `epoch` (the node restarted) or a malformed update empties it until the
  whole tree is fetched again; while the node is away it answers nothing.

So an answer is the node's own (the same `FrameTree` over the same samples, with the same history
bounds) as of the last commit this client has heard of. A lookup the cache cannot answer (empty,
an unknown frame, a time outside the history) goes to the node, which gives the authoritative
answer or error. What a cache cannot know is a commit still on its way to it: a lookup racing a
pose posted by another process may answer from the sample before it, as a node lookup that arrived
a moment earlier would. Anything told through the blackboard (a monitor event, an acknowledgement)
arrives after the frames of the same commit.
"""

from __future__ import annotations

import logging
from typing import Any

from blackboard.errors import BlackboardError
from blackboard.frames import FrameTree
from wire.se2 import SE2

__all__ = ["FrameCache", "FrameCacheStats"]

log = logging.getLogger("blackboard.frame_cache")

#: updates held while the cache has no tree, at most
MAX_HELD = 10_000


class FrameCacheStats:
    """Counters of one cache: lookups answered here (`hits`) or sent to the node (`misses`), whole-tree fetches, gaps seen."""

    __slots__ = ("hits", "misses", "primes", "gaps", "updates")

    def __init__(self) -> None:
        self.hits = self.misses = self.primes = self.gaps = self.updates = 0

    def as_dict(self) -> dict[str, int]:
        """Return the counters by name."""
        return {k: getattr(self, k) for k in self.__slots__}


class FrameCache:
    """The frame tree as of the last frame commit heard from the node (single-threaded: use it on one loop)."""

    def __init__(self) -> None:
        self.tree: FrameTree | None = None
        self.epoch: str | None = None
        self.seq = 0
        #: updates heard while there is no tree (None once there is one), applied after the tree fetched
        self._held: list[list] | None = []
        self.stats = FrameCacheStats()

    @property
    def ready(self) -> bool:
        """Return whether the cache holds the node's tree (False: every lookup goes to the node)."""
        return self.tree is not None

    def invalidate(self, why: str = "") -> None:
        """Forget the tree (the node went away, or an update was missed) and hold updates until `prime`."""
        if self.tree is not None and why:
            log.info("frame cache emptied: %s", why)
        self.tree, self.epoch, self.seq, self._held = None, None, 0, []

    def prime(self, history: dict) -> bool:
        """Take the whole tree as `bb/frames/history` answers it, then the updates held meanwhile that are newer.

        Return whether the cache holds a tree after (False: a held update did not follow on; fetch again).
        Raise BlackboardError (the cache stays empty) on an answer that is not a frame history.
        """
        try:
            tree = FrameTree.from_history_wire(history["edges"], history=float(history["history"]),
                                               max_samples=int(history["max_samples"]), inertial=tuple(history["inertial"]))
            epoch, seq = str(history["epoch"]), int(history["seq"])
        except BlackboardError:
            self.invalidate()
            raise
        except (KeyError, TypeError, ValueError) as exc:
            self.invalidate()
            raise BlackboardError(f"bb/frames/history: not a frame history ({type(exc).__name__}: {exc})"[:300]) from None
        held, self._held = self._held or [], None
        self.tree, self.epoch, self.seq = tree, epoch, seq
        self.stats.primes += 1
        for msg in held:
            if not self.update(msg):
                return False
        return True

    def update(self, msg: Any) -> bool:
        """Apply one `[epoch, seq, changes]` from `bb/frames/updates`; return False when the cache needs the whole tree again."""
        if self._held is not None:  # no tree yet (it is being fetched): keep the update for after
            if len(self._held) >= MAX_HELD:
                self._held.clear()  # the tree fetched will be newer than these; a gap after it asks again
            self._held.append(msg)
            return True
        assert self.tree is not None
        try:
            epoch, seq, changes = msg
            seq = int(seq)
        except (TypeError, ValueError):
            self.invalidate("a malformed frame update")
            self.stats.gaps += 1
            return False
        if epoch == self.epoch and seq <= self.seq:
            return True  # already in the tree it fetched
        if epoch != self.epoch or seq != self.seq + 1:
            self.invalidate(f"frame update {epoch}/{seq} after {self.epoch}/{self.seq}")
            self.stats.gaps += 1
            return False
        try:
            for ch in changes:
                if ch[0] == "p":
                    _, parent, child, x, y, yaw, stamp, hold = ch
                    self.tree.add_pose(parent, child, (float(x), float(y), float(yaw)), float(stamp),
                                       hold=float("inf") if hold is None else float(hold))
                else:
                    _, parent, child, x, y, yaw = ch
                    self.tree.set_static(parent, child, (float(x), float(y), float(yaw)))
        except (BlackboardError, TypeError, ValueError) as exc:
            self.invalidate(f"frame update {epoch}/{seq} does not apply: {exc}")
            self.stats.gaps += 1
            return False
        self.seq = seq
        self.stats.updates += 1
        return True

    def lookup(self, target: str, target_stamp: float | None, source: str, source_stamp: float | None) -> SE2 | None:
        """Return T_{target@target_stamp ← source@source_stamp} from the cached tree, or None for the node to answer."""
        tree = self.tree
        if tree is None:
            self.stats.misses += 1
            return None
        try:
            T = tree.lookup(target, target_stamp, source, source_stamp)
        except BlackboardError:
            self.stats.misses += 1
            return None
        self.stats.hits += 1
        return T
