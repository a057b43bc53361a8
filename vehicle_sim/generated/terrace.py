"""A raised terrace at the end of a campus's walks, reached by stairs and by a slope beside them (as the shipped campus's).

Drawn in the frame of the foot of the terrace (the walk network's place `foot`, which becomes the
intersection node `foot`): along `u`, the heading the last walk arrives with, and lateral `l`, to the
left of it. The terrace rises `height_m` (6–8 steps of 0.15 m) beyond the front edge at
along = `edge_m`; the foot walk runs along its foot both ways (ends `foot_left`, `foot_right`).

* **Stairs** straight ahead: an approach walk from the foot to `stairs_bottom`, then `stairs`
  (kind stairs, 0.85 m treads, `stairs_width_m`), whose top edge is the terrace's front edge.
* **The slope beside them** (kind slope, grade `grade`, `ramp_width_m` wide, a `gap_m` of lawn from
  the stairs), on the side the seed draws, from the foot walk's edge up to the front edge; its foot,
  `slope_bottom`, is a place on the foot walk. Beyond it a sloped lawn (`bank`) in the same plane.
* A **plaza** on the terrace across both tops, with `stairs_top`; retaining walls along the rest of
  the front edge and round the terrace's sides and back, and a cheek wall beside the stairs, each
  `gap_m` off the stairs (a wall flush with them was touched by the Terregator's corner, turning on
  the plaza after climbing them keeping right, seed 3).
* **Terrace walks**: from `stairs_top` to the crossing `x_terrace` (a T or four-way at 55–125°),
  where the route goes straight on, left or right to the place `library`; the other arms lead to
  `terrace_ahead` / `terrace_left` / `terrace_right`. A building stands `ENTRANCE_M` beyond each of
  their ends (the library's always; the others where they fit). The terrace's lawn reaches
  `margin_m` beyond all of this.

Edges: `e_approach` (follow-road), `e_stairs` (climb-stairs: stairs and plaza) and `e_slope`
(go-through-slope: ramp and plaza, up the ramp's middle and across the plaza to `stairs_top`) as in
the shipped campus, so the stairs are the cheaper way and `avoid_stairs` takes the slope.

Frames: `world` (x east, y north) [m]; local (along, lateral) [m] from the foot; headings [rad] CCW from +x.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import shapely
from pydantic import BaseModel, ConfigDict, Field

from vehicle_sim.generated.street_network import Junction, NetworkParams, Street, StreetNetwork, _apart, _unit
from wire.se2 import wrap_angle

__all__ = ["TerraceParams", "Terrace", "STEP_RISE_M", "ENTRANCE_M", "draw_terrace", "entrance_building"]

#: Rise of one step [m] and the tread [m] (the shipped campus's stairs: 7 steps of 0.15 m on 6 m).
STEP_RISE_M, TREAD_M = 0.15, 0.857
#: A dead-end walk's building stands this far [m] beyond the walk's end (its entrance).
ENTRANCE_M = 3.0
_EPS = 0.02  # [m] beyond a least clearance, so rounding to mm keeps it


class TerraceParams(BaseModel):
    """How a terrace is drawn: steps, widths [m], grade, walk lengths [m], the terrace crossing's angle [deg], margins [m]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    steps: tuple[int, int] = (6, 8)
    grade: float = Field(0.1, gt=0.0, le=0.125)  # the ramp's rise per metre (1:10 as the shipped ramp)
    stairs_width_m: tuple[float, float] = (5.0, 6.0)
    ramp_width_m: float = 4.0
    gap_m: float = 1.0  # lawn between the stairs and the ramp, and between the stairs and the walls on their other side
    bank_m: float = 14.0  # the sloped lawn beyond the ramp
    approach_m: float = 2.0  # `stairs_bottom` before the first step
    plaza_m: float = 5.0
    walk_width_m: float = 3.0
    side_walk_width_m: float = 2.5
    foot_walk_m: tuple[float, float] = (18.0, 28.0)  # the foot walk each way from the foot
    up_walk_m: tuple[float, float] = (12.0, 18.0)  # stairs_top to x_terrace
    arm_m: tuple[float, float] = (14.0, 20.0)  # x_terrace's arms
    crossing_deg: tuple[float, float] = (55.0, 125.0)
    t_share: float = Field(0.5, ge=0.0, le=1.0)
    reach_m: float = 3.0  # an intersection's area reaches this far along each walk
    margin_m: float = 5.0  # the terrace's lawn beyond its walks and buildings
    lower_gap_m: float = 8.0  # least distance from the terrace (and bank, ramp, stairs) to a lower walk not at its foot


