"""What is wrong with a world or map file: each problem where (feature, field) and what, and the error naming them all."""

from __future__ import annotations

from typing import Iterable

from pydantic import BaseModel, ConfigDict

from wire.errors import WireError

__all__ = ["Problem", "WorldFileError"]


class Problem(BaseModel):
    """One thing wrong in a world file: where (feature index and id, field) and what."""

    model_config = ConfigDict(frozen=True)

    index: int | None = None
    feature_id: str | None = None
    field: str | None = None
    message: str

    def __str__(self) -> str:
        where = []
        if self.index is not None:
            where.append(f"feature #{self.index}")
        if self.feature_id is not None:
            where.append(f"id {self.feature_id!r}")
        head = " ".join(where) if where else "collection"
        fld = f" {self.field}:" if self.field else ":"
        return f"{head}{fld} {self.message}"


class WorldFileError(WireError, ValueError):
    """A world or map file that cannot be used; names the file, each bad feature and what is wrong."""

    def __init__(self, source: str, problems: Iterable[Problem]):
        self.source = source
        self.problems: tuple[Problem, ...] = tuple(problems)
        lines = [f"{source}: {len(self.problems)} problem(s)"]
        lines += [f"  {source}: {p}" for p in self.problems]
        super().__init__("\n".join(lines))
