"""What every EDDIE perception module needs: a sensor frame from the simulator, the believed pose, the map objects in view.

A frame comes from the simulator's capture service like PERCEPTION's (laser and camera, never the
truth labels); a module that reads only the range asks for the laser alone. The believed pose is
the controller's dead-reckoned `local` pose (stream `state`) and the navigator's `world` ← `local`
(stream `world_from_local`; until it speaks, the start pose the module was given).
"""

from __future__ import annotations

import asyncio
import json
import math
from typing import Callable

import numpy as np
from shapely.geometry import Point, Polygon

from eddie.messages.controller import ControllerMode, ControllerState
from eddie.messages.navigator import WorldFromLocal
from eddie.modules.errors import EddieModuleError
from eddie.navigator.local_pose_buffer import LocalPoseBuffer
from eddie.toolkit.module import Module
from modules.map_navigator import MapData, map_object
from modules.perception.obstacles import LaserScan
from modules.perception.sensor_frame import SensorFrame, SensorFrameError, decode_sensor_frame
from modules.vocabulary import MapObject
from wire.capture import CaptureDecodeError, decode_capture
from wire.keys import SimKeys
from wire.se2 import compose
from wire.timemode import lockstep_enabled

__all__ = ["CaptureError", "capture_frame", "capture_scan", "Belief", "objects_in_view"]


class CaptureError(EddieModuleError):
    """The simulator's capture service did not answer, or answered with something that is not a frame."""


async def _capture(m: Module, request: dict, timeout: float) -> bytes:
    """Ask the simulator's capture service; return the first good reply's bytes; raise CaptureError."""
    key = SimKeys(m.net.namespace).capture
    replies = await m.link.get(key, payload=json.dumps(request).encode(), timeout=timeout)
    for r in replies:
        if r.ok:
            return r.payload
    if replies:
        raise CaptureError(f"{key}: {replies[0].payload.decode(errors='replace')[:200]}")
    raise CaptureError(f"no simulator answered {key} within {timeout:.1f} s")


async def capture_frame(m: Module, *, timeout: float = 15.0, max_age_s: float = 0.0) -> SensorFrame:
    """Ask the simulator for one laser + camera frame (no truth); raise CaptureError.

    With `max_age_s` [s sim] a frame of an earlier instant at most that old will do (one the simulator
    rendered for another module; `wire.capture.CaptureRequest.max_age_s`): pair it with the pose at its stamp.
    """
    payload = await _capture(m, {"laser": True, "camera": True, "max_age_s": max_age_s}, timeout)
    try:
        return decode_sensor_frame(payload)
    except SensorFrameError as exc:
        raise CaptureError(f"{SimKeys(m.net.namespace).capture}: {exc}") from None


async def capture_scan(m: Module, *, timeout: float = 15.0, max_age_s: float = 0.0) -> LaserScan:
    """Ask the simulator for one laser image alone (no camera, no truth); raise CaptureError.

    For a module that reads only the range (OBSTACLE STOP): the simulator skips the camera's render
    and its bytes. The scan is the one `capture_frame` would give to the bit (a capture's noise is
    drawn from its stamp, the laser's first), and carries what a frame's does: no reflectance. `max_age_s` as
    `capture_frame`'s.
    """
    payload = await _capture(m, {"laser": True, "camera": False, "max_age_s": max_age_s}, timeout)
    try:
        c = decode_capture(payload)
    except CaptureDecodeError as exc:
        raise CaptureError(f"{SimKeys(m.net.namespace).capture}: {exc}") from None
    if c.laser_range is None or c.laser_valid is None or c.laser_az is None or c.laser_el is None:
        raise CaptureError(f"{SimKeys(m.net.namespace).capture}: the capture has no laser image")
    return LaserScan(range_m=c.laser_range, valid=c.laser_valid, az=c.laser_az, el=c.laser_el,
                     T_vehicle_laser=c.T_vehicle_laser, ambiguity=float(c.ambiguity), stamp=float(c.stamp))


#: how long [s wall] a module waits for the controller's pose to reach a capture's stamp before it skips the frame
POSE_WAIT_S = 2.0


