"""Objects that are not on the map: parked cars, walkers on scripted paths, a bin left on a sidewalk.

An actor is a box (length × width × height [m]) moving along a scripted path of waypoints in the
`world` frame: it waits `start_after` [s] of sim time, or until the vehicle first comes within
`trigger_distance` [m], then walks the waypoints at `speed` [m/s], dwelling `dwell` [s] at each
waypoint that names one; at the last waypoint it stays (or is gone when `vanish` is set). Actors are
declared in an actors file (JSON or YAML: `{"actors": [...]}`), picked by preset name, or listed in the
world file's optional top-level `actors` (the same entries), and are truth: only the simulator
renders them and counts collisions with them (and evaluation replays them).
"""

from __future__ import annotations

from vehicle_sim.errors import SimError

import json
import math
from pathlib import Path
from typing import Literal

import numpy as np
import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

__all__ = [
    "ActorError",
    "Waypoint",
    "Actor",
    "ActorSet",
    "ActorState",
    "ACTOR_PRESETS",
    "ACTOR_SIZES",
    "load_actors",
    "actors_from_doc",
]

#: Default box (length, width, height) [m] and colour (RGB mean) per actor kind.
ACTOR_SIZES: dict[str, tuple[float, float, float]] = {
    "car": (4.4, 1.8, 1.5),
    "pedestrian": (0.5, 0.6, 1.75),
    "dog": (0.9, 0.35, 0.6),
    "bin": (0.7, 0.7, 1.1),
}
_COLOURS: dict[str, tuple[float, float, float]] = {
    "car": (150.0, 30.0, 35.0),
    "pedestrian": (60.0, 70.0, 120.0),
    "dog": (120.0, 90.0, 60.0),
    "bin": (40.0, 90.0, 50.0),
}


class ActorError(SimError, ValueError):
    """A bad actors file or preset name (the message names where and what)."""


class Waypoint(BaseModel):
    """One point of an actor's path, `world` frame [m]; `dwell` [s] spent there on arrival."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    x: float
    y: float
    dwell: float = Field(0.0, ge=0.0)


class Actor(BaseModel):
    """An object not on the map: a box on a scripted path (see the module docstring)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    id: str = Field(min_length=1)
    kind: Literal["car", "pedestrian", "dog", "bin"]
    path: tuple[Waypoint, ...] = Field(min_length=1)
    speed: float = Field(1.2, gt=0.0)  # [m/s]
    start_after: float = Field(0.0, ge=0.0)  # [s]
    trigger_distance: float | None = Field(None, gt=0.0)  # [m]
    vanish: bool = False
    size: tuple[float, float, float] | None = None  # (length, width, height) [m]
    yaw_deg: float | None = None  # heading while standing before the first move [deg]
    reflectance: float = Field(0.5, gt=0.0, le=1.0)

    @property
    def box(self) -> tuple[float, float, float]:
        """Return (length, width, height) [m]."""
        return self.size if self.size is not None else ACTOR_SIZES[self.kind]

    @property
    def colour(self) -> tuple[float, float, float]:
        """Return the RGB mean colour [0–255]."""
        return _COLOURS[self.kind]


class ActorState(BaseModel):
    """Where an actor is at one sim time: centre (x, y) [m] and heading yaw [rad], `world` frame."""

    model_config = ConfigDict(frozen=True)

    id: str
    kind: str
    x: float
    y: float
    yaw: float
    present: bool
    moving: bool


def _timeline(a: Actor) -> list[tuple[float, float, float, float]]:
    """Return (t_rel [s], x, y, yaw) knots of an actor's path from its start (piecewise linear)."""
    p = a.path
    yaw0 = math.radians(a.yaw_deg) if a.yaw_deg is not None else (
        math.atan2(p[1].y - p[0].y, p[1].x - p[0].x) if len(p) > 1 else 0.0)
    out = [(0.0, p[0].x, p[0].y, yaw0)]
    t, yaw = 0.0, yaw0
    if p[0].dwell:
        t += p[0].dwell
        out.append((t, p[0].x, p[0].y, yaw))
    for a0, a1 in zip(p[:-1], p[1:]):
        d = math.hypot(a1.x - a0.x, a1.y - a0.y)
        if d > 1e-9:
            yaw = math.atan2(a1.y - a0.y, a1.x - a0.x)
            out[-1] = (out[-1][0], out[-1][1], out[-1][2], out[-1][3])
            t += d / a.speed
            out.append((t, a1.x, a1.y, yaw))
        if a1.dwell:
            t += a1.dwell
            out.append((t, a1.x, a1.y, yaw))
    return out


