"""The TERRAIN module process (Navlab 1990 §2.3.3–2.3.5 on CODGER): the laser's terrain map, posted as tiles.

Each cycle it asks the simulator's scanner for a laser image (images never go through the
blackboard), looks up the vehicle's pose at the scan (`local←vehicle` at the scan's stamp composed
with the PILOT's newest `world←local`), takes the height under the vehicle from the map it holds
(the first image's datum is 0 m: heights are relative), fuses the image's locus map into its
world-frame `modules.terrain.TerrainMap`, and posts one `terrain_tile` per tile the image changed
(the PILOT replaces an older tile of the same block with a newer one).

  reads   poses local←vehicle, world←local
  asks    sidewalk/<ns>/sim/capture (laser only)
  writes  terrain_tile
"""

from __future__ import annotations

import asyncio
import logging
import math

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from blackboard.errors import BlackboardError
from codger.laser_capture import laser_capture
from modules.terrain.range_image import RangeImage
from modules.terrain.terrain_map import TerrainMap
from modules.terrain.vehicle_model import terrain_vehicle_for
from modules.terrain.vehicle_pose import VehiclePose
from modules.vocabulary.terrain import TerrainTile
from wire.capture import CaptureDecodeError
from wire.se2 import compose

__all__ = ["TerrainModuleConfig", "TerrainModule"]

log = logging.getLogger("codger.terrain")


class TerrainModuleConfig(BaseModel):
    """The TERRAIN module's settings: the map's bounds [m] `world` and cells [m], tiles [cells], cycle [s] sim, timeouts [s]."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    vehicle: str = "navlab"
    bounds: tuple[float, float, float, float]
    resolution_m: float = Field(0.2, gt=0.0)
    tile_cells: int = Field(64, ge=8, le=1024)
    period_s: float = Field(0.5, gt=0.0)
    capture_timeout_s: float = Field(5.0, gt=0.0)
    pose_wait_s: float = Field(1.0, ge=0.0)
    start_pad_m: float = Field(4.0, ge=0.0, description="at the first image: the vehicle's plane assumed this far beyond its bumper [m]")
    start_pad_margin_m: float = Field(2.0, ge=0.0, description="…and this far around its body [m]")
    at_start_m: float = Field(0.5, gt=0.0, description="the vehicle is where it was set down while this close to its odometry's origin [m]")


class TerrainModule:
    """Run the TERRAIN module on a module runtime `rt` (blackboard `rt.bb`, Zenoh link `rt.link`, clock `rt.clock`)."""

    def __init__(self, rt, cfg: TerrainModuleConfig) -> None:
        self.rt = rt
        self.cfg = cfg
        self.map = TerrainMap(cfg.bounds, cfg.resolution_m, terrain_vehicle_for(cfg.vehicle), tile_cells=cfg.tile_cells)
        self.z = 0.0
        self.tiles_posted = 0

    async def _world_pose(self, stamp: float) -> tuple[np.ndarray, float]:
        """Return world←vehicle (3,) at `stamp` [s] and how far [m] the vehicle stands from its odometry's origin."""
        deadline = self.rt.clock.now() + self.cfg.pose_wait_s
        while True:
            try:
                lv = await self.rt.bb.lookup_pose(parent="local", child="vehicle", stamp=stamp)
                wl = await self.rt.bb.lookup_pose(parent="world", child="local", stamp=None)
                return compose(wl.as_array(), lv.as_array()), math.hypot(lv.x, lv.y)
            except BlackboardError:
                if self.rt.clock.now() >= deadline:
                    raise
                await self.rt.clock.sleep(0.05)

    async def cycle(self) -> int:
        """Fuse one laser image into the map and post the tiles it changed; return how many."""
        cap = await laser_capture(self.rt, self.cfg.capture_timeout_s)
        world, from_origin = await self._world_pose(float(cap.stamp))
        x, y, yaw = (float(v) for v in world)
        # Where the vehicle was set down (it has not moved since its odometry started), the blind ground ahead of
        # it is assumed to continue the plane it stands on, once (see `modules.terrain.wheel_footprint`).
        pad = self.map.images == 0 and from_origin < self.cfg.at_start_m
        roll, pitch = (0.0, 0.0) if cap.attitude is None else (float(a) for a in cap.attitude[:2])
        # The map's work runs off the event loop (compiled code that releases the GIL): the heartbeat goes on meanwhile.
        tiles = await asyncio.to_thread(self._fuse, cap, x, y, yaw, roll, pitch, pad)
        for tile in tiles:
            await self.rt.bb.post(tile, frame="world", geometry=None, stamp=float(cap.stamp))
        self.tiles_posted += len(tiles)
        return len(tiles)

    def _fuse(self, cap, x: float, y: float, yaw: float, roll: float, pitch: float, pad: bool) -> list[TerrainTile]:
        """Fuse the laser image of `cap` taken at (x, y [m], yaw, roll, pitch [rad]) `world`, then the footprint; return the tiles changed."""
        image = RangeImage.from_capture(cap)
        under = self.map.height_near(x, y)
        z = self.z if under is None else under
        pose = VehiclePose(x, y, z, roll, pitch, yaw)
        changed, dz = self.map.add_image(image, pose)
        self.z = z + dz
        # The ground the wheels stand on, which the laser never sees (and, at the start, the blind ground ahead).
        foot = self.map.add_footprint(pose, ahead=self.cfg.start_pad_m, margin=self.cfg.start_pad_margin_m) if pad \
            else self.map.add_footprint(pose)
        return self.map.tiles(sorted(set(changed) | set(foot)), float(cap.stamp))

    async def run(self) -> None:
        """Map until the runtime stops."""
        await self.rt.clock.wait_running()
        self.rt.ready()
        while not self.rt.stopping:
            try:
                await self.cycle()
            except (TimeoutError, CaptureDecodeError, BlackboardError, RuntimeError) as exc:
                log.warning("terrain: cycle failed: %s", exc)
            await self.rt.clock.sleep(self.cfg.period_s)