@dataclass(frozen=True)
class Terrace:
    """A drawn terrace: its height [m] and steps, the side of the slope (+1 left of the stairs), areas (world polygons), edges' ways.

    `network` is the walk network with the foot walk and the terrace walks added (`foot` now a
    crossing); `upper` the ids of the streets on the terrace; `stairs_route` and `slope_route` the
    node ids from the start to `library` each way; `buildings` the dead-end buildings on the terrace
    (place id → footprint), the library's first.
    """

    height_m: float
    steps: int
    axis_deg: float
    side: float
    network: StreetNetwork
    upper: frozenset[str]
    widths: dict[str, float]
    lawn: shapely.Polygon
    bank: shapely.Polygon
    stairs: shapely.Polygon
    ramp: shapely.Polygon
    plaza: shapely.Polygon
    approach: shapely.Polygon
    walls: tuple[shapely.Polygon, ...]
    stairs_bottom: tuple[float, float]
    slope_bottom: tuple[float, float]
    stairs_top: tuple[float, float]
    slope_via: tuple[tuple[float, float], ...]
    buildings: dict[str, shapely.Polygon]
    stairs_route: tuple[str, ...]
    slope_route: tuple[str, ...]
    crossing: Junction

    @property
    def zone(self) -> shapely.Geometry:
        """Return where the ground is not the lower level: the terrace, its walls, the bank, the ramp and the stairs."""
        return shapely.union_all([self.lawn, self.bank, self.stairs, self.ramp, *self.walls])


def entrance_building(end: np.ndarray, heading: float, width: float, depth: float, gap: float = ENTRANCE_M + _EPS) -> shapely.Polygon:
    """Return the footprint of a building `width` × `depth` [m] `gap` [m] beyond a walk's end `end` (2,) [m], facing back along `heading` [rad]."""
    u, n = _unit(heading), _unit(heading + math.pi / 2)
    c = end + u * (gap + depth / 2)
    return shapely.Polygon([tuple(np.round(c + u * su * depth / 2 + n * sn * width / 2, 3)) for su, sn in ((-1, -1), (1, -1), (1, 1), (-1, 1))])


