"""Sidewalk: the composition root (CLI, launcher, missions, reports, compare)."""

__all__: list[str] = []
