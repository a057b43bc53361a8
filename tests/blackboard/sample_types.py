"""Token types used by the blackboard tests (imported by test nodes with --types)."""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from blackboard import token_type

__all__ = ["Landmark", "Segment", "Obstacle"]


@token_type("bbt_landmark")
class Landmark(BaseModel):
    """A mapped landmark."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    name: str
    kind: Literal["tree", "mailbox", "lamp", "building"] = "tree"
    height: float = Field(1.0, ge=0.0)
    tags: tuple[str, ...] = ()
    info: dict[str, int] = {}


@token_type("bbt_segment")
class Segment(BaseModel):
    """A route segment."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    index: int
    mode: str = "follow-road"


@token_type("bbt_obstacle")
class Obstacle(BaseModel):
    """An obstacle seen by perception."""

    model_config = ConfigDict(frozen=True, extra="forbid")
    confidence: float = Field(ge=0.0, le=1.0)
