"""A generated suburb (issue 37): streets without markings through 3–6 crossings, houses, driveways, a mailbox to deliver to.

Like `north_hills`, drawn anew from each seed: the network (`street_network`: crossings at 55–125°,
T-junctions, bends of 50–150 m radius, left and right turns), the houses, driveways of four
surfaces, mailboxes, trees, stop signs and hydrants at their least clearances (`street_world`),
another sun and weather, the destination mailbox on either side. The same seed gives identical files.
"""

from __future__ import annotations

from pathlib import Path

from vehicle_sim.generated.street_network import NetworkParams
from vehicle_sim.generated.street_world import StreetStyle, StreetWorld, generate_street_world, write_street_world

__all__ = ["SUBURB_NETWORK", "SUBURB_STYLE", "generate", "write"]

SUBURB_NETWORK = NetworkParams()
SUBURB_STYLE = StreetStyle(kind="suburb")
_SALT = 0x5B0B


def generate(seed: int, *, name: str | None = None) -> StreetWorld:
    """Return the suburb of `seed` (StreetWorldError when no draw fits)."""
    return generate_street_world("suburb", seed, name or f"suburb_{seed}", SUBURB_NETWORK, SUBURB_STYLE, salt=_SALT)


def write(world: StreetWorld, out: str | Path) -> list[Path]:
    """Write and check the suburb's world, map, mission and actors in directory `out`; return the paths."""
    return write_street_world(world, out)
