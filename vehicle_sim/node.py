"""The simulator node: runs a `Simulator` against the wall clock at a real-time factor and serves it over Zenoh.

In lock-step (`NodeConfig.lockstep`, `sidewalk up sim --lockstep`) there is no wall-clock pacing:
the node publishes sim time 0 and holds there (publishing it again every `HOLD_REPUBLISH_S` [s wall]
for processes that start late) until released on `sim/lockstep/release` (`sidewalk run` releases
it once the mission is accepted, so every run starts its mission at the same step); then, at each
clock publication, it publishes clock, odometry and truth, waits for the barrier
(`wire.lockstep.Barrier`: every participant has handled what it received, captures asked at that
sim time included: the capture worker serves them meanwhile), applies the drive commands received
and steps on. Each publication has two phases, each closed by the barrier: odometry and truth of t,
then the tick t (a module woken at t reads the state of t, whichever process ran first). Clock,
odometry and truth are then never dropped under congestion.

Keys under `sidewalk/<ns>/` (see `wire.keys.SimKeys`, docs/keys.md): sim/clock, sim/odom, sim/truth, sim/events
(published, msgpack), sim/cmd (subscribed: `DriveCommand`, msgpack or JSON), sim/slip (subscribed:
`OdometrySlip`, the position-jump fault), sim/capture, sim/info,
sim/map, sim/world (queryables), alive/sim (liveliness), heartbeat/sim (1 Hz wall clock).
Threads: the physics loop, a capture worker (captures asked at one sim instant rendered once,
`vehicle_sim.instant_captures`), the preview pump; zenoh callbacks only enqueue.
"""

from __future__ import annotations

import json
import logging
import os
import socket
import queue
import threading
import time
from collections import deque
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from wire.keys import SimKeys
from wire.network import NetworkConfig
from wire.health import process_usage
from wire.lockstep import Barrier, LockstepRelease, encode as encode_lockstep
from wire.session import Query, Session, open_session, barrier_traffic, traffic
from wire.drive import DriveCommand, OdometrySlip, SimEvent, SimHeartbeat, SimInfo, WireError, decode, encode
from vehicle_sim.actors import ActorSet, load_actors
from vehicle_sim.instant_captures import InstantCaptures
from vehicle_sim.mapgen import map_for
from vehicle_sim.preview_pump import PreviewPump
from vehicle_sim.odometry import DEFAULT_ODOMETRY, OdometryModel
from vehicle_sim.simulator import CommandRejected, SimConfig, Simulator
from vehicle_sim.worldfile import World

__all__ = ["SimKeys", "NodeConfig", "SimNode", "BARRIER_LINE"]  # SimKeys re-exported from wire.keys

log = logging.getLogger("vehicle_sim.node")

#: How often [s wall] a lock-step node held at its start publishes its clock, odometry and truth again.
HOLD_REPUBLISH_S = 0.2
#: How `sidewalk up sim` starts the line it prints at exit with the lock-step barrier's figures (`BarrierStats` JSON after it).
BARRIER_LINE = "sim: lock-step barrier "


