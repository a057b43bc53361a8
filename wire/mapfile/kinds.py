"""The vocabularies of world and map files: object kinds and their label indices, roles, path-graph modes, shapes by kind."""

from __future__ import annotations

from typing import Literal

__all__ = ["KINDS", "OBJECT_KINDS", "KIND_PRIORITY", "ROLES", "EDGE_MODES", "NODE_KINDS", "EdgeMode", "SHAPES_BY_KIND"]

#: Class names for per-pixel labels; `label_at` returns indices into this tuple.
#: "none" = no object there; "sky" is for sensors (rays that hit nothing), never returned by `label_at`.
KINDS: tuple[str, ...] = (
    "none",
    "grass",
    "road",
    "driveway",
    "sidewalk",
    "intersection",
    "slope",
    "stairs",
    "building",
    "tree",
    "mailbox",
    "lamp_post",
    "bench",
    "hedge",
    "sign",
    "hydrant",
    "wall",
    "rock",
    "sky",
)

#: Kinds an object feature may have.
OBJECT_KINDS: tuple[str, ...] = tuple(k for k in KINDS if k not in ("none", "sky"))

#: Painting priority for ground queries: higher paints over lower; ties: later feature wins.
KIND_PRIORITY: dict[str, int] = {
    "grass": 0,
    "driveway": 1,
    "road": 2,
    "sidewalk": 3,
    "intersection": 4,
    "slope": 5,
    "stairs": 5,
    "hedge": 6,
    "wall": 6,
    "rock": 6,
    "building": 7,
    "tree": 8,
    "mailbox": 8,
    "lamp_post": 8,
    "bench": 8,
    "sign": 8,
    "hydrant": 8,
}

ROLES: tuple[str, ...] = ("path", "landmark", "obstacle", "none")
EDGE_MODES: tuple[str, ...] = (
    "follow-road",
    "go-through-slope",
    "climb-stairs",
    "turn-at-intersection",
    "go-through-intersection",
)
NODE_KINDS: tuple[str, ...] = ("intersection", "place")
#: The navigation mode of a path-graph edge (one of `EDGE_MODES`).
EdgeMode = Literal["follow-road", "go-through-slope", "climb-stairs", "turn-at-intersection", "go-through-intersection"]

#: Which shape types each kind may carry (ground covers are flat/slope; stairs are stairs; …).
SHAPES_BY_KIND: dict[str, tuple[str, ...]] = {
    "grass": ("flat", "slope"),
    "road": ("flat", "slope"),
    "driveway": ("flat", "slope"),
    "sidewalk": ("flat", "slope"),
    "intersection": ("flat", "slope"),
    "slope": ("slope",),
    "stairs": ("stairs",),
    "building": ("prism",),
    "hedge": ("prism",),
    "wall": ("prism",),
    "rock": ("prism", "post", "flat"),  # flat: a rock of a terrain world, its shape in the terrain raster
    "tree": ("tree",),
    "mailbox": ("post", "prism"),
    "lamp_post": ("post",),
    "bench": ("prism", "post"),
    "sign": ("post",),
    "hydrant": ("post",),
}
