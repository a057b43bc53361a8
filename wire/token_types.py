"""Declared payload type names: model classes named once, bound by whoever decodes them, in any import order.

`modules.vocabulary` declares its token types here without importing the blackboard (EDDIE imports
the vocabulary and must not load it); the blackboard's default registry follows the declarations
(`follow`), replaying those made before it was imported.
"""

from __future__ import annotations

from typing import Any, Callable

__all__ = ["declare", "declared", "follow"]

_DECLARED: dict[str, type] = {}
_FOLLOWERS: list[Callable[[str, type], Any]] = []


def declare(name: str, model: type) -> None:
    """Declare `model` as payload type `name` and tell every follower."""
    _DECLARED[name] = model
    for f in list(_FOLLOWERS):
        f(name, model)


def declared() -> dict[str, type]:
    """Return every declaration so far (name → model)."""
    return dict(_DECLARED)


def follow(on_declare: Callable[[str, type], Any]) -> None:
    """Call `on_declare(name, model)` for every declaration, past and future."""
    _FOLLOWERS.append(on_declare)
    for name, model in list(_DECLARED.items()):
        on_declare(name, model)
