"""A generated marked road (issue 37): YARF's kind of road (Navlab 1990 §2.2.2, ch. 5) on a network drawn from a seed.

As on `schenley`: 7.6 m roads with a double yellow centre line and white edge stripes on every
street, a right-turn lane added before each crossing where the route turns right (a 12 m taper, the
edge stripe out along it, a dashed lane line carrying on), rows of roadside trees throwing their
shadows across the road under a low sun, a few houses. The network is drawn like a suburb's
(`street_network`: crossings at 55–125°, T-junctions, bends of 50–150 m radius, left and right
turns) with longer straights before crossings, where the turn lanes go. The mission delivers to the
mailbox beside the `mailbox` place at YARF's 15 km/h. The same seed gives identical files.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import shapely
import shapely.ops

from vehicle_sim.generated.street_network import NetworkParams, Street, StreetNetwork
from vehicle_sim.generated.street_world import StreetStyle, StreetWorld, generate_street_world, write_street_world
from vehicle_sim.worldfile import Marking
from vehicle_sim.worldgen import ASPHALT, WorldBuilder, _offset_line

__all__ = ["MARKED_NETWORK", "MARKED_STYLE", "TURN_LANE_M", "TAPER_M", "generate", "write"]

MARKED_NETWORK = NetworkParams(crossings=(3, 5), road_width_m=7.6, reach_m=11.0, leg_m=(85.0, 130.0), straight_m=(30.0, 45.0),
                               straight_after_bend_m=70.0, final_leg_m=(80.0, 100.0), street_gap_m=36.0)
MARKED_STYLE = StreetStyle(kind="marked-road", road_width_m=7.6, lot_m=(30.0, 45.0), lot_share=0.3, tree_row_m=11.0,
                           sun_elevation_deg=(28.0, 45.0), speed_limit=4.2)
#: The added right-turn lane: its length before the crossing [m], its taper [m], its width [m].
TURN_LANE_M, TAPER_M, LANE_W = 49.0, 12.0, 3.5
_EDGE = MARKED_STYLE.road_width_m / 2 - 0.25  # edge stripe from the centre line [m]
_SALT = 0x7A4F


def _turn_lane_streets(net: StreetNetwork) -> set[str]:
    """Return the ids of the route's streets into a crossing where the route turns right."""
    right = {j.id for j in net.junctions if j.turn == "right"}
    return {s.id for s in net.streets if s.on_route and s.b in right}


def _lane_frame(centre: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return the trimmed street's end (2,) [m], its unit direction and its unit right normal."""
    end, before = centre[-1], centre[-2]
    u = (end - before) / np.linalg.norm(end - before)
    return end, u, np.array([u[1], -u[0]])


def _line(pts) -> tuple[tuple[float, float], ...]:
    return tuple((round(float(x), 3), round(float(y), 3)) for x, y in pts)


def _markings(net: StreetNetwork, st: Street, centre: np.ndarray) -> tuple[Marking, ...]:
    """Return a street's stripes: the double yellow centre line, the white edges; with a turn lane, its edge and lane line."""
    out = [Marking(colour="yellow", line=tuple(_offset_line(centre, d)), width=0.1) for d in (-0.12, 0.12)]
    out.append(Marking(colour="white", line=tuple(_offset_line(centre, _EDGE)), width=0.12))
    if st.id not in _turn_lane_streets(net):
        out.append(Marking(colour="white", line=tuple(_offset_line(centre, -_EDGE)), width=0.12))
        return tuple(out)
    line = shapely.LineString(centre)
    before = np.asarray(shapely.ops.substring(line, 0.0, line.length - TURN_LANE_M).coords, float)
    out.append(Marking(colour="white", line=tuple(_offset_line(before, -_EDGE)), width=0.12))
    end, u, r = _lane_frame(centre)
    a = end - u * TURN_LANE_M
    out.append(Marking(colour="white", line=_line([a + r * _EDGE, a + u * TAPER_M + r * (_EDGE + LANE_W), end + r * (_EDGE + LANE_W)]),
                       width=0.12))
    out.append(Marking(colour="white", line=_line([a + r * _EDGE, end + r * _EDGE]), width=0.12, dash=(3.0, 9.0)))
    return tuple(out)


def _turn_lanes(net: StreetNetwork, b: WorldBuilder, centres: dict[str, np.ndarray]) -> None:
    """Add the right-turn lane areas before each crossing where the route turns right."""
    half = MARKED_STYLE.road_width_m / 2
    for sid in sorted(_turn_lane_streets(net)):
        end, u, r = _lane_frame(centres[sid])
        a = end - u * TURN_LANE_M
        b.area(f"road_turn_lane_{sid}", "road", _line([a + r * half, end + r * half, end + r * (half + LANE_W),
                                                       a + u * TAPER_M + r * (half + LANE_W)]),
               role="path", colour=ASPHALT, cost=1.0, reflectance=0.3)


def generate(seed: int, *, name: str | None = None) -> StreetWorld:
    """Return the marked-road world of `seed` (StreetWorldError when no draw fits)."""
    return generate_street_world("marked-road", seed, name or f"marked_road_{seed}", MARKED_NETWORK, MARKED_STYLE, salt=_SALT,
                                 markings_for=_markings, extra_road=_turn_lanes)


def write(world: StreetWorld, out: str | Path) -> list[Path]:
    """Write and check the marked road's world, map, mission and actors in directory `out`; return the paths."""
    return write_street_world(world, out)
