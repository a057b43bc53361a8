"""The integrated controller as an EDDIE module: on the simulator's drive interface, answering and publishing.

Inbox and service `command`: controller commands (`eddie.messages.controller`); the inbox also takes
the map manager's `set_speed` triggers (a mission speed cap over every client); service `position`:
the dead-reckoned pose now; service `recorded_path`: a stretch of the driven path. Streams: `state`
every control tick (≥ 10 Hz sim) with the odometry of the periods it missed (`trail`: a controller held
up publishes what queued meanwhile), `path` when the path changes, `events` for every event (also written
to the process log).
"""

from __future__ import annotations

import logging
import math
from collections import deque

from wire.drive import DriveMessageError, Odometry, decode, encode
from wire.keys import SimKeys
from wire.lockstep import lockstep_enabled

from eddie.controller.integrated_controller import ControllerConfig, IntegratedController
from eddie.errors import BadMessage, ControlRefused
from eddie.messages.map_manager import SetSpeed, TriggerMessage, open_trigger_data
from eddie.messages.controller import (
    MAX_TRAIL, DeadReckon, Nudge, PathCommand, PositionQuery, RecordedPath, RecordedPathQuery, Release, SpeedLimit, Stop,
)
from eddie.toolkit.message import Message
from eddie.toolkit.module import Incoming, Module
from wire.ratelimit import warn_limited

__all__ = ["ControllerModule", "COMMANDS"]

log = logging.getLogger(__name__)
#: The controller's event log (INFO, written whatever SIDEWALK_LOG says: the log of events is part of the controller).
event_log = logging.getLogger("eddie.controller.events")
event_log.setLevel(logging.INFO)

#: Messages the controller takes as commands.
COMMANDS = (PathCommand, DeadReckon, SpeedLimit, Nudge, Stop, Release)


class ControllerModule:
    """Run an `IntegratedController` on module endpoint `m` (named `controller` by convention)."""

    def __init__(self, m: Module, cfg: ControllerConfig) -> None:
        self.m = m
        self.cfg = cfg
        self.core = IntegratedController(cfg)
        self.sim = SimKeys(m.net.namespace)
        self.bad_odometry = 0
        #: lock-step: the state goes out as the odometry of each control period arrives (the simulator announces
        #: sim time t only once it was handled), so every module woken at t already holds the controller's pose of t
        self._state_on_odom = lockstep_enabled()
        self._next_state: float | None = None  # sim time [s] of the next state published on odometry (None: not started)
        #: real time: odometry of each control period since the last state published, for its `trail`
        self._trail: deque[tuple[float, float, float, float]] = deque(maxlen=MAX_TRAIL)
        self._next_trail = -math.inf

    def _on_odom(self, _key: str, payload: bytes) -> None:
        try:
            od = decode(Odometry, payload)
            self.core.odometry(od)
        except DriveMessageError as exc:
            self.bad_odometry += 1
            warn_limited(log, "bad-odometry", "controller: bad odometry: %.200s", exc)
            return
        if not self._state_on_odom and od.stamp >= self._next_trail:
            self._trail.append((od.stamp, od.x, od.y, od.yaw))
            self._next_trail = od.stamp + 1.0 / self.cfg.control_hz - 1e-6
        if self._next_state is not None and od.stamp >= self._next_state:
            # stamped with the odometry's time: it may arrive before the clock tick of the same step
            self.m.publish("state", self.core.state(od.stamp), stamp=od.stamp)
            self._next_state = od.stamp + 1.0 / self.cfg.control_hz - 1e-6

    def _publish_state(self, now: float) -> None:
        """Publish the state with the odometry of the control periods since the previous one as its trail.

        Not before the first odometry: a pose of (0, 0, 0) stamped now would enter every pose history as the vehicle's.
        """
        if self.core.odom is None:
            return
        st = self.core.state(now)
        trail = tuple(s for s in self._trail if s[0] < st.stamp)
        self._trail.clear()
        self.m.publish("state", st.model_copy(update={"trail": trail}) if trail else st)

    def _now(self) -> float:
        return self.m.now() or 0.0

    async def _position(self, inc: Incoming) -> Message:
        if not isinstance(inc.message, PositionQuery):
            raise BadMessage(f"position from {inc.sender!r}: expected a PositionQuery", sender=inc.sender, field="type")
        pos = self.core.position()
        if pos is None:
            raise ControlRefused("no odometry yet (is the simulator running?)")
        return pos

    async def _recorded(self, inc: Incoming) -> Message:
        q = inc.message
        if not isinstance(q, RecordedPathQuery):
            raise BadMessage(f"recorded_path from {inc.sender!r}: expected a RecordedPathQuery", sender=inc.sender, field="type")
        return RecordedPath(points=tuple(self.core.record.stretch(q.odometer_from, q.odometer_to)),
                            odometer_from=q.odometer_from, odometer_to=q.odometer_to)

    async def _command(self, inc: Incoming) -> Message:
        if not isinstance(inc.message, COMMANDS):
            raise BadMessage(f"command from {inc.sender!r}: {type(inc.message).__name__} is not a controller command",
                             sender=inc.sender, field="type")
        ack = self.core.command(inc.message, self._now())
        self._flush()
        return ack

    def _trigger(self, msg: TriggerMessage) -> None:
        data = open_trigger_data(msg)
        if not isinstance(data, SetSpeed):
            raise BadMessage(f"trigger {msg.annotation_id!r}: {type(data).__name__} is not for the controller", field="data")
        self.core.set_mission_speed(data.speed, self._now(), msg.annotation_id)
        self._flush()

    def _flush(self) -> None:
        for ev in self.core.take_events():
            event_log.info("t=%.2f %s client=%s %s", ev.stamp, ev.kind, ev.client, ev.detail)
            self.m.publish("events", ev)
        if self.core.path_changed:
            self.m.publish("path", self.core.path_message(self._now()))

    async def _inbox(self) -> None:
        while True:
            try:
                inc = await self.m.receive()
            except BadMessage as exc:
                warn_limited(log, "bad-inbox", "controller: %.200s", exc)
                continue
            try:
                if isinstance(inc.message, TriggerMessage):
                    self._trigger(inc.message)
                else:
                    await self._command(inc)
            except BadMessage as exc:
                warn_limited(log, "bad-command", "controller: %.200s", exc)

    async def run(self) -> None:
        """Drive until cancelled; always leave the vehicle commanded to stop."""
        import asyncio

        m = self.m
        m.link.subscribe(self.sim.odom, self._on_odom)
        m.serve("position", self._position)
        m.serve("command", self._command)
        m.serve("recorded_path", self._recorded)
        await m.clock.wait_running()
        inbox = asyncio.ensure_future(self._inbox())
        m.ready()
        period = 1.0 / self.cfg.control_hz
        if self._state_on_odom:
            if self.core.odom is not None:
                m.publish("state", self.core.state(m.clock.now()))
            self._next_state = m.clock.now() + period - 1e-6
        try:
            while True:
                now = m.clock.now()
                cmd = self.core.tick(now)
                m.link.put(self.sim.cmd, encode(cmd))
                if not self._state_on_odom:
                    self._publish_state(now)
                self._flush()
                await m.clock.sleep(period)
        finally:
            inbox.cancel()
            try:
                m.link.put(self.sim.cmd, encode(self.core.tick(self._now()).model_copy(update={"speed": 0.0, "turn_rate": None})))
            except Exception as exc:  # noqa: BLE001 - the session may be closing
                log.warning("controller: final stop not sent: %s", exc)
