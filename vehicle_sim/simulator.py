"""The pure stepping simulator: world + vehicle + odometry + command supervisor + events, deterministic from a seed.

No network, no wall clock: `Simulator.step()` advances sim time by one physics step (1 / physics_hz [s]).
Frames: truth in `world`; odometry in `local` (starts at (0, 0, 0) at the start pose and drifts).
On rough ground (a world with terrain) the body rests on its wheels (`vehicle_sim.ground_contact`):
the truth carries its height, roll and pitch, and a tip-over or a high-centring stops the vehicle for
good (an event each), a collision with the ground blocks it as a collision with an object does.
"""

from __future__ import annotations

from vehicle_sim.errors import SimError

import math
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from wire.drive import DriveCommand, Odometry, SimClock, SimEvent, TruthPose, VehicleLimits
from wire.se2 import compose_tuple, wrap_angle
from vehicle_sim.actors import ActorSet
from vehicle_sim.ground_contact import GroundPose, body_for, hazards, rest_on_ground
from vehicle_sim.kinematics import VehicleParams, VehicleState, limits_of, params_for, step
from vehicle_sim.odometry import DEFAULT_ODOMETRY, NoiseSource, OdometryModel, OdometryState, odometry_step
from vehicle_sim.watchdog import CommandSupervisor
from vehicle_sim.worldfile import KINDS, PostShape, PrismShape, TreeShape, World

__all__ = ["SimConfig", "Simulator", "CommandRejected"]


class CommandRejected(SimError, ValueError):
    """A drive command the vehicle cannot execute (e.g. turn-in-place on the Navlab)."""


