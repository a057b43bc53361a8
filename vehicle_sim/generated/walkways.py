"""A campus walkway network drawn from a seed: walks from the `dorm` through 3–4 crossings, one of them a Y, to the terrace's foot.

A walkway network is a street network (`street_network`: its streets, junctions, legs and
apartness check) with narrower ways, shorter legs and gentler bends, and one crossing of its own:
the **Y**, where the walk forks into two branches 25–45° either side of its heading (the route
takes one, the other runs to a place of its own). Every other crossing meets the route at 55–125°,
four-way or a T. At least one crossing is a Y; among the others the route turns left at one and
right at another (real turns, not forks). Every walk the route does not take is a dead-end side
walk to a place of its own (`x2_left`, …). After the last crossing a straight walk leads to the
place `foot`, where the terrace (`terrace`) takes over: the network's `start_yaw` is the heading at
the start, and the last street's heading is the terrace's.

Frames: `world` (x east, y north) [m]; headings are math angles [rad] CCW from +x. A Y junction's
`angle_deg` is its fork: the angle [deg] between its two branches.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from vehicle_sim.generated.street_network import Junction, NetworkParams, Street, StreetNetwork, _leg, _unit
from wire.se2 import wrap_angle

__all__ = ["WalkwayParams", "CAMPUS_WALKS", "draw_walkways"]

Kind = Literal["cross", "T", "Y"]


class WalkwayParams(BaseModel):
    """What a walkway network is made of: the street-network parameters for walks, the Y's branches [deg], the walk to the foot [m]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    legs: NetworkParams = NetworkParams(
        crossings=(3, 4), crossing_deg=(55.0, 125.0), t_share=0.4, bend_share=0.35, bend_radius_m=(25.0, 60.0),
        bend_deg=(15.0, 40.0), bend_arc_max_m=40.0, straight_m=(10.0, 18.0), straight_after_bend_m=12.0, leg_m=(30.0, 50.0),
        side_street_m=(18.0, 30.0), road_width_m=3.0, reach_m=3.0, street_gap_m=12.0)
    y_share: float = Field(0.35, ge=0.0, le=1.0)  # share of crossings that are Ys (at least one, at most all but two)
    y_branch_deg: tuple[float, float] = (25.0, 45.0)  # each branch's angle off the incoming walk's heading
    foot_m: tuple[float, float] = (25.0, 40.0)  # from the last crossing to the terrace's foot


#: The generated campus's walks (`campus`).
CAMPUS_WALKS = WalkwayParams()


def _plan(rng: np.random.Generator, p: WalkwayParams, n: int) -> tuple[list[Kind], list[str], list[bool]]:
    """Return each crossing's kind and turn, and which legs bend: at least one Y, a left and a right at crossings that are not Ys."""
    kinds: list[Kind] = ["Y" if rng.random() < p.y_share else ("T" if rng.random() < p.legs.t_share else "cross") for _ in range(n)]
    ys = [i for i, k in enumerate(kinds) if k == "Y"]
    if not ys:
        kinds[int(rng.integers(0, n))] = "Y"
    while sum(k == "Y" for k in kinds) > n - 2:  # keep two crossings for a real left and right turn
        ys = [i for i, k in enumerate(kinds) if k == "Y"]
        kinds[ys[int(rng.integers(0, len(ys)))]] = "cross"
    turns = [("left", "right")[int(rng.integers(0, 2))] if k == "Y" else ("through", "left", "right")[int(rng.integers(0, 3))]
             for k in kinds]
    others = [i for i, k in enumerate(kinds) if k != "Y"]
    if not ({"left", "right"} <= {turns[i] for i in others}):
        i, j = (others[int(k)] for k in rng.choice(len(others), size=2, replace=False))
        turns[i], turns[j] = "left", "right"
    if "T" not in kinds and rng.random() < 0.5:
        kinds[others[int(rng.integers(0, len(others)))]] = "T"
    bends = [bool(rng.random() < p.legs.bend_share) for _ in range(n)]
    return kinds, turns, bends


def draw_walkways(rng: np.random.Generator, p: WalkwayParams = CAMPUS_WALKS) -> StreetNetwork | None:
    """Draw a walkway network from `rng`: `dorm` → x1 … xn → `foot`; None when the draw crosses or crowds itself (draw again)."""
    lp = p.legs
    n = int(rng.integers(lp.crossings[0], lp.crossings[1] + 1))
    kinds, turns, bends = _plan(rng, p, n)
    h = float(rng.uniform(0.0, 2.0 * math.pi))
    start_yaw = h
    pos = np.zeros(2)
    places: dict[str, tuple[float, float]] = {"dorm": (0.0, 0.0)}
    junctions: list[Junction] = []
    streets: list[Street] = []
    route = ["dorm"]
    drawn_bends = []

    def street(sid: str, a: str, b: str, line: np.ndarray, on_route: bool) -> None:
        streets.append(Street(sid, a, b, np.round(line, 3), on_route))

    for i in range(n):
        line, h_in, bend = _leg(rng, lp, pos, h, bends[i])
        if bend is not None:
            drawn_bends.append(bend)
        jid = f"x{i + 1}"
        street(f"{route[-1]}_{jid}", route[-1], jid, line, True)
        xy = line[-1]
        if kinds[i] == "Y":
            left, right = (math.radians(float(rng.uniform(*p.y_branch_deg))) for _ in range(2))
            heads = {"left": h_in + left, "right": h_in - right}
            angle = math.degrees(left + right)
        else:
            angle = float(rng.uniform(*lp.crossing_deg))
            heads = {"ahead": h_in, "left": h_in + math.radians(angle), "right": h_in + math.radians(angle) - math.pi}
        take = {"through": "ahead", "left": "left", "right": "right"}[turns[i]]
        others = [k for k in heads if k != take]
        if kinds[i] == "T":
            others.remove(others[int(rng.integers(0, len(others)))])
        arms = [h_in + math.pi, heads[take]]
        for arm in others:
            pid = f"{jid}_{arm}"
            end = xy + float(rng.uniform(*lp.side_street_m)) * _unit(heads[arm])
            places[pid] = (round(float(end[0]), 3), round(float(end[1]), 3))
            street(f"{jid}_{arm}", jid, pid, np.vstack([xy, end]), False)
            arms.append(heads[arm])
        junctions.append(Junction(jid, (round(float(xy[0]), 3), round(float(xy[1]), 3)), round(angle, 2), turns[i], kinds[i],  # type: ignore[arg-type]
                                  tuple(wrap_angle(a) for a in arms)))
        route.append(jid)
        pos, h = xy, heads[take]
    foot = pos + float(rng.uniform(*p.foot_m)) * _unit(h)
    places["foot"] = (round(float(foot[0]), 3), round(float(foot[1]), 3))
    street(f"{route[-1]}_foot", route[-1], "foot", np.vstack([pos, foot]), True)
    route.append("foot")
    return StreetNetwork(places, tuple(junctions), tuple(streets), tuple(route), start_yaw, tuple(drawn_bends))
