"""Obstacle stop with FIDO's stereo in place of the laser (Navlab 1990 §4.3, §2.5).

The same module as `eddie.obstacle_stop` — woken and put to sleep by the mission's obstacle
triggers, stopping the controller as its highest-priority client and holding it while something
stands on its path — but each check asks the simulator for a stereo pair and runs a FIDO step on it
(`modules.fido.FidoObstacleWatch`, its search guided by the controller's dead-reckoned motion
between two pairs); the obstacle is FIDO's first obstacle features inside the path's corridor, and
the verdict is obstacle stop's (`stop_verdict`). It answers to obstacle stop's name, so the
mission's triggers reach it. A "stop at object" still looks for the object with the laser: it is
the map's object seen for a position correction, not an obstacle.

It asks the simulator's capture service for the pair as `eddie.modules.sensing.capture_frame` asks for a
frame (through the same request helper).
"""

from __future__ import annotations

import asyncio
import logging
import math

import numpy as np

from eddie.modules.errors import EddieModuleError
from eddie.modules.sensing import CaptureError, _capture
from eddie.obstacle_stop.obstacle_stop import ObstacleReport, ObstacleStopConfig, corridor_path, stop_verdict
from eddie.obstacle_stop.obstacle_stop_module import ObstacleStop
from eddie.toolkit.module import Module
from wire.capture import CaptureDecodeError, CaptureResult, decode_capture
from wire.keys import SimKeys
from modules.fido import FidoError, FidoObstacleWatch, FidoWatchConfig, StereoPair, StereoRig

__all__ = ["FidoStop", "FidoStopError", "capture_stereo"]

log = logging.getLogger("eddie.fido_stop")
#: each sighting that blocks the path is logged whatever SIDEWALK_LOG says: the run's log is where a stop is explained
log.setLevel(logging.INFO)


class FidoStopError(EddieModuleError):
    """A stereo pair FIDO cannot use (missing images or calibration, a pair that is not rectified)."""


async def capture_stereo(m: Module, *, size: int = 512, timeout: float = 15.0) -> CaptureResult:
    """Ask the simulator for one stereo pair alone, `size`×`size` [px] (no laser, camera or truth); raise CaptureError."""
    payload = await _capture(m, {"laser": False, "camera": False, "stereo": True, "stereo_size": size}, timeout)
    try:
        return decode_capture(payload)
    except CaptureDecodeError as exc:
        raise CaptureError(f"{SimKeys(m.net.namespace).capture}: {exc}") from None


class FidoStop(ObstacleStop):
    """Obstacle stop on FIDO's stereo obstacle features."""

    def __init__(self, m: Module, *, awake: bool = True, cfg: ObstacleStopConfig = ObstacleStopConfig(),
                 start: tuple[float, float, float] = (0.0, 0.0, 0.0), watch: FidoWatchConfig = FidoWatchConfig()) -> None:
        super().__init__(m, awake=awake, cfg=cfg, start=start)
        self.watch = FidoObstacleWatch(watch)
        self._seen = None

    async def capture(self) -> CaptureResult:
        """Ask the simulator for a stereo pair (no laser, no camera, no truth); raise CaptureError."""
        return await capture_stereo(self.m, size=self.watch.cfg.stereo_size)

    async def look(self, frame: CaptureResult, pose: tuple[float, float, float]) -> ObstacleReport:
        """Run a FIDO step on the pair seen at `pose` (`local`); return the verdict on its obstacle features along the path."""
        try:
            pair, rig = StereoPair.from_capture(frame), StereoRig.from_capture(frame)
            seen = await asyncio.to_thread(self.watch.step, pair, rig, pose)
        except FidoError as exc:
            raise FidoStopError(f"fido: {exc}") from None
        self._seen = seen
        d = self.watch.corridor_distance(seen, corridor_path(self.cfg, self.path, pose), self.cfg.half_width_m)
        if math.isfinite(d):
            log.info("fido: t=%.2f an obstacle feature %.1f m along the path (%d obstacle features, %d new; %d features, %d tracked; %.0f ms)",
                     seen.stamp, d, len(seen.xyz), seen.new, seen.features, seen.tracked, seen.step_ms)
        return stop_verdict(d, seen.stamp, self.cfg, path_local=self.path, pose_local=pose, speed=self.belief.speed)

    def along(self, path: np.ndarray, pose: tuple[float, float, float]) -> ObstacleReport:
        """Return the verdict of the last step's obstacle features along another `path` (`local` [m]), seen at `pose`."""
        seen = self._seen
        d = self.watch.corridor_distance(seen, corridor_path(self.cfg, path, pose), self.cfg.half_width_m)
        return stop_verdict(d, seen.stamp, self.cfg, path_local=path, pose_local=pose, speed=self.belief.speed)

