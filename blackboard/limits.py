"""How large a token the node stores, per token type: bytes of attributes and geometry, points of geometry.

The node checks each posted or updated token once, where its stored bytes are known (the store
encodes them anyway), and refuses one too large with `TokenTooLargeError` (wire code
`token_too_large`) naming the type, the size and the limit; nothing else in the batch and nothing
stored is affected. Types are named here only (the blackboard imports none of them); a type not in
the table gets `DEFAULT_LIMIT`. The figures leave ample room over what a campus run posts (the
largest `route_segment` seen is 8 KB, a `driving_unit` 10 KB, a `local_path_plan` 6 KB).

| type | bytes | points |
|---|---|---|
| mission | 1 MiB | – (a mission file is at most 256 KB and 1,000 steps) |
| mission_step, step_result, mission_status | 64 KiB | – |
| route_plan | 256 KiB | 10,000 |
| route_segment | 256 KiB | 10,000 |
| segment_result, position_estimate, heartbeat | 16 KiB | 16 |
| map_object | 64 KiB | 4,096 |
| map_places | 256 KiB | 4,096 |
| driving_unit, local_path_constraints, local_path_plan, perception_result | 256 KiB | 4,096 |
| obstacle_report | 64 KiB | 1,024 |
| any other type | 64 KiB | 4,096 |
"""

from __future__ import annotations

from typing import NamedTuple

from blackboard.errors import TokenTooLargeError

__all__ = ["TokenLimit", "LIMITS", "DEFAULT_LIMIT", "limit_for", "check_token_size"]

KIB = 1024


class TokenLimit(NamedTuple):
    """The most bytes [B] of attributes plus geometry, and geometry points, one token may hold."""

    max_bytes: int
    max_points: int


DEFAULT_LIMIT = TokenLimit(64 * KIB, 4096)

_SMALL = TokenLimit(16 * KIB, 16)
_RECORD = TokenLimit(64 * KIB, 16)
_LOCAL = TokenLimit(256 * KIB, 4096)
_ROUTE = TokenLimit(256 * KIB, 10_000)

LIMITS: dict[str, TokenLimit] = {
    "mission": TokenLimit(1024 * KIB, 16),
    "mission_step": _RECORD,
    "step_result": _RECORD,
    "mission_status": _RECORD,
    "route_plan": _ROUTE,
    "route_segment": _ROUTE,
    "segment_result": _SMALL,
    "position_estimate": _SMALL,
    "heartbeat": _SMALL,
    "map_object": TokenLimit(64 * KIB, 4096),
    "map_places": TokenLimit(256 * KIB, 4096),
    "driving_unit": _LOCAL,
    "local_path_constraints": _LOCAL,
    "local_path_plan": _LOCAL,
    "perception_result": _LOCAL,
    "obstacle_report": TokenLimit(64 * KIB, 1024),
}


def limit_for(type_name: str) -> TokenLimit:
    """Return the limit of `type_name` (the default for a type not in the table)."""
    return LIMITS.get(type_name, DEFAULT_LIMIT)


def check_token_size(type_name: str, n_bytes: int, n_points: int) -> None:
    """Raise TokenTooLargeError if a `type_name` token of `n_bytes` [B] (attributes + geometry) and `n_points` exceeds its limit."""
    lim = LIMITS.get(type_name, DEFAULT_LIMIT)
    if n_bytes <= lim.max_bytes and n_points <= lim.max_points:
        return
    whose = "its type" if type_name in LIMITS else "a type without a limit of its own"
    what = (f"{n_points} geometry points exceeds the limit of {lim.max_points} points" if n_points > lim.max_points
            else f"{n_bytes} bytes exceeds the limit of {lim.max_bytes} bytes")
    raise TokenTooLargeError(f"a {type_name[:64]!r} token of {what} for {whose} (blackboard/limits.py)")