class NodeConfig(BaseModel):
    """Node settings: vehicle, real-time factor, physics and publish rates [Hz] (sim time), seed, map error scale."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    vehicle: Literal["terregator", "navlab"] = "terregator"
    rtf: float = Field(default=1.0, gt=0.0, le=1000.0)
    seed: int = 0
    physics_hz: float = Field(default=100.0, gt=0.0, le=2000.0)
    publish_hz: float = Field(default=20.0, gt=0.0)
    watchdog_timeout: float = Field(default=0.5, gt=0.0)
    map_error: float = Field(default=1.0, ge=0.0)
    odometry: OdometryModel = DEFAULT_ODOMETRY
    capture_workers: int = Field(default=1, ge=1, le=8)
    #: where the vehicle starts: x, y [m] in `world`, yaw [rad]; None = the world file's start
    start: tuple[float, float, float] | None = None
    #: objects not on the map: an actors file (JSON/YAML) or a preset name (`vehicle_sim.actors`)
    actors: str | None = None
    #: step only when every lock-step participant handled its inputs (no wall-clock pacing; `rtf` unused)
    lockstep: bool = False
    #: lock-step: how long [s wall] a participant may stay silent before it is skipped for a step
    lockstep_timeout_s: float = Field(default=2.0, gt=0.0)


class SimNode:
    """A simulator served over Zenoh; `start()` → ready, `stop()` → session closed."""

    def __init__(self, world: World, config: NodeConfig, net: NetworkConfig) -> None:
        if config.publish_hz > config.physics_hz:
            raise ValueError(f"publish_hz {config.publish_hz} must not exceed physics_hz {config.physics_hz}")
        self.world = world
        self.config = config
        self.net = net
        self.keys = SimKeys(net.namespace)
        # the world file's own actors, then those of the run's --actors
        self.actors = world.actor_set() + (load_actors(config.actors) if config.actors else ActorSet())
        self.sim = Simulator(
            world,
            SimConfig(vehicle=config.vehicle, physics_hz=config.physics_hz, watchdog_timeout=config.watchdog_timeout,
                      odometry=config.odometry, seed=config.seed),
            start=config.start,
            actors=self.actors,
        )
        self._publish_every = max(1, int(round(config.physics_hz / config.publish_hz)))
        self._cmds: deque[bytes] = deque()
        self._slips: deque[bytes] = deque()
        self._captures: queue.Queue = queue.Queue()
        self._stop = threading.Event()
        self._wake = threading.Event()
        self._lock = threading.Lock()  # guards the pose snapshot
        self._snapshot = (self.sim.t, self.sim.state)
        self._threads: list[threading.Thread] = []
        self._session: Session | None = None
        self.session_closed = True  # False once a close did not finish in time (see `stop`)
        self._scene = None
        self._map_json: bytes | None = None
        self._world_json: bytes | None = None
        self.rtf_actual = 0.0
        self.overruns = 0
        self.commands_received = 0
        self.commands_rejected = 0
        self.step_time_total = 0.0
        self._error: BaseException | None = None
        self._hb_seq = 0
        self.instants = InstantCaptures()
        self._previews: PreviewPump | None = None
        self._released = threading.Event()
        self.barrier: Barrier | None = None

    # ---- lifecycle ---------------------------------------------------------------------------

    @property
    def captures_served(self) -> int:
        """Return the captures rendered so far (one asked again at a sim instant already rendered is served, not counted)."""
        return self.instants.renders

    def info(self) -> SimInfo:
        """Return what this node simulates."""
        s = self.sim
        return SimInfo(
            world=self.world.name, vehicle=self.config.vehicle, limits=s.limits, seed=self.config.seed, rtf=self.config.rtf,
            physics_hz=self.config.physics_hz, publish_hz=self.config.physics_hz / self._publish_every,
            watchdog_timeout=self.config.watchdog_timeout, start_x=s.start[0], start_y=s.start[1], start_yaw=s.start[2],
            map_error=self.config.map_error,
        )

    def start(self) -> None:
        """Open the session, declare everything, start the loop; return once serving (the node is ready)."""
        from vehicle_sim.scene import Scene
        from vehicle_sim.sensors.capture import warm_up

        self._scene = Scene(self.world, seed=self.config.seed)
        if len(self.actors):
            self._scene.add_actors(self.actors)
        warm_up(self._scene, vehicle=self.config.vehicle)  # the first capture a module asks for must not compile the ray caster
        self._map_json = json.dumps(map_for(self.world, self.config.map_error, self.config.seed).to_geojson()).encode()
        self._world_json = json.dumps(self.world.to_geojson()).encode()
        self._session = z = open_session(self.net)
        try:
            z.wait_connected(name="sim", cancelled=self._stop.is_set)  # never serve (and say ready) while connected to nothing
            k = self.keys
            lossy = not self.config.lockstep  # in lock-step a lost tick would change what the modules do
            # in real time batched, not express: at RTF 50 these go out 1000 times a second [wall] each, and a
            # busy subscriber filled its few one-sample batches, so every publish waited (or dropped): the
            # physics loop fell to RTF 25 for a tenth of the run (session 17)
            self._pub_clock = z.publisher(k.clock, droppable=lossy, express=not lossy)
            self._pub_odom = z.publisher(k.odom, droppable=lossy, express=not lossy)
            self._pub_truth = z.publisher(k.truth, droppable=lossy, express=not lossy)
            self._pub_events = z.publisher(k.events)
            self._pub_hb = z.publisher(k.heartbeat, droppable=True)
            self._pub_preview = z.publisher(k.preview, droppable=True)  # monitor/recorder only: may drop, never blocks
            self._previews = PreviewPump(self._pub_preview.put)
            self._previews.start()
            z.subscribe_payload(k.cmd, self._on_cmd)
            z.subscribe_payload(k.slip, lambda _k, payload: self._slips.append(payload))
            z.queryable(k.capture, self._on_capture)
            z.queryable(k.truth_capture, lambda q: self._on_capture(q, truth=True))
            z.queryable(k.info, self._on_info)
            z.queryable(k.map, lambda q: self._reply_static(q, self._map_json))
            z.queryable(k.world, lambda q: self._reply_static(q, self._world_json))
            if self.config.lockstep:
                self.barrier = Barrier(z, timeout_s=self.config.lockstep_timeout_s)
                z.queryable(k.lockstep_release, self._on_release)
            for i in range(self.config.capture_workers):
                t = threading.Thread(target=self._capture_worker, name=f"sim-capture-{i}", daemon=True)
                t.start()
                self._threads.append(t)
            loop = threading.Thread(target=self._run_loop, name="sim-physics", daemon=True)
            loop.start()
            self._threads.append(loop)
            z.liveliness_token(k.alive)
        except BaseException:
            self.stop()
            raise

    def request_stop(self) -> None:
        """Ask the node to stop (safe from a signal handler); `stop()` then finishes the job."""
        self._stop.set()
        self._wake.set()

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the loop and workers, then close the session (idempotent).

        Each thread is waited for `timeout` [s wall], and so is the session's close: a Zenoh close can hang
        (as the router's does, see `wire.router.serve_router`); `session_closed` then says False and the
        process may exit without it (the simulator keeps no state).
        """
        self._stop.set()
        self._wake.set()
        for _ in self._threads:
            self._captures.put(None)
        for t in self._threads:
            t.join(timeout)
        self._threads.clear()
        if self._previews is not None:
            self._previews.stop(timeout)
        if self.barrier is not None:
            log.info("lock-step barrier: %s", self.barrier.stats.model_dump_json())
            self.barrier.close()
        if self._session is not None:
            self.session_closed = self._session.close_within(timeout, "sim")
            self._session = None

    def wait(self, timeout: float | None = None) -> bool:
        """Block until the node stops (or `timeout` [s] wall passes); return True if stopped."""
        return self._stop.wait(timeout)

    @property
    def error(self) -> BaseException | None:
        """Return the exception that stopped the physics loop, if any."""
        return self._error

    # ---- callbacks (zenoh threads: enqueue only) ------------------------------------------------

    def _on_cmd(self, key: str, payload: bytes) -> None:
        self._cmds.append(payload)

    def _on_capture(self, q: Query, *, truth: bool = False) -> None:
        with self._lock:
            t, state = self._snapshot
        self._captures.put((q, t, state, truth))

    def _on_release(self, q: Query) -> None:
        with self._lock:
            t, _state = self._snapshot
        was_held = not self._released.is_set()
        self._released.set()
        try:
            q.reply(encode_lockstep(LockstepRelease(sim_time=t, was_held=was_held)))
        finally:
            q.finish()

    def _on_info(self, q: Query) -> None:
        try:
            q.reply(encode(self.info(), as_json=q.is_json), as_json=q.is_json)
        finally:
            q.finish()

    def _reply_static(self, q: Query, data: bytes | None) -> None:
        try:
            if data is not None:
                q.reply(data, as_json=True)
        finally:
            q.finish()

    # ---- capture worker -----------------------------------------------------------------------

    def _capture_worker(self) -> None:
        from vehicle_sim.sensors import CaptureRequest, capture, encode_capture

        while True:
            item = self._captures.get()
            if item is None:
                return
            q, t, state, truth = item
            try:
                if self._stop.is_set():
                    q.reply_err(json.dumps({"error": "simulator is shutting down"}).encode(), as_json=True)
                    continue
                req = decode(CaptureRequest, q.payload) if q.payload else CaptureRequest()
                scene = self._scene
                res, rendered = self.instants.get(t, req, lambda r: capture(scene.at_time(self.actors, t), (state.x, state.y, state.yaw),
                                                                            t, r, vehicle=self.config.vehicle))
                # truth only on its own key, which access control can deny (it cannot see a payload's flag)
                q.reply(encode_capture(res, truth=truth))
                if rendered:
                    self._previews.offer(res, self.captures_served)
            except WireError as exc:
                q.reply_err(json.dumps({"error": "bad capture request", "detail": str(exc)}).encode(), as_json=True)
            except Exception as exc:  # noqa: BLE001 - report any capture failure to the asker
                log.exception("capture failed")
                q.reply_err(json.dumps({"error": "capture failed", "detail": f"{type(exc).__name__}: {exc}"}).encode(), as_json=True)
            finally:
                q.finish()

    # ---- physics loop -------------------------------------------------------------------------

    def _drain_commands(self) -> None:
        sim = self.sim
        while self._slips:
            try:
                slip = decode(OdometrySlip, self._slips.popleft())
            except WireError as exc:
                log.warning("ignoring an odometry slip: %s", exc)
                continue
            sim.slip_odometry(slip.dx, slip.dy, slip.dyaw)
            log.info("odometry slipped by (%.2f, %.2f) m, %.3f rad at %.2f s sim", slip.dx, slip.dy, slip.dyaw, sim.t)
        while self._cmds:
            raw = self._cmds.popleft()
            self.commands_received += 1
            try:
                cmd = decode(DriveCommand, raw)
                sim.submit(cmd)
            except WireError as exc:
                self.commands_rejected += 1
                ev = SimEvent(stamp=sim.t, kind="rejected", x=sim.state.x, y=sim.state.y, detail=str(exc)[:500])
                self._pub_events.put(encode(ev))
            except CommandRejected:
                self.commands_rejected += 1  # the simulator logged a "rejected" event

    def _publish_state(self) -> None:
        """Publish odometry and truth (lock-step: before the tick, see `_step_lockstep`)."""
        sim = self.sim
        self._pub_odom.put(encode(sim.odometry()))
        self._pub_truth.put(encode(sim.truth()))

    def _publish_clock(self) -> None:
        """Publish the sim clock (lock-step: once what the odometry caused is done)."""
        self._pub_clock.put(encode(self.sim.clock(self.config.rtf, self.rtf_actual)))

    def _publish(self) -> None:
        sim = self.sim
        if self.config.lockstep:
            self._publish_state()
            self._publish_clock()
            return
        self._pub_clock.put(encode(sim.clock(self.config.rtf, self.rtf_actual)))
        self._pub_odom.put(encode(sim.odometry()))
        self._pub_truth.put(encode(sim.truth()))

    def _run_loop(self) -> None:
        try:
            self._loop_lockstep() if self.config.lockstep else self._loop()
        except BaseException as exc:  # noqa: BLE001 - keep the reason for the caller
            self._error = exc
            log.exception("simulator loop failed")
            self._stop.set()

    def _beat(self) -> None:
        self._hb_seq += 1
        self._pub_hb.put(encode(SimHeartbeat(seq=self._hb_seq, sim_time=self.sim.t, wall_time=time.time(), period_s=1.0,
                                             pid=os.getpid(), host=socket.gethostname(),
                                             usage=process_usage(traffic(), barrier_traffic()))))

    def _account(self, window: deque[tuple[float, float]], now: float, hb_next: float) -> float:
        """Update the achieved RTF over the last wall second and beat when due at `now` [s perf_counter]; return the next beat."""
        window.append((now, self.sim.t))
        while len(window) > 2 and now - window[0][0] > 1.0:
            window.popleft()
        if len(window) >= 2 and window[-1][0] > window[0][0]:
            self.rtf_actual = (window[-1][1] - window[0][1]) / (window[-1][0] - window[0][0])
        if now >= hb_next:
            self._beat()
            return now + 1.0
        return hb_next

    def _loop_lockstep(self) -> None:
        """Step as fast as the barrier allows: publish, wait for every participant, take the commands, step."""
        sim = self.sim
        barrier = self.barrier
        assert barrier is not None
        every = self._publish_every
        perf = time.perf_counter
        hb_next = perf()
        window: deque[tuple[float, float]] = deque()
        self._publish()
        while not self._released.wait(HOLD_REPUBLISH_S):  # held at the start: say the time again for late starters
            if self._stop.is_set():
                return
            self._publish()
            if perf() >= hb_next:
                self._beat()
                hb_next = perf() + 1.0
        while not self._stop.is_set():
            barrier.wait(sim.steps, sim.t, stop=self._stop)
            # every command sent in answer to what was published has arrived: apply them all before the step
            self._drain_commands()
            t0 = perf()
            for _ in range(every):
                for ev in sim.step():
                    self._pub_events.put(encode(ev))
            self.step_time_total += perf() - t0
            with self._lock:
                self._snapshot = (sim.t, sim.state)
            # two phases: the state of t (odometry, truth), everything it causes (the HELM's pose of t on the
            # blackboard, the controller's position), and only then the tick t, so a module woken at t reads the
            # state of t whichever process ran first
            self._publish_state()
            barrier.wait(sim.steps, sim.t, stop=self._stop)
            self._publish_clock()
            now = perf()
            hb_next = self._account(window, now, hb_next)

    def _loop(self) -> None:
        sim = self.sim
        rtf = self.config.rtf
        dt = sim.dt
        every = self._publish_every
        max_lag = max(0.25, 5 * dt, 0.1 * rtf)  # sim seconds (≈ 0.1 s wall) we may fall behind before re-anchoring
        wake_wall = max(dt / rtf, 0.001)  # at most 1000 wakes per wall second
        perf = time.perf_counter
        wall0 = perf()
        sim0 = sim.t
        hb_next = wall0
        window: deque[tuple[float, float]] = deque()
        self._publish()
        while not self._stop.is_set():
            self._drain_commands()
            now = perf()
            target = sim0 + (now - wall0) * rtf
            if target - sim.t > max_lag:
                self.overruns += 1
                wall0, sim0 = now, sim.t  # re-anchor: drop the backlog rather than spiral
                target = sim.t + dt
            t0 = perf()
            while sim.t + dt <= target + 1e-9 and not self._stop.is_set():
                events = sim.step()
                for ev in events:
                    self._pub_events.put(encode(ev))
                if sim.steps % every == 0:
                    with self._lock:
                        self._snapshot = (sim.t, sim.state)
                    self._publish()
                if self._cmds or self._slips:
                    self._drain_commands()
            self.step_time_total += perf() - t0
            now = perf()
            hb_next = self._account(window, now, hb_next)
            next_wall = wall0 + (sim.t + dt - sim0) / rtf
            delay = max(next_wall - perf(), 0.0)
            if delay > 0.0:
                self._stop.wait(max(delay, wake_wall))