def draw_terrace(rng: np.random.Generator, net: StreetNetwork, walks: NetworkParams, p: TerraceParams = TerraceParams()) -> Terrace | None:
    """Draw the terrace at the end of `net` (its last walk arrives at place `foot`); None when it crowds the walks (draw again)."""
    last = next(s for s in net.streets if s.b == "foot")
    d = last.line[-1] - last.line[-2]
    h = math.atan2(d[1], d[0])
    u, nv = _unit(h), _unit(h + math.pi / 2)
    f = np.asarray(net.places["foot"], float)

    def at(a: float, lat: float) -> np.ndarray:
        return f + a * u + lat * nv

    def rect(a0: float, a1: float, l0: float, l1: float) -> shapely.Polygon:
        lo, hi = min(l0, l1), max(l0, l1)
        return shapely.Polygon([tuple(np.round(at(a, lat), 3)) for a, lat in ((a0, lo), (a1, lo), (a1, hi), (a0, hi))])

    def rnd(q: np.ndarray) -> tuple[float, float]:
        return (round(float(q[0]), 3), round(float(q[1]), 3))

    steps = int(rng.integers(p.steps[0], p.steps[1] + 1))
    height = round(steps * STEP_RISE_M, 3)
    side = 1.0 if rng.random() < 0.5 else -1.0
    ws = round(float(rng.uniform(*p.stairs_width_m)), 2)
    ww = p.walk_width_m
    edge = ww / 2 + height / p.grade  # the front edge: the ramp rises from the foot walk's edge to here
    depth = steps * TREAD_M
    s0 = edge - depth
    r_in, r_out = ws / 2 + p.gap_m, ws / 2 + p.gap_m + p.ramp_width_m
    rc = (r_in + r_out) / 2
    top_a = edge + 2.0
    lengths = [float(rng.uniform(*p.foot_walk_m)) for _ in range(2)]
    foot_walk = {1.0: lengths[0], -1.0: lengths[1]}
    name = {1.0: "left", -1.0: "right"}
    sn, on = name[side], name[-side]

    # the foot walk, with slope_bottom on the slope's side; the foot becomes a four-way crossing
    places = {k: v for k, v in net.places.items() if k != "foot"}
    places["slope_bottom"] = rnd(at(0.0, side * rc))
    places[f"foot_{sn}"] = rnd(at(0.0, side * foot_walk[side]))
    places[f"foot_{on}"] = rnd(at(0.0, -side * foot_walk[-side]))
    if foot_walk[side] < r_out + p.bank_m + 2.0:
        places[f"foot_{sn}"] = rnd(at(0.0, side * (r_out + p.bank_m + 2.0)))
    streets = list(net.streets)
    streets.append(Street("foot_slope", "foot", "slope_bottom", np.round(np.vstack([f, at(0.0, side * rc)]), 3), True))
    streets.append(Street(f"slope_{sn}", "slope_bottom", f"foot_{sn}", np.round(np.vstack([at(0.0, side * rc), places[f"foot_{sn}"]]), 3), False))
    streets.append(Street(f"foot_{on}", "foot", f"foot_{on}", np.round(np.vstack([f, places[f"foot_{on}"]]), 3), False))
    foot = Junction("foot", rnd(f), 90.0, "through", "cross", tuple(wrap_angle(a) for a in (h + math.pi, h + math.pi / 2, h - math.pi / 2, h)))

    # the terrace walks: stairs_top -> x_terrace -> library (through, left or right), the other arms to places
    top = at(top_a, 0.0)
    places["stairs_top"] = rnd(top)
    places["stairs_bottom"] = rnd(at(s0 - p.approach_m, 0.0))
    xt = top + float(rng.uniform(*p.up_walk_m)) * u
    angle = float(rng.uniform(*p.crossing_deg))
    turn = ("through", "left", "right")[int(rng.integers(0, 3))]
    heads = {"ahead": h, "left": h + math.radians(angle), "right": h + math.radians(angle) - math.pi}
    take = {"through": "ahead", "left": "left", "right": "right"}[turn]
    others = [k for k in heads if k != take]
    kind = "T" if rng.random() < p.t_share else "cross"
    if kind == "T":
        others.remove(others[int(rng.integers(0, len(others)))])
    upper = [Street("top_terrace", "stairs_top", "x_terrace", np.round(np.vstack([top, xt]), 3), True)]
    ends: dict[str, tuple[np.ndarray, float]] = {}
    for arm in (take, *others):
        pid = "library" if arm == take else f"terrace_{arm}"
        end = xt + float(rng.uniform(*p.arm_m)) * _unit(heads[arm])
        places[pid] = rnd(end)
        upper.append(Street(f"terrace_{arm}", "x_terrace", pid, np.round(np.vstack([xt, end]), 3), arm == take))
        ends[pid] = (end, heads[arm])
    crossing = Junction("x_terrace", rnd(xt), round(angle, 2), turn, kind,  # type: ignore[arg-type]
                        tuple(wrap_angle(a) for a in (h + math.pi, heads[take], *(heads[k] for k in others))))
    widths = {s.id: ww if s.on_route or s.id == f"slope_{sn}" or s.id == f"foot_{on}" else p.side_walk_width_m for s in streets}
    widths.update({s.id: ww if s.on_route else p.side_walk_width_m for s in upper})

    # the dead-end buildings on the terrace: the library must fit, the others where they do
    walk_area = shapely.union_all([shapely.LineString(s.line).buffer(widths[s.id] / 2, cap_style="flat") for s in upper]
                                  + [rect(edge, edge + p.plaza_m, -side * (ws / 2 + 2.0), side * (r_out + 2.0))])
    buildings: dict[str, shapely.Polygon] = {}
    for pid, (end, head) in ends.items():
        big = pid == "library"
        g = entrance_building(end, head, float(rng.uniform(22.0, 30.0) if big else rng.uniform(14.0, 22.0)),
                              float(rng.uniform(14.0, 20.0) if big else rng.uniform(10.0, 16.0)))
        ok = g.distance(walk_area) >= ENTRANCE_M and all(g.distance(o) >= 2.0 for o in buildings.values())
        ok = ok and min(float(np.dot(np.asarray(q) - f, u)) for q in g.exterior.coords) >= edge + 2.0
        if ok:
            buildings[pid] = g
        elif big:
            return None

    # the terrace's extent: everything on it, the plaza and the bank's top, and a margin
    pts = np.vstack([np.asarray(shapely.convex_hull(walk_area).exterior.coords)] + [np.asarray(g.exterior.coords) for g in buildings.values()])
    along, lat = (pts - f) @ u, (pts - f) @ nv
    back = float(along.max()) + p.margin_m
    reach = {1.0: float(lat.max()) + p.margin_m, -1.0: -float(lat.min()) + p.margin_m}
    reach[side] = max(reach[side], r_out + p.bank_m + 3.0)
    reach[-side] = max(reach[-side], ws / 2 + 6.0)
    lmin, lmax = -round(reach[-1.0], 2), round(reach[1.0], 2)
    lawn = rect(edge, back, lmin, lmax)
    bank = rect(ww / 2, edge, side * r_out, side * (r_out + p.bank_m))
    stairs = rect(s0, edge, -ws / 2, ws / 2)
    ramp = rect(ww / 2, edge, side * r_in, side * r_out)
    plaza = rect(edge, edge + p.plaza_m, -side * (ws / 2 + 2.0), side * (r_out + 2.0))
    approach = rect(ww / 2, s0, -ww / 2, ww / 2)
    t = 0.3  # wall thickness [m]
    cheek = ws / 2 + p.gap_m  # the walls on the stairs' other side stand a gap off them, as the ramp does on its side
    walls = (rect(edge - t, edge, -side * cheek, -side * (reach[-side] + t)),  # the front edge on the stairs' other side
             rect(edge - t, edge, side * (r_out + p.bank_m), side * (reach[side] + t)),  # beyond the bank
             rect(s0, edge - t, -side * cheek, -side * (cheek + 0.4)),  # the cheek wall beside the stairs
             rect(edge - t, back + t, lmin - t, lmin), rect(edge - t, back + t, lmax, lmax + t), rect(back, back + t, lmin, lmax))
    terrace = Terrace(
        height_m=height, steps=steps, axis_deg=round(math.degrees(h), 3), side=side,
        network=StreetNetwork(places, (*net.junctions, foot, crossing), tuple(streets + upper), net.route, net.start_yaw, net.bends),
        upper=frozenset(s.id for s in upper), widths=widths, lawn=lawn, bank=bank, stairs=stairs, ramp=ramp, plaza=plaza,
        approach=approach, walls=walls, stairs_bottom=places["stairs_bottom"], slope_bottom=places["slope_bottom"],
        stairs_top=places["stairs_top"], slope_via=(rnd(at(edge, side * rc)), rnd(at(top_a, side * rc))), buildings=buildings,
        stairs_route=(*net.route, "stairs_bottom", "stairs_top", "x_terrace", "library"),
        slope_route=(*net.route, "slope_bottom", "stairs_top", "x_terrace", "library"), crossing=crossing)
    return terrace if _fits(terrace, walks, p) else None