class ActorSet:
    """The actors of one run and their scripted motion; `update` once per physics step, then query."""

    def __add__(self, other: "ActorSet") -> "ActorSet":
        """Return the actors of both sets (ids must stay unique)."""
        return ActorSet(self.actors + other.actors)

    def __init__(self, actors: tuple[Actor, ...] | list[Actor] = ()) -> None:
        ids = [a.id for a in actors]
        if len(set(ids)) != len(ids):
            raise ActorError(f"actors: duplicate ids in {ids}")
        self.actors = tuple(actors)
        self._knots = [np.asarray(_timeline(a), np.float64) for a in self.actors]
        self._started: list[float | None] = [None if a.trigger_distance is not None else a.start_after for a in self.actors]

    def __len__(self) -> int:
        return len(self.actors)

    def update(self, t: float, vehicle_xy: tuple[float, float]) -> None:
        """Start proximity-triggered actors whose trigger the vehicle at `vehicle_xy` [m] reached at sim time `t` [s]."""
        for i, a in enumerate(self.actors):
            if self._started[i] is None and a.trigger_distance is not None:
                p = a.path[0]
                if math.hypot(vehicle_xy[0] - p.x, vehicle_xy[1] - p.y) <= a.trigger_distance:
                    self._started[i] = float(t) + a.start_after

    def states(self, t: float) -> list[ActorState]:
        """Return every actor's state at sim time `t` [s] (call `update` first for triggered actors)."""
        out = []
        for a, k, t0 in zip(self.actors, self._knots, self._started):
            rel = -1.0 if t0 is None else float(t) - t0
            if rel <= 0.0:
                x, y, yaw, moving, present = k[0, 1], k[0, 2], k[0, 3], False, True
            elif rel >= k[-1, 0]:
                x, y, yaw, moving, present = k[-1, 1], k[-1, 2], k[-1, 3], False, not a.vanish
            else:
                j = int(np.searchsorted(k[:, 0], rel, side="right"))
                ta, tb = k[j - 1, 0], k[j, 0]
                f = (rel - ta) / max(tb - ta, 1e-12)
                x = k[j - 1, 1] + f * (k[j, 1] - k[j - 1, 1])
                y = k[j - 1, 2] + f * (k[j, 2] - k[j - 1, 2])
                yaw = k[j, 3]
                moving = bool(np.hypot(k[j, 1] - k[j - 1, 1], k[j, 2] - k[j - 1, 2]) > 1e-9)
                present = True
            out.append(ActorState(id=a.id, kind=a.kind, x=float(x), y=float(y), yaw=float(yaw), present=present, moving=moving))
        return out

    def footprints(self, t: float) -> list[tuple[Actor, np.ndarray]]:
        """Return (actor, (4, 2) footprint corners [m], `world`) of every present actor at sim time `t` [s]."""
        out = []
        for a, s in zip(self.actors, self.states(t)):
            if s.present:
                out.append((a, box_corners(s.x, s.y, s.yaw, a.box[0], a.box[1])))
        return out


def box_corners(x: float, y: float, yaw: float, length: float, width: float) -> np.ndarray:
    """Return the (4, 2) corners [m] of a box centred at (x, y) heading yaw [rad], counter-clockwise."""
    c, s = math.cos(yaw), math.sin(yaw)
    hl, hw = 0.5 * length, 0.5 * width
    local = np.array([[hl, hw], [-hl, hw], [-hl, -hw], [hl, -hw]])
    return local @ np.array([[c, s], [-s, c]]) + (x, y)