class Belief:
    """The controller's `local` poses (the newest and a short history) and navigator `world` ← `local`, kept from their streams.

    A frame is paired with the pose at its capture stamp (`local_at`), not the newest one: at RTF 20
    a capture's round trip is seconds of sim, metres of travel. On a loaded machine the controller's
    stream can be behind the simulator: a frame stamped after the newest pose waits for the pose
    that covers it (`reached`) rather than take the newest, which at RTF 50 was up to 14 s sim old.
    """

    def __init__(self, m: Module, world_from_local: tuple[float, float, float]) -> None:
        """Subscribe on `m`; `world_from_local` (x, y [m], yaw [rad]) holds until the navigator speaks."""
        self.world_from_local = np.asarray(world_from_local, dtype=np.float64)
        self.local: np.ndarray | None = None
        self.local_stamp: float | None = None
        self.speed = 0.0
        #: the controller's mode, the client holding it and its speed cap [m/s] (None: none), from its newest state
        self.mode: ControllerMode = "idle"
        self.client = ""
        self.speed_limit: float | None = None
        self.fixes_used = 0
        self.history = LocalPoseBuffer(span_s=30.0)
        #: called with each controller state, after the belief took it in
        self.on_state: list[Callable[[ControllerState], None]] = []
        self._waiting: list[tuple[float, asyncio.Future[None]]] = []
        m.subscribe("controller", "state", ControllerState, self._on_state)
        m.subscribe("navigator", "world_from_local", WorldFromLocal, self._on_transform)

    def _on_state(self, st: ControllerState) -> None:
        self.local, self.local_stamp, self.speed = st.to_pose2d().as_array(), st.stamp, st.v
        self.mode, self.client, self.speed_limit = st.mode, st.client, st.speed_limit
        for t, x, y, yaw in st.trail:  # the periods a held-up controller missed
            self.history.add(t, x, y, yaw)
        self.history.add(st.stamp, st.x, st.y, st.yaw)
        if self._waiting:
            still = []
            for stamp, fut in self._waiting:
                if stamp <= st.stamp:
                    if not fut.done():
                        fut.set_result(None)
                else:
                    still.append((stamp, fut))
            self._waiting = still
        for call in self.on_state:
            call(st)

    async def reached(self, stamp: float, timeout_s: float = POSE_WAIT_S) -> bool:
        """Wait until the controller's newest pose is at or past sim time `stamp` [s]; False after `timeout_s` [s wall].

        In lock-step the simulator does not step while a module works, and the controller's pose of
        each control period comes before the tick: nothing newer would come, so it does not wait.
        """
        if (self.local_stamp is not None and self.local_stamp >= stamp) or lockstep_enabled():
            return True
        fut: asyncio.Future[None] = asyncio.get_running_loop().create_future()
        self._waiting.append((stamp, fut))
        try:
            await asyncio.wait_for(fut, timeout_s)
            return True
        except asyncio.TimeoutError:
            return False
        finally:
            self._waiting = [w for w in self._waiting if w[1] is not fut]

    def _on_transform(self, t: WorldFromLocal) -> None:
        self.world_from_local, self.fixes_used = t.to_pose2d().as_array(), t.fixes_used

    def world(self) -> np.ndarray | None:
        """Return the believed pose (3,) in `world` (None before the controller spoke)."""
        return None if self.local is None else compose(self.world_from_local, self.local)

    def local_at(self, stamp: float) -> np.ndarray | None:
        """Return the `local` pose (3,) at sim time `stamp` [s]: interpolated, or the newest when `stamp` is past it.

        None before the controller spoke, or when `stamp` is older than the history kept.
        """
        if self.local is None:
            return None
        if self.local_stamp is not None and stamp >= self.local_stamp:
            return self.local.copy()
        return self.history.at(stamp)

    def world_at(self, stamp: float) -> np.ndarray | None:
        """Return the believed pose (3,) in `world` at sim time `stamp` [s] (see `local_at`)."""
        local = self.local_at(stamp)
        return None if local is None else compose(self.world_from_local, local)

    async def at_capture(self, stamp: float) -> tuple[np.ndarray, np.ndarray] | None:
        """Return the (`local`, `world`) poses (3,) at a capture's stamp [s] once the controller's stream has reached it
        (`reached`); None when it does not within `POSE_WAIT_S`, or there is no pose at the stamp (`local_at`)."""
        if not await self.reached(stamp):
            return None
        local = self.local_at(stamp)
        return None if local is None else (local, compose(self.world_from_local, local))


def objects_in_view(map_data: MapData, pose: tuple[float, float, float], reach: float = 24.0) -> tuple[MapObject, ...]:
    """Return the map objects whose footprint meets the sensor's reach ahead of `pose` (`world`)."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    fan = Polygon([(x + c * a - s * b, y + s * a + c * b) for a, b in
                   [(0.0, -1.0), (reach, -reach * 0.9), (reach, reach * 0.9), (0.0, 1.0)]])
    out = []
    for o in map_data.world.objects:
        g = Polygon(o.polygon) if o.polygon is not None else Point(o.center).buffer(o.radius or 0.1)
        if g.intersects(fan):
            out.append(map_object(o))
    return tuple(out)
