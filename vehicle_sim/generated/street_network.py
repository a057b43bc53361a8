"""A street network drawn from a seed: a delivery route through 3–6 crossings, with bends, turns and side streets.

The route leaves the `start` place, runs a leg (straight, or straight–arc–straight with a bend of
50–150 m radius) to each crossing, and there goes straight on, turns left or turns right (at least
one of each turn per network). The street crossing the route meets it at 55–125°; a crossing is
four-way or a T (one of the streets the route does not take is left out). Every street the route
does not take is a dead-end side street to a place of its own (`x2_left`, …). After the last
crossing a straight leg passes the destination place `mailbox` and ends at the place `end`.
The network is a tree, so the route is the one way from `start` to `mailbox`.

Frames: `world` (x east, y north) [m]; headings are math angles [rad] CCW from +x.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
import shapely
from pydantic import BaseModel, ConfigDict, Field

from wire.se2 import wrap_angle

__all__ = ["NetworkParams", "Junction", "Street", "StreetNetwork", "draw_network", "ARC_STEP_M"]

#: Spacing [m] of the points sampled along a bend.
ARC_STEP_M = 4.0

Turn = Literal["through", "left", "right"]


class NetworkParams(BaseModel):
    """What a street network is made of: counts, lengths [m], angles [deg], the road's width and reach into crossings [m]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    crossings: tuple[int, int] = (3, 6)  # route crossings, drawn in this range (inclusive)
    crossing_deg: tuple[float, float] = (55.0, 125.0)  # angle between the route's incoming street and the crossing street
    t_share: float = Field(0.4, ge=0.0, le=1.0)  # share of crossings that are T-junctions (at least one is)
    bend_share: float = Field(0.5, ge=0.0, le=1.0)  # share of legs with a bend (at least one has)
    bend_radius_m: tuple[float, float] = (50.0, 150.0)
    bend_deg: tuple[float, float] = (20.0, 60.0)  # heading change of a bend
    bend_arc_max_m: float = 100.0  # a bend's arc is at most this long
    straight_m: tuple[float, float] = (30.0, 45.0)  # straight before and after a bend
    straight_after_bend_m: float = 30.0  # at least this straight between a bend and the next crossing
    leg_m: tuple[float, float] = (60.0, 110.0)  # a straight leg
    side_street_m: tuple[float, float] = (35.0, 55.0)
    final_leg_m: tuple[float, float] = (70.0, 95.0)
    destination_m: tuple[float, float] = (40.0, 55.0)  # from the last crossing to the destination
    road_width_m: float = 6.0
    reach_m: float = 9.0  # a crossing's area reaches this far along each street from its node
    street_gap_m: float = 32.0  # least distance between streets that do not meet


@dataclass(frozen=True)
class Junction:
    """A crossing of the route: its node, where it is [m], the crossing angle [deg], what the route does there, its streets' headings [rad]."""

    id: str
    xy: tuple[float, float]
    angle_deg: float
    turn: Turn
    kind: Literal["cross", "T", "Y"]  # Y: a fork (campus walks, `walkways`)
    arms: tuple[float, ...]  # headings [rad] of every street leaving the node, the incoming one included


@dataclass(frozen=True)
class Street:
    """A street between two nodes: its centreline (K, 2) float64 [m] from node `a` to node `b`; whether the route drives it."""

    id: str
    a: str
    b: str
    line: np.ndarray
    on_route: bool

    @property
    def length(self) -> float:
        """Return the centreline's length [m]."""
        return float(np.sum(np.hypot(*np.diff(self.line, axis=0).T)))


@dataclass(frozen=True)
class StreetNetwork:
    """A drawn network: places and junctions by node id, streets, the route's node ids, its turns, its start heading [rad]."""

    places: dict[str, tuple[float, float]]
    junctions: tuple[Junction, ...]
    streets: tuple[Street, ...]
    route: tuple[str, ...]
    start_yaw: float
    bends: tuple[tuple[float, float], ...]  # (radius [m], heading change [deg], signed) of each bend drawn

    def node_xy(self, nid: str) -> tuple[float, float]:
        """Return where node `nid` is [m]."""
        if nid in self.places:
            return self.places[nid]
        return next(j.xy for j in self.junctions if j.id == nid)

    def route_line(self) -> np.ndarray:
        """Return the route's centreline (K, 2) [m] from `start` to `mailbox`."""
        parts = []
        for a, b in zip(self.route[:-1], self.route[1:]):
            s = next(s for s in self.streets if {s.a, s.b} == {a, b})
            line = s.line if s.a == a else s.line[::-1]
            parts.append(line if not parts else line[1:])
        return np.vstack(parts)


def _unit(h: float) -> np.ndarray:
    return np.array([math.cos(h), math.sin(h)])