def _fits(t: Terrace, walks: NetworkParams, p: TerraceParams) -> bool:
    """Return whether the lower walks keep `lower_gap_m` from the terrace and apart from each other, and the terrace walks apart."""
    net = t.network
    lower = [s for s in net.streets if s.id not in t.upper]
    zone = t.zone
    for s in lower:
        if "foot" in (s.a, s.b) or s.a == "slope_bottom":  # the foot walk and the walk into the foot meet the terrace
            continue
        if shapely.LineString(s.line).distance(zone) < p.lower_gap_m:
            return False
    # slope_bottom is a place part-way along the foot walk: apartness takes the foot walk on that side as one walk
    a, b = next(s for s in lower if s.id == "foot_slope"), next(s for s in lower if s.a == "slope_bottom")
    whole = Street(b.id, "foot", b.b, np.vstack([a.line[:1], b.line[1:]]), False)
    lower = [s for s in lower if s is not a and s is not b] + [whole]
    sub = StreetNetwork(net.places, net.junctions, tuple(lower), net.route, net.start_yaw, net.bends)
    up = StreetNetwork(net.places, net.junctions, tuple(s for s in net.streets if s.id in t.upper), net.route, net.start_yaw, net.bends)
    return _apart(sub, walks) and _apart(up, walks)
