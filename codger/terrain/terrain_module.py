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

import logging

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from blackboard.errors import BlackboardError
from codger.laser_capture import laser_capture
from modules.terrain.range_image import RangeImage
from modules.terrain.terrain_map import TerrainMap
from modules.terrain.vehicle_model import terrain_vehicle_for
from modules.terrain.vehicle_pose import VehiclePose
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


class TerrainModule:
    """Run the TERRAIN module on a module runtime `rt` (blackboard `rt.bb`, Zenoh link `rt.link`, clock `rt.clock`)."""

    def __init__(self, rt, cfg: TerrainModuleConfig) -> None:
        self.rt = rt
        self.cfg = cfg
        self.map = TerrainMap(cfg.bounds, cfg.resolution_m, terrain_vehicle_for(cfg.vehicle), tile_cells=cfg.tile_cells)
        self.z = 0.0
        self.tiles_posted = 0

    async def _world_pose(self, stamp: float) -> np.ndarray:
        deadline = self.rt.clock.now() + self.cfg.pose_wait_s
        while True:
            try:
                lv = await self.rt.bb.lookup_pose(parent="local", child="vehicle", stamp=stamp)
                wl = await self.rt.bb.lookup_pose(parent="world", child="local", stamp=None)
                return compose(wl.as_array(), lv.as_array())
            except BlackboardError:
                if self.rt.clock.now() >= deadline:
                    raise
                await self.rt.clock.sleep(0.05)

    async def cycle(self) -> int:
        """Fuse one laser image into the map and post the tiles it changed; return how many."""
        cap = await laser_capture(self.rt, self.cfg.capture_timeout_s)
        x, y, yaw = (float(v) for v in await self._world_pose(float(cap.stamp)))
        under = self.map.height_near(x, y)
        z = self.z if under is None else under
        roll, pitch = (0.0, 0.0) if cap.attitude is None else (float(a) for a in cap.attitude[:2])
        changed, dz = self.map.add_image(RangeImage.from_capture(cap), VehiclePose(x, y, z, roll, pitch, yaw))
        self.z = z + dz
        for tile in self.map.tiles(changed, float(cap.stamp)):
            await self.rt.bb.post(tile, frame="world", geometry=None, stamp=float(cap.stamp))
        self.tiles_posted += len(changed)
        return len(changed)

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