def _leg(rng: np.random.Generator, p: NetworkParams, pos: np.ndarray, h: float, bend: bool
         ) -> tuple[np.ndarray, float, tuple[float, float] | None]:
    """Return a leg's centreline (K, 2) [m] from `pos` heading `h` [rad], its end heading [rad] and its bend (radius, deg) or None."""
    if not bend:
        return np.vstack([pos, pos + float(rng.uniform(*p.leg_m)) * _unit(h)]), h, None
    a = float(rng.uniform(*p.straight_m))
    b = max(float(rng.uniform(*p.straight_m)), p.straight_after_bend_m)
    radius = float(rng.uniform(*p.bend_radius_m))
    most = min(p.bend_deg[1], math.degrees(p.bend_arc_max_m / radius))
    turn = math.radians(float(rng.uniform(p.bend_deg[0], max(most, p.bend_deg[0])))) * (1.0 if rng.random() < 0.5 else -1.0)
    p0 = pos + a * _unit(h)
    centre = p0 + radius * _unit(h + math.copysign(math.pi / 2, turn))
    n = max(2, int(math.ceil(radius * abs(turn) / ARC_STEP_M)))
    arc = [centre + radius * _unit(h - math.copysign(math.pi / 2, turn) + turn * k / n) for k in range(1, n + 1)]
    h1 = h + turn
    end = arc[-1] + b * _unit(h1)
    return np.vstack([pos, p0, *arc, end]), h1, (radius, math.degrees(turn))


def _plan(rng: np.random.Generator, p: NetworkParams, n: int) -> tuple[list[Turn], list[str], list[bool]]:
    """Return each crossing's turn and kind, and which of the n legs before crossings bend (at least one each of left, right, T, bend)."""
    turns: list[Turn] = [("through", "left", "right")[int(rng.integers(0, 3))] for _ in range(n)]
    if "left" not in turns or "right" not in turns:
        i, j = (int(k) for k in rng.choice(n, size=2, replace=False))
        turns[i], turns[j] = "left", "right"
    kinds = ["T" if rng.random() < p.t_share else "cross" for _ in range(n)]
    if "T" not in kinds:
        kinds[int(rng.integers(0, n))] = "T"
    bends = [bool(rng.random() < p.bend_share) for _ in range(n)]
    if not any(bends):
        bends[int(rng.integers(0, n))] = True
    return turns, kinds, bends


def draw_network(rng: np.random.Generator, p: NetworkParams) -> StreetNetwork | None:
    """Draw a street network from `rng`; None when the draw crosses or crowds itself (draw again)."""
    n = int(rng.integers(p.crossings[0], p.crossings[1] + 1))
    turns, kinds, bends = _plan(rng, p, n)
    h = float(rng.uniform(0.0, 2.0 * math.pi))
    start_yaw = h
    pos = np.zeros(2)
    places: dict[str, tuple[float, float]] = {"start": (0.0, 0.0)}
    junctions: list[Junction] = []
    streets: list[Street] = []
    route = ["start"]
    drawn_bends = []

    def street(sid: str, a: str, b: str, line: np.ndarray, on_route: bool) -> None:
        streets.append(Street(sid, a, b, np.round(line, 3), on_route))

    for i in range(n):
        line, h_in, bend = _leg(rng, p, pos, h, bends[i])
        if bend is not None:
            drawn_bends.append(bend)
        jid = f"x{i + 1}"
        street(f"{route[-1]}_{jid}", route[-1], jid, line, True)
        xy = line[-1]
        angle = float(rng.uniform(*p.crossing_deg))
        heads = {"ahead": h_in, "left": h_in + math.radians(angle), "right": h_in + math.radians(angle) - math.pi}
        take = {"through": "ahead", "left": "left", "right": "right"}[turns[i]]
        others = [k for k in heads if k != take]
        if kinds[i] == "T":
            others.remove(others[int(rng.integers(0, len(others)))])
        arms = [h_in + math.pi, heads[take]]
        for arm in others:
            pid = f"{jid}_{arm}"
            end = xy + float(rng.uniform(*p.side_street_m)) * _unit(heads[arm])
            places[pid] = (round(float(end[0]), 3), round(float(end[1]), 3))
            street(f"{jid}_{arm}", jid, pid, np.vstack([xy, end]), False)
            arms.append(heads[arm])
        junctions.append(Junction(jid, (round(float(xy[0]), 3), round(float(xy[1]), 3)), round(angle, 2), turns[i], kinds[i],  # type: ignore[arg-type]
                                  tuple(wrap_angle(a) for a in arms)))
        route.append(jid)
        pos, h = xy, heads[take]
    final = float(rng.uniform(*p.final_leg_m))
    dest = pos + float(rng.uniform(*p.destination_m)) * _unit(h)
    end = pos + final * _unit(h)
    places["mailbox"] = (round(float(dest[0]), 3), round(float(dest[1]), 3))
    places["end"] = (round(float(end[0]), 3), round(float(end[1]), 3))
    street(f"{route[-1]}_mailbox", route[-1], "mailbox", np.vstack([pos, dest]), True)
    street("mailbox_end", "mailbox", "end", np.vstack([dest, end]), False)
    route.append("mailbox")
    net = StreetNetwork(places, tuple(junctions), tuple(streets), tuple(route), start_yaw, tuple(drawn_bends))
    return net if _apart(net, p) else None


def _apart(net: StreetNetwork, p: NetworkParams) -> bool:
    """Return whether streets meet only at their shared nodes and streets that do not meet keep `street_gap_m` apart."""
    lines = [shapely.LineString(s.line) for s in net.streets]
    for i, (si, li) in enumerate(zip(net.streets, lines)):
        for sj, lj in zip(net.streets[i + 1:], lines[i + 1:]):
            shared = {si.a, si.b} & {sj.a, sj.b}
            if not shared:
                if li.distance(lj) < p.street_gap_m:
                    return False
                continue
            hub = shapely.Point(net.node_xy(shared.pop())).buffer(p.reach_m + 4.0)
            if li.difference(hub).distance(lj.difference(hub)) < p.road_width_m + 2.0:
                return False
    return True
