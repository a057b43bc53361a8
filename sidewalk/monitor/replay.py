"""`sidewalk replay`: a recording played back into the monitor's model at X× sim speed, served as the live page is.

The recorded channels feed the same interpreters the live adapters use: the simulator's keys, the
heartbeats and mission events (`SimSource`), the blackboard token events (`CodgerInterpreter`,
frames from the recorded `/tf` transforms), EDDIE's streams and annotations (`EddieInterpreter`).
Heartbeat ages are judged on the recording's own wall clock, so a module that was wedged in the
run shows as wedged in the replay at any speed.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import contextlib
import math
import signal
import threading
from typing import Any, Optional

from blackboard import FrameTree
from blackboard.errors import BlackboardError
from sidewalk.monitor.codger import CodgerInterpreter
from sidewalk.monitor.eddie import EddieInterpreter
from sidewalk.monitor.errors import PortInUseError
from sidewalk.monitor.model import MonitorModel
from sidewalk.monitor.server import MonitorServer
from sidewalk.monitor.sources import SimSource
from sidewalk.recording import ANNOTATIONS_TOPIC, RecordedMessage, Recording, RecordingError

__all__ = ["serve_replay", "Replayer", "TreeFrames"]


class TreeFrames:
    """World←frame from the recorded transforms (a pose history like the blackboard's)."""

    def __init__(self) -> None:
        self.tree = FrameTree(history=120.0)

    def add(self, value: dict) -> Optional[tuple[str, str, float]]:
        """Add a recorded `foxglove.FrameTransform`; return (parent, child, stamp [s]) or None if malformed."""
        try:
            ts = value["timestamp"]
            t = ts["sec"] + ts["nsec"] * 1e-9
            q = value["rotation"]
            yaw = 2.0 * math.atan2(q["z"], q["w"])
            tr = value["translation"]
            parent, child = value["parent_frame_id"], value["child_frame_id"]
            # the PILOT's world←local holds until corrected; the HELM's poses come at 10 Hz sim
            self.tree.add_pose(parent, child, (tr["x"], tr["y"], yaw), t, hold=math.inf if child == "local" else 1.0)
        except (KeyError, TypeError, ValueError, BlackboardError):
            return None
        return parent, child, t

    async def world_from(self, frame: str, stamp: float) -> Optional[tuple[float, float, float]]:
        """Return world←`frame`@`stamp` (None when the recorded history cannot answer)."""
        try:
            return self.tree.lookup("world", stamp, frame, stamp)
        except BlackboardError:
            return None


class _RecordingWall:
    """The recording's wall clock [s] at the replay's current sim time, from the heartbeats' wall times."""

    def __init__(self) -> None:
        self.hb_wall: Optional[float] = None
        self.hb_sim = 0.0
        self.sim = 0.0
        self.rtf = 1.0

    def __call__(self) -> float:
        if self.hb_wall is None:
            return 0.0
        return self.hb_wall + max(0.0, self.sim - self.hb_sim) / max(self.rtf, 1e-3)


class Replayer:
    """Feed one recording into a model at `speed`× sim speed."""

    def __init__(self, rec: Recording, model: MonitorModel, wall: _RecordingWall, *, speed: float = 1.0) -> None:
        self.rec = rec
        self.model = model
        self.wall = wall
        self.speed = speed
        self.frames = TreeFrames()
        self.sim = SimSource(model)
        self.codger = CodgerInterpreter(model, self.frames)
        self.eddie = EddieInterpreter(model)
        self.fed = 0
        self.done = asyncio.Event()
        self._halt = threading.Event()

    async def run(self) -> None:
        """Play the whole recording, then keep the last state (the page stays up)."""
        loop = asyncio.get_running_loop()
        q: asyncio.Queue[Optional[list[RecordedMessage]]] = asyncio.Queue(maxsize=8)  # bounded: the reader waits for us
        reader = loop.run_in_executor(None, self._read, loop, q)
        t0, end = await asyncio.to_thread(self.rec.time_range)
        wall0 = loop.time()
        last_progress = 0.0
        try:
            while (batch := await q.get()) is not None:
                for m in batch:
                    delay = wall0 + (m.log_time - t0) / self.speed - loop.time()
                    if delay > 0.002:
                        await asyncio.sleep(delay)  # playback pacing
                    await self._feed(m)
                    now = loop.time()
                    if now - last_progress >= 0.5:
                        last_progress = now
                        self.model.set_meta(progress={"t": round(m.log_time, 2), "start": t0, "end": end, "speed": self.speed,
                                                      "done": False})
            self.model.set_meta(progress={"t": end, "start": t0, "end": end, "speed": self.speed, "done": True})
        finally:
            self._halt.set()  # a reader still waiting on the queue gives up
            await asyncio.gather(reader, return_exceptions=True)
            self.done.set()

    def _read(self, loop: asyncio.AbstractEventLoop, q: "asyncio.Queue[Any]") -> None:
        """Read the file in batches into `q` (a thread: the file is read while earlier messages play)."""

        def put(item: Any) -> bool:
            fut = asyncio.run_coroutine_threadsafe(q.put(item), loop)
            while True:
                try:
                    fut.result(timeout=0.5)
                    return True
                except concurrent.futures.TimeoutError:
                    if self._halt.is_set():
                        fut.cancel()
                        return False

        batch: list[RecordedMessage] = []
        try:
            for m in self.rec.messages():
                batch.append(m)
                if len(batch) >= 200:
                    if not put(batch):
                        return
                    batch = []
        except RecordingError as exc:  # a truncated file: play what could be read
            msg = str(exc)
            loop.call_soon_threadsafe(lambda: self.model.set_meta(error=msg))
        if put(batch):
            put(None)

    async def _feed(self, m: RecordedMessage) -> None:
        self.fed += 1
        v, topic = m.value, m.topic
        self.wall.sim = max(self.wall.sim, m.log_time)
        if topic.startswith("/tokens/"):
            if isinstance(v.get("token"), dict):
                await self.codger.on_token(str(v.get("event", "new")), v["token"])
        elif topic == "/tf":
            got = self.frames.add(v)
            if got is not None:
                parent, child, t = got
                if (parent, child) == ("world", "local"):
                    T = await self.frames.world_from("local", t)
                    if T is not None:
                        self.codger.on_world_from_local(t, *T)
                elif (parent, child) == ("local", "vehicle"):
                    T = await self.frames.world_from("vehicle", t)
                    if T is not None:
                        self.codger.on_estimate(t, *T)
        elif topic == "/alive":
            self.sim.on_alive(str(v.get("name", "")), bool(v.get("alive")))
        elif topic == ANNOTATIONS_TOPIC:
            self.eddie.on_annotations(v.get("payload", v))
        else:
            rel = topic[1:]
            if rel.startswith("heartbeat/") and isinstance(v.get("wall_time"), (int, float)):
                self.wall.hb_wall, self.wall.hb_sim = float(v["wall_time"]), m.log_time
            if rel == "sim/clock":
                self.wall.rtf = float(v.get("rtf_actual") or v.get("rtf") or 1.0) or 1.0
            received = float(v["wall_time"]) if rel.startswith("heartbeat/") and "wall_time" in v else None
            if not self.sim.on_sample(rel, v, received=received):
                self.eddie.on_sample(rel, v)


def serve_replay(rec: Recording, *, host: str = "127.0.0.1", port: int = 8080, speed: float = 1.0) -> int:
    """Serve the page with `rec` played back at `speed`× sim speed until SIGINT/SIGTERM; return the exit code."""

    async def main() -> int:
        wall = _RecordingWall()
        model = MonitorModel(arch="replay", replay=True, wall=wall)
        model.set_meta(source=str(rec.path), namespace="replay")
        model.started = 0.0  # on the recording's wall clock: "silent" until its first heartbeat, then judged
        server = MonitorServer(model, host, port)
        try:
            await server.start()
        except PortInUseError as exc:
            print(f"error: {exc}", flush=True)
            return 2
        stop = asyncio.Event()
        loop = asyncio.get_running_loop()
        for sig in (signal.SIGINT, signal.SIGTERM):
            with contextlib.suppress(NotImplementedError, RuntimeError):
                loop.add_signal_handler(sig, stop.set)
        rp = Replayer(rec, model, wall, speed=speed)
        task = asyncio.ensure_future(rp.run())
        print(f"replay: {server.url} ({rec.path}, {speed:g}× sim speed; Ctrl-C to stop)", flush=True)
        try:
            await stop.wait()
        finally:
            task.cancel()
            await asyncio.gather(task, return_exceptions=True)
            await server.stop()
        return 0

    return asyncio.run(main())
