"""The TERRAIN module (CODGER) posts the laser's terrain map as tiles: blackboard node, simulator, HELM, PILOT and
TERRAIN each in its own OS process, on real Zenoh.

The Navlab stands at the shipped cross-country mission's start; the PILOT is told the true start and drives
nothing. The TERRAIN module's tiles, decoded, must hold the ground ahead as the truth raster has it — up to
the one height offset the module cannot know (its datum is the first image's vehicle height, 0 m).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from blackboard import AttrPredicate, BlackboardClient, Spec
from modules.vocabulary import TerrainTile
from tests.modules._codger_rig import codger_rig
from vehicle_sim.worldfile import load_world

pytestmark = [pytest.mark.e2e, pytest.mark.missions, pytest.mark.timeout(900)]  # five processes: quiet ~18 s (2026-11-28), 85 s at load 25, and a cold numba cache compiles the sim's terrain ray cast and the locus code: many minutes on a busy machine

START = (25.0, 33.019, math.radians(2.16))  # worlds/cross-country.yaml


async def test_the_terrain_tiles_hold_the_ground_ahead_as_the_truth_has_it() -> None:
    with codger_rig("tm", world="cross_country", truth=START, pilot_pose=START, seed=3, sim_timeout=600.0) as rig:
        rig.start(["-m", "codger.terrain", "--vehicle", "navlab", "--bounds=0,0,80,70"], "SIDEWALK-READY terrain",
                  timeout=600.0)
        node = rig.node
        async with BlackboardClient(node.client_net(), source="test") as bb:
            first = await bb.wait(Spec(type="terrain_tile"), timeout=600.0)
            assert isinstance(first.attrs, TerrainTile)
            # a tile of the next image: every tile of the first has been posted before it
            await bb.wait(Spec(type="terrain_tile", where=(AttrPredicate(path="sensed_at", op=">", value=first.attrs.sensed_at),)),
                          timeout=600.0)
            tiles = [t.attrs for t in await bb.retrieve(Spec(type="terrain_tile"))]
        world = load_world("cross_country")
        diffs, bad_near = [], 0
        for tile in tiles:
            assert tile.frame == "world" and tile.resolution == pytest.approx(0.2)
            x0, y0 = tile.origin
            assert -0.2 <= x0 and x0 + tile.nx * 0.2 <= 80.2 and -0.2 <= y0 and y0 + tile.ny * 0.2 <= 70.2
            z, _ = tile.heights()
            rows, cols = np.nonzero(np.isfinite(z))
            xy = np.column_stack([x0 + (cols + 0.5) * 0.2, y0 + (rows + 0.5) * 0.2])
            near = np.hypot(xy[:, 0] - START[0], xy[:, 1] - START[1]) <= 15.0
            diffs.append(z[rows, cols][near] - world.elevation(xy[near]))
            bad_near += int(tile.inadmissible_mask()[rows, cols][near].sum())
        d = np.concatenate(diffs)
        assert d.size > 2000, (d.size, sorted({t.origin for t in tiles}))  # the ground ahead, seen
        offset = float(np.median(d))
        assert np.percentile(np.abs(d - offset), 90) < 0.15, (offset, np.percentile(np.abs(d - offset), [50, 90, 99]))
        assert bad_near < 0.2 * d.size  # the start is open ground: few cells a wheel cannot stand on
    assert all(c == 0 for c in rig.codes), rig.codes