class SimConfig(BaseModel):
    """Simulator settings: vehicle, physics rate [Hz], watchdog timeout [s], odometry model, seed."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    vehicle: Literal["terregator", "navlab"] = "terregator"
    physics_hz: float = Field(default=100.0, gt=0.0, le=2000.0)
    watchdog_timeout: float = Field(default=0.5, gt=0.0)
    odometry: OdometryModel = DEFAULT_ODOMETRY
    seed: int = 0
    #: stop the vehicle where it touches an obstacle (True) or let it pass through (False)
    collisions_block: bool = True


class Simulator:
    """Step a vehicle through a world: commands in; truth, odometry and events out.

    `rng` (or `config.seed`) seeds the odometry noise; the same seed and the same command sequence
    (submitted at the same sim times) give the same trajectory and odometry.
    """

    def __init__(
        self,
        world: World,
        config: SimConfig = SimConfig(),
        *,
        rng: np.random.Generator | None = None,
        start: tuple[float, float, float] | None = None,
        params: VehicleParams | None = None,
        actors: ActorSet | None = None,
    ) -> None:
        self.world = world
        self.actors = actors if actors is not None else ActorSet()
        self._actor_contact: str | None = None
        self.actor_clearance_min = math.inf  # closest approach of the footprint to any actor [m]
        self.config = config
        self.params: VehicleParams = params if params is not None else params_for(config.vehicle)
        if self.params.kind != config.vehicle:
            raise ValueError(f"params are for {self.params.kind!r} but the config says {config.vehicle!r}")
        self.limits: VehicleLimits = limits_of(self.params)
        self.dt = 1.0 / config.physics_hz
        if start is None:
            s = world.start
            start = (s.x, s.y, s.yaw) if s is not None else (0.0, 0.0, 0.0)
        self.start = (float(start[0]), float(start[1]), float(start[2]))
        self.state = VehicleState(x=self.start[0], y=self.start[1], yaw=self.start[2])
        self.odom = OdometryState()
        self.slips = 0  # odometry jumps injected (faults)
        self.supervisor = CommandSupervisor(config.watchdog_timeout)
        self._noise = NoiseSource(rng if rng is not None else np.random.default_rng(config.seed))
        self.steps = 0
        self.t = 0.0
        self._events: list[SimEvent] = []
        self._in_collision: str | None = None
        self._off_path = False
        self._setup_ground_lookup()
        self._check_ground(self.state, initial=True)
        # rough ground: the body on its wheels, the hazards it meets; `disabled` says why it can move no more
        self.ground: GroundPose | None = None
        self.disabled: str | None = None
        self._terrain_kinds: set[str] = set()
        self._terrain_checked: tuple[float, float, float] | None = None
        self._body = body_for(config.vehicle) if world.terrain_raster is not None else None
        if self._body is not None:
            self._check_terrain(self.state, initial=True)

    # ---- ground lookup (cheap per step) --------------------------------------------------

    def _setup_ground_lookup(self) -> None:
        w = self.world
        w.object_index_at(np.zeros((1, 2)))  # build the raster
        self._raster = w._raster
        self._origin = w._origin
        self._res = w.raster_res
        n = len(w.objects)
        self._solid = np.zeros(n + 1, dtype=bool)
        self._path = np.zeros(n + 1, dtype=bool)
        for i, o in enumerate(w.objects):
            self._solid[i + 1] = isinstance(o.shape, (PrismShape, TreeShape, PostShape))
            self._path[i + 1] = o.role == "path"
        # footprint sample points in the vehicle frame: perimeter every ~0.5 m
        p = self.params
        x0, x1 = -p.rear_overhang, p.length - p.rear_overhang
        y0, y1 = -p.width / 2.0, p.width / 2.0
        nx = max(2, int(math.ceil((x1 - x0) / 0.5)) + 1)
        ny = max(2, int(math.ceil((y1 - y0) / 0.5)) + 1)
        xs = np.linspace(x0, x1, nx)
        ys = np.linspace(y0, y1, ny)
        pts = [(x, y0) for x in xs] + [(x, y1) for x in xs] + [(x0, y) for y in ys[1:-1]] + [(x1, y) for y in ys[1:-1]]
        self._footprint = np.asarray(pts, dtype=np.float64)

    def _cells(self, xy: np.ndarray) -> np.ndarray:
        ij = np.floor((xy - self._origin) * (1.0 / self._res)).astype(np.int64)
        h, w = self._raster.shape
        if ij.min() < 0 or ij[:, 0].max() >= w or ij[:, 1].max() >= h:
            ij[:, 0] = np.clip(ij[:, 0], 0, w - 1)
            ij[:, 1] = np.clip(ij[:, 1], 0, h - 1)
        return self._raster[ij[:, 1], ij[:, 0]].astype(np.int64)

    def _cell(self, x: float, y: float) -> int:
        h, w = self._raster.shape
        i = min(max(int(math.floor((x - self._origin[0]) / self._res)), 0), w - 1)
        j = min(max(int(math.floor((y - self._origin[1]) / self._res)), 0), h - 1)
        return int(self._raster[j, i])

    def footprint_world(self, state: VehicleState | None = None) -> np.ndarray:
        """Return the footprint sample points of the vehicle in the world frame, (K, 2) [m]."""
        s = state or self.state
        c, si = math.cos(s.yaw), math.sin(s.yaw)
        return self._footprint @ np.array([[c, si], [-si, c]]) + (s.x, s.y)

    def _check_ground(self, s: VehicleState, initial: bool = False) -> bool:
        """Update collision / off-path status for state `s`; return True when `s` collides."""
        cells = self._cells(self.footprint_world(s))
        solid = self._solid[cells]
        if solid.any():
            idx = int(cells[solid][0]) - 1
            obj = self.world.objects[idx]
            if self._in_collision != obj.id and not initial:
                self._events.append(SimEvent(stamp=self.t, kind="collision", x=s.x, y=s.y, object_id=obj.id, object_kind=obj.kind,
                                             detail=f"vehicle touched {obj.kind} {obj.id!r}"))
            self._in_collision = obj.id
            collided = True
        else:
            self._in_collision = None
            collided = False
        centre = self._cell(s.x, s.y)
        off = not bool(self._path[centre])
        if off != self._off_path:
            kind = "off-path" if off else "on-path"
            under = self.world.objects[centre - 1] if centre > 0 else None
            self._events.append(SimEvent(stamp=self.t, kind=kind, x=s.x, y=s.y,
                                         object_id=under.id if under else None,
                                         object_kind=under.kind if under else KINDS[0]))
            self._off_path = off
        return collided

    # ---- commands --------------------------------------------------------------------------

    def submit(self, command: DriveCommand) -> None:
        """Accept a drive command at the current sim time; raise `CommandRejected` (and log an event) if impossible."""
        if not self.limits.turns_in_place and (command.turn_rate is not None or any(s.turn_rate is not None for s in command.then)):
            ev = SimEvent(stamp=self.t, kind="rejected", x=self.state.x, y=self.state.y,
                          detail=f"{self.limits.name} cannot turn in place: turn_rate must be omitted (seq {command.seq})")
            self._events.append(ev)
            raise CommandRejected(ev.detail)
        self.supervisor.submit(command, self.t)

    # ---- stepping ----------------------------------------------------------------------------

    def step(self) -> list[SimEvent]:
        """Advance sim time by one physics step; return the events that happened (and drain them)."""
        sup = self.supervisor.tick(self.t)
        if sup.tripped:
            self._events.append(SimEvent(stamp=self.t, kind="watchdog", x=self.state.x, y=self.state.y,
                                         detail=f"no drive command for {self.config.watchdog_timeout} s: stopping"))
        elif sup.exhausted:
            self._events.append(SimEvent(stamp=self.t, kind="commands-exhausted", x=self.state.x, y=self.state.y,
                                         detail="timed commands ran out: stopping"))
        prev = self.state
        new = step(prev, sup.command, self.dt, self.params)
        if self.disabled is not None:  # tipped over or high-centred: it stays where it is
            new = VehicleState(x=prev.x, y=prev.y, yaw=prev.yaw, v=0.0, kappa=prev.kappa, omega=0.0)
        self.steps += 1
        self.t = self.steps * self.dt
        ds = 0.5 * (prev.v + new.v) * self.dt  # the arc length the kinematics integrated [m]
        if self._check_ground(new) and self.config.collisions_block:
            new = VehicleState(x=prev.x, y=prev.y, yaw=prev.yaw, v=0.0, kappa=prev.kappa, omega=0.0)
            ds = 0.0
        if len(self.actors) and self._check_actors(new) and self.config.collisions_block:
            new = VehicleState(x=prev.x, y=prev.y, yaw=prev.yaw, v=0.0, kappa=prev.kappa, omega=0.0)
            ds = 0.0
        if self._body is not None and self._check_terrain(new) and self.config.collisions_block:
            new = VehicleState(x=prev.x, y=prev.y, yaw=prev.yaw, v=0.0, kappa=prev.kappa, omega=0.0)
            ds = 0.0
            self.ground = rest_on_ground(self.world.elevation, new.x, new.y, new.yaw, self._body)
        dyaw = wrap_angle(new.yaw - prev.yaw)
        self.odom = odometry_step(self.odom, ds, dyaw, self.dt, self.config.odometry, self._noise.pair())
        self.state = new
        return self.drain_events()

    def slip_odometry(self, dx: float, dy: float, dyaw: float) -> None:
        """Jump the odometry by (dx, dy [m], dyaw [rad]) in the `vehicle` frame, the vehicle itself unmoved.

        A wheel slip or encoder glitch: the `position-jump` fault (issue 10). Every estimate built on
        the odometry jumps with it, whatever the architecture does with position fixes.
        """
        o = self.odom
        x, y, yaw = compose_tuple((o.x, o.y, o.yaw), (dx, dy, dyaw))
        self.odom = OdometryState(x=x, y=y, yaw=yaw, distance=o.distance, v=o.v, omega=o.omega)
        self.slips += 1

    def advance(self, duration: float) -> list[SimEvent]:
        """Step for `duration` [s] of sim time; return every event that happened."""
        n = int(round(duration / self.dt))
        out: list[SimEvent] = []
        for _ in range(n):
            out += self.step()
        return out

    def _check_terrain(self, s: VehicleState, initial: bool = False) -> bool:
        """Rest the body on the terrain at `s`; log tip-over, high-centring, a collision with the ground; True when blocked.

        The body's pose is found every step, the hazards whenever it moved 5 cm or turned 0.5° since.
        """
        body = self._body
        assert body is not None
        height = self.world.elevation
        last = self._terrain_checked
        if not initial and last is not None and math.hypot(s.x - last[0], s.y - last[1]) < 0.05 \
                and abs(wrap_angle(s.yaw - last[2])) < math.radians(0.5):
            self.ground = rest_on_ground(height, s.x, s.y, s.yaw, body)
            return "collision" in self._terrain_kinds
        self._terrain_checked = (s.x, s.y, s.yaw)
        self.ground, found = hazards(height, s.x, s.y, s.yaw, body)
        kinds = {h.kind for h in found}
        for h in found:
            if h.kind not in self._terrain_kinds and not initial:
                self._events.append(SimEvent(stamp=self.t, kind=h.kind, x=s.x, y=s.y, object_kind="terrain",  # type: ignore[arg-type]
                                             detail=h.detail))
            if h.kind in ("tip-over", "high-centred") and self.disabled is None and not initial:
                self.disabled = h.kind
        self._terrain_kinds = kinds
        return "collision" in kinds

    def blocked_at(self, x: float, y: float, yaw: float) -> str | None:
        """Return why the vehicle could not stand at (x, y) [m], heading yaw [rad] (a solid touched, a terrain hazard), or None.

        A truth query for generators and evaluation: it logs no event and changes nothing.
        """
        cells = self._cells(self.footprint_world(VehicleState(x=x, y=y, yaw=yaw)))
        solid = self._solid[cells]
        if solid.any():
            obj = self.world.objects[int(cells[solid][0]) - 1]
            return f"touches {obj.kind} {obj.id!r}"
        if self._body is not None:
            _, found = hazards(self.world.elevation, x, y, yaw, self._body)
            if found:
                return "; ".join(f"{h.kind}: {h.detail}" for h in found)
        return None

    def _check_actors(self, s: VehicleState) -> bool:
        """Move the actors to now, track the closest approach, log a collision on first contact; True while touching."""
        self.actors.update(self.t, (s.x, s.y))
        pts = self.footprint_world(s)
        touching = None
        near = None  # still in contact: a blocked vehicle stays where it touched (hysteresis of 0.1 m)
        for a, corners in self.actors.footprints(self.t):
            d = _clearance(pts, corners)
            self.actor_clearance_min = min(self.actor_clearance_min, d)
            if d <= 0.0 and touching is None:
                touching = a
            if d <= 0.1 and a.id == self._actor_contact:
                near = a.id
        if touching is not None and self._actor_contact != touching.id:
            self._events.append(SimEvent(stamp=self.t, kind="collision", x=s.x, y=s.y, object_id=touching.id, object_kind="rock",
                                         detail=f"vehicle touched {touching.kind} {touching.id!r} (not on the map)"))
        self._actor_contact = touching.id if touching is not None else near
        return touching is not None

    def drain_events(self) -> list[SimEvent]:
        """Return and forget the events not yet returned."""
        ev, self._events = self._events, []
        return ev

    # ---- outputs -------------------------------------------------------------------------------

    def truth(self) -> TruthPose:
        """Return the true pose of the vehicle in the world frame now."""
        s = self.state
        if self.ground is not None:
            g = self.ground
            return TruthPose(stamp=self.t, x=s.x, y=s.y, z=g.z, yaw=s.yaw, v=s.v, omega=s.omega, curvature=s.kappa,
                             roll=g.roll, pitch=g.pitch)
        z = self.world.elevation_at(s.x, s.y)
        return TruthPose(stamp=self.t, x=s.x, y=s.y, z=z, yaw=s.yaw, v=s.v, omega=s.omega, curvature=s.kappa)

    def odometry(self) -> Odometry:
        """Return the dead-reckoned pose of the vehicle in the local frame now."""
        o = self.odom
        return Odometry(stamp=self.t, x=o.x, y=o.y, yaw=o.yaw, v=o.v, omega=o.omega, distance=o.distance)

    def clock(self, rtf: float = 0.0, rtf_actual: float = 0.0) -> SimClock:
        """Return the sim clock now (rtf fields are the node's business)."""
        return SimClock(stamp=self.t, rtf=rtf, rtf_actual=rtf_actual, step=self.steps)

    @property
    def off_path(self) -> bool:
        """Return True while the vehicle's centre is not on a path object."""
        return self._off_path

    @property
    def colliding_with(self) -> str | None:
        """Return the id of the obstacle the vehicle touches, if any."""
        return self._in_collision


def _clearance(points: np.ndarray, corners: np.ndarray) -> float:
    """Return the distance [m] from the vehicle footprint samples (K, 2) to a convex box (4, 2); <= 0 inside."""
    c = corners.mean(axis=0)
    e = np.roll(corners, -1, axis=0) - corners
    n = np.stack([e[:, 1], -e[:, 0]], -1) / np.linalg.norm(e, axis=1, keepdims=True)
    if float(np.dot(n[0], corners[0] - c)) < 0:
        n = -n
    signed = ((points[:, None, :] - corners[None]) * n[None]).sum(-1).max(axis=1)  # (K,) >0 outside
    if (signed <= 0).any():
        return float(signed.min())
    # outside: distance to the nearest edge segment
    t = np.clip(((points[:, None, :] - corners[None]) * e[None]).sum(-1) / (e * e).sum(-1)[None], 0.0, 1.0)
    proj = corners[None] + t[..., None] * e[None]
    return float(np.linalg.norm(points[:, None, :] - proj, axis=-1).min())
