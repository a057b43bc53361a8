"""JSON for people and tools: never `NaN` or `Infinity` (not JSON; strict parsers refuse them), `null` instead.

Every `--json` output of the `sidewalk` CLI and every JSON file it writes for people (report.json,
compare.json) goes through `dumps`.
"""

from __future__ import annotations

import json
import math
from typing import Any

__all__ = ["finite", "dumps"]


def finite(obj: Any) -> Any:
    """Return `obj` with every non-finite float (in dicts, lists and tuples, at any depth) replaced by None."""
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, dict):
        return {k: finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [finite(v) for v in obj]
    return obj


def dumps(obj: Any, **kw: Any) -> str:
    """Return `obj` as JSON text, non-finite floats as `null` (`json.dumps` keywords pass through)."""
    return json.dumps(finite(obj), allow_nan=False, **kw)
