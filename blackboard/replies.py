"""Blackboard replies that are more than a token or a pose: the frame listing and the node's counters."""

from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["FrameEdge", "FrameListing", "NodeStats"]


class FrameEdge(BaseModel):
    """One edge of the frame tree: `child` in `parent`; a moving one has its oldest and newest stamps [s]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    parent: str
    child: str
    static: bool
    oldest: float | None = Field(None, description="sim time of the oldest pose kept [s] (moving edges)")
    newest: float | None = Field(None, description="sim time of the newest pose [s] (moving edges)")

    def wire(self) -> dict[str, Any]:
        """Return the wire object (no stamps on a static edge)."""
        return self.model_dump(exclude_none=True)


class FrameListing(BaseModel):
    """The node's frame tree (`bb/frames`)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    edges: tuple[FrameEdge, ...] = ()

    def edge(self, parent: str, child: str) -> FrameEdge | None:
        """Return the edge `child` in `parent`, or None."""
        return next((e for e in self.edges if e.parent == parent and e.child == child), None)

    def wire(self) -> dict[str, Any]:
        """Return the wire object `{"edges": [...]}`."""
        return {"edges": [e.wire() for e in self.edges]}


class NodeStats(BaseModel):
    """The node's counters since start (`bb/stats`); the field names are the wire keys."""

    model_config = ConfigDict(frozen=True, extra="ignore")

    posts: int = 0
    updates: int = 0
    deletes: int = 0
    poses: int = 0
    statics: int = 0
    retrieves: int = 0
    lookups: int = 0
    monitors_registered: int = 0
    events: int = 0
    errors: int = 0
    commits: int = 0
    write_requests: int = 0
    bytes_in: int = Field(0, description="[bytes]")
    bytes_out: int = Field(0, description="[bytes]")
    busy_us: int = Field(0, description="time spent handling requests [µs]")
    tokens: int = Field(0, description="tokens held now")
    monitors: int = Field(0, description="monitors registered now")
