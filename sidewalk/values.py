"""Tolerant readers of decoded message values (msgpack or JSON maps from other processes or recordings)."""

from __future__ import annotations

from typing import Any

__all__ = ["num", "points_of"]


def num(v: Any, default: float = 0.0) -> float:
    """Return `v` as a float, or `default` when it is missing or not a number."""
    try:
        return float(v)
    except (TypeError, ValueError):
        return default


def points_of(v: Any) -> list[tuple[float, float]]:
    """Return (x, y) pairs [m] of a list of [x, y] pairs or of {x, y} maps (anything else: none)."""
    out = []
    for p in v or ():
        if isinstance(p, dict) and "x" in p and "y" in p:
            out.append((num(p["x"]), num(p["y"])))
        elif isinstance(p, (list, tuple)) and len(p) >= 2:
            out.append((num(p[0]), num(p[1])))
    return out