#: Named actor sets for the shipped missions.
ACTOR_PRESETS: dict[str, dict] = {
    # amv-delivery on north_hills: a pedestrian steps into the northbound lane of Oak when the vehicle is
    # 30 m away, stands there 30 s (long enough for a vehicle crawling at 1 m/s to meet it), then crosses on;
    # a car parked in the westbound lane of Elm pulls away 30 s after the vehicle came within 25 m and
    # turns north onto Birch. Both stand in the path of either architecture: the walker stops at x = 0.5,
    # in front of a vehicle on the road's centre (EDDIE's road follower) and one keeping right (CODGER).
    "amv-delivery": {"actors": [
        {"id": "walker", "kind": "pedestrian", "speed": 1.4, "trigger_distance": 30.0,
         "path": [{"x": 5.0, "y": 40.0}, {"x": 0.5, "y": 40.0, "dwell": 30.0}, {"x": -6.0, "y": 40.0}]},
        {"id": "parked_car", "kind": "car", "speed": 5.0, "trigger_distance": 25.0, "start_after": 30.0,
         "yaw_deg": 180.0, "vanish": True,
         "path": [{"x": -175.0, "y": 241.5}, {"x": -233.0, "y": 241.5}, {"x": -238.5, "y": 247.0}, {"x": -238.5, "y": 300.0}]},
    ]},
    # a bin left on the Oak sidewalk edge and a dog crossing Oak, for the laser evaluation
    "north_hills-eval": {"actors": [
        {"id": "bin", "kind": "bin", "path": [{"x": 3.6, "y": 10.0}]},
        {"id": "dog", "kind": "dog", "speed": 1.5, "start_after": 0.0,
         "path": [{"x": -5.0, "y": 25.0}, {"x": 5.0, "y": 27.0}, {"x": -5.0, "y": 29.0}]},
        {"id": "car", "kind": "car", "yaw_deg": 90.0, "path": [{"x": -1.5, "y": 60.0}]},
    ]},
    # on campus, for the laser and FIDO evaluations (east of the south walk's first 60 m, which stays clear):
    # a bin on the south walk, a walker standing on the quad's walk, a dog that crosses the south walk and back in its
    # first 12 s and then stays on the grass beside it
    "campus-eval": {"actors": [
        {"id": "bin", "kind": "bin", "path": [{"x": 75.0, "y": 0.9}]},
        {"id": "walker", "kind": "pedestrian", "path": [{"x": 89.6, "y": 15.0}]},
        {"id": "dog", "kind": "dog", "speed": 1.0, "start_after": 0.0,
         "path": [{"x": 105.0, "y": -3.0}, {"x": 105.0, "y": 3.0}, {"x": 105.0, "y": -3.0}]},
    ]},
}


def load_actors(spec: str | Path) -> ActorSet:
    """Load an actors file (JSON or YAML) or a preset name; raise `ActorError` naming where and what."""
    text = str(spec)
    if text in ACTOR_PRESETS:
        doc, where = ACTOR_PRESETS[text], f"preset {text!r}"
    else:
        p = Path(text)
        if not p.is_file():
            raise ActorError(f"actors: {text!r} is neither a file nor a preset ({', '.join(sorted(ACTOR_PRESETS))})")
        where = str(p)
        try:
            raw = p.read_text()
            doc = json.loads(raw) if p.suffix == ".json" else yaml.safe_load(raw)
        except (OSError, ValueError, yaml.YAMLError) as exc:
            raise ActorError(f"{where}: cannot read: {exc}") from None
    return actors_from_doc(doc, where)


def actors_from_doc(doc, where: str) -> ActorSet:
    """Validate `{"actors": [...]}` read from `where` (a file, a preset, a world file); raise `ActorError` naming the entry."""
    if not isinstance(doc, dict) or not isinstance(doc.get("actors"), list):
        raise ActorError(f"{where}: expected a mapping with an 'actors' list")
    out = []
    for i, item in enumerate(doc["actors"]):
        try:
            out.append(Actor.model_validate(item))
        except ValidationError as exc:
            e = exc.errors()[0]
            raise ActorError(f"{where}: actors[{i}].{'.'.join(str(x) for x in e['loc'])}: {e['msg']}") from None
    try:
        return ActorSet(out)
    except ActorError as exc:
        raise ActorError(f"{where}: {exc}") from None
