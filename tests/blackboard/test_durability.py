"""Durability: SIGKILL the node while a client streams writes; every acknowledged write is there after restart.

`test_sigkill_while_streaming_loses_no_acknowledged_token` kills a `python -m blackboard` process
once in each sync mode. `test_hundred_sigkills_at_random_points_of_a_write_stream` kills a real
node (forked from `node_zygote`, restarted on the same database each time) at 100 seeded random
points of one stream of writes — 40 of them while the node holds between the journal append of a
commit and its acknowledgement (`--test-hold-after-journal`) — and checks after each restart that
every acknowledged write is there, exactly as written, and that what was not acknowledged is
there whole or not at all (the writes stored form a prefix of the stream, in whole batches).
"""

from __future__ import annotations

import asyncio
import json
import math
import os
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

from blackboard import AttrPredicate, BlackboardClient, BlackboardError, NetworkConfig, NodeUnavailableError, Point, Polygon, Pose2D, Spec, Within
from blackboard.testing import start_node
from tests.blackboard.sample_types import Landmark, Segment
from wire.ports import free_port

pytestmark = pytest.mark.timeout(180)

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("sync", ["normal", "full"])
async def test_sigkill_while_streaming_loses_no_acknowledged_token(tmp_path, sync):
    db = str(tmp_path / "bb.sqlite")
    port = free_port()
    node = start_node(namespace="dur", port=port, db=db, sync=sync, types=("tests.blackboard.sample_types",))
    acked: set[str] = set()
    enough = asyncio.Event()
    stop = False
    failures = 0
    try:
        async with BlackboardClient(node.client_net(), source="streamer", timeout=3.0, reconnect=False) as bb:

            def record(fut: asyncio.Future) -> None:
                nonlocal failures
                if fut.cancelled() or fut.exception() is not None:
                    failures += 1
                    return
                acked.add(fut.result().id)
                if len(acked) >= 400:
                    enough.set()

            async def stream() -> None:
                i = 0
                while not stop:
                    futs = [asyncio.ensure_future(bb.post(Segment(index=i + k), stamp=float(i + k))) for k in range(25)]
                    for f in futs:
                        f.add_done_callback(record)
                    i += 25
                    await asyncio.gather(*futs, return_exceptions=True)

            streamer = asyncio.create_task(stream())
            await asyncio.wait_for(enough.wait(), 60)
            # posts queued now are on their way (the first is sent at once) when the node dies
            extra = [bb.post(Segment(index=-2 - k), stamp=0.0) for k in range(25)]
            for f in extra:
                f.add_done_callback(record)
            node.kill()  # SIGKILL with posts in flight
            stop = True
            await asyncio.wait_for(streamer, 30)
            outcomes = await asyncio.wait_for(asyncio.gather(*extra, return_exceptions=True), 30)
            assert all(isinstance(o, NodeUnavailableError) or o.id in acked for o in outcomes)
        assert failures > 0  # posts were in flight when the node died, and failed rather than hang
    finally:
        node.kill()

    node2 = start_node(namespace="dur", port=port, db=db, sync=sync, types=("tests.blackboard.sample_types",))
    try:
        async with BlackboardClient(node2.client_net(), source="checker") as bb:
            stored = {t["id"] for t in await bb.retrieve_raw(Spec(type="bbt_segment"))}
            missing = acked - stored
            assert not missing, f"{len(missing)} acknowledged tokens lost, e.g. {sorted(missing)[:5]}"
            assert len(stored) >= len(acked) >= 400
            # the node keeps working on the recovered store, and ids are not reused
            t = await bb.post(Segment(index=-1), stamp=0.0)
            assert t.id not in stored
    except BlackboardError:
        raise
    finally:
        node2.stop()


# ------------------------------------------------------------------------------ 100 kill points
KILLS = 100
HOLD_EVERY = 5  # kills 0, 5, 10, … are while holding after the journal append: 20 …
HOLD_RANDOM = 0.25  # … and a quarter of the others, drawn from the seed
WINDOW = 4  # batches in flight at once


class Zygote:
    """The fork server of `node_zygote`: start a node on the database, SIGKILL and reap it."""

    def __init__(self) -> None:
        env = {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}
        self.proc = subprocess.Popen([sys.executable, "-m", "tests.blackboard.node_zygote"], stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, text=True, env=env, cwd=REPO)

    def ask(self, **req) -> dict:
        """Send one request; return the reply (blocking)."""
        assert self.proc.stdin is not None and self.proc.stdout is not None
        self.proc.stdin.write(json.dumps(req) + "\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        assert line, f"the zygote died (exit {self.proc.poll()})"
        rep = json.loads(line)
        assert "error" not in rep, rep
        return rep

    def close(self) -> None:
        """Close its stdin (it kills what it started) and reap it."""
        if self.proc.stdin is not None:
            self.proc.stdin.close()
        self.proc.wait(30)


@dataclass
class Batch:
    """Writes issued in one loop iteration: a pose (sent at once, alone) and 1-4 posts (the next message, one commit)."""

    kill: int
    seq: int
    size: int
    pose_stamp: float
    pose_future: asyncio.Future | None = None
    post_futures: list[asyncio.Future] = field(default_factory=list)
    pose_acked: bool = False
    posts_acked: bool = False

    def landmarks(self) -> list[Landmark]:
        """Return the tokens of the batch, as posted."""
        return [Landmark(name=f"k{self.kill}.b{self.seq}.{i}", info={"kill": self.kill, "seq": self.seq, "i": i, "size": self.size})
                for i in range(self.size)]

    def pose(self) -> Pose2D:
        """Return the local←vehicle pose the batch posts at `pose_stamp` [s]."""
        return Pose2D(x=float(self.seq), y=float(self.kill), yaw=0.001 * self.seq)

    def issue(self, bb: BlackboardClient) -> None:
        """Queue the pose, then the posts (the client sends a loop iteration's first write alone)."""
        self.pose_future = bb.post_pose(parent="local", child="vehicle", pose=self.pose(), stamp=self.pose_stamp, hold=None)
        self.post_futures = [bb.post(lm, stamp=self.pose_stamp, geometry=Point(x=float(self.seq), y=float(self.kill)))
                             for lm in self.landmarks()]

    async def settle(self) -> None:
        """Wait for every write's outcome; record what was acknowledged (a message is acknowledged whole)."""
        (pose,) = await asyncio.gather(self.pose_future, return_exceptions=True)
        posts = await asyncio.gather(*self.post_futures, return_exceptions=True)
        for o in (pose, *posts):
            assert not isinstance(o, BaseException) or isinstance(o, NodeUnavailableError), repr(o)
        self.pose_acked = not isinstance(pose, BaseException)
        failed = [isinstance(o, BaseException) for o in posts]
        assert all(failed) or not any(failed), f"one message, acknowledged in part: {posts}"
        self.posts_acked = not any(failed)


async def _wait_file(path: str, timeout: float) -> None:
    """Return once `path` exists; TimeoutError after `timeout` [s] wall."""
    deadline = time.monotonic() + timeout
    while not os.path.exists(path):
        if time.monotonic() > deadline:
            raise TimeoutError(f"{path} did not appear within {timeout} s")
        await asyncio.sleep(0.002)


async def test_hundred_sigkills_at_random_points_of_a_write_stream(tmp_path):
    rng = np.random.default_rng(20240601)
    db = str(tmp_path / "bb.sqlite")
    hold = str(tmp_path / "hold")
    ep = f"tcp/127.0.0.1:{free_port()}"
    ns = f"kill{os.getpid()}"
    zygote = Zygote()
    loop = asyncio.get_running_loop()
    # The client listens; each node connects to it (a restarted node is back at once).
    bb = BlackboardClient(NetworkConfig(namespace=ns, listen=(ep,)), source="stream", timeout=10.0, connect_timeout=30.0,
                          reconnect=False)
    opening = asyncio.ensure_future(bb.open())
    held_kills = 0
    try:
        node = await loop.run_in_executor(None, lambda: zygote.ask(cmd="start", ns=ns, connect=ep, db=db, hold=hold))
        await opening
        stored_ids: set[str] = set()  # every token found after a restart (acknowledged, or journaled and held)
        acked_ids: set[str] = set()
        last_acked_pose: tuple[float, Pose2D] | None = None
        pose_stamp = 0.0
        for kill in range(KILLS):
            holding = kill % HOLD_EVERY == 0 or rng.random() < HOLD_RANDOM
            target = int(rng.integers(0, 24))  # batches acknowledged before the kill
            batches: list[Batch] = []
            acked = 0
            armed = False
            while True:
                while len(batches) - acked < WINDOW:
                    pose_stamp = round(pose_stamp + 0.01, 2)
                    b = Batch(kill=kill, seq=len(batches), size=int(rng.integers(1, 5)), pose_stamp=pose_stamp)
                    b.issue(bb)
                    batches.append(b)
                    await asyncio.sleep(0)  # the posts leave now: one message per batch
                    if armed:
                        break  # one more batch is enough to reach the hold
                if armed:
                    break
                await batches[acked].settle()
                assert batches[acked].pose_acked and batches[acked].posts_acked
                acked += 1
                if acked >= target:
                    if not holding:
                        break
                    Path(hold).touch()  # the next commit journals, then holds before acknowledging
                    armed = True
            if armed:
                await _wait_file(hold + ".held", 30.0)
                held_kills += 1
            # SIGKILL: writes in flight (or held) are never acknowledged
            await loop.run_in_executor(None, lambda: zygote.ask(cmd="kill", pid=node["pid"]))
            await bb.wait_node(alive=False, timeout=30.0)
            for b in batches:
                await b.settle()
                if b.posts_acked:
                    acked_ids.update(f.result().id for f in b.post_futures)
                if b.pose_acked:
                    last_acked_pose = (b.pose_stamp, b.pose())
            for p in (hold, hold + ".held"):
                if os.path.exists(p):
                    os.unlink(p)

            # restart on the same database and look at everything
            node = await loop.run_in_executor(None, lambda: zygote.ask(cmd="start", ns=ns, connect=ep, db=db, hold=hold))
            await bb.wait_node(alive=True, timeout=30.0)
            # this stream's posts: each message stored whole or not at all, the stored ones a prefix,
            # every acknowledged one among them, exactly as written
            mine = await bb.retrieve(Spec(type="bbt_landmark", where=(AttrPredicate(path="info.kill", op="==", value=kill),)))
            by_batch: dict[int, list] = {}
            for t in mine:
                by_batch.setdefault(t.attrs.info["seq"], []).append(t)
            # the earlier streams' tokens are all still there (nothing else writes, ids are never reused:
            # the count says so; every tenth restart, and the last, lists them)
            assert (await bb.stats()).tokens == len(stored_ids) + len(mine), f"kill {kill}: tokens lost or gained"
            now = stored_ids | {t.id for t in mine}
            if kill % 10 == 9:
                listed = {t["id"] for t in await bb.retrieve_raw(Spec(type="bbt_landmark"))}
                assert listed == now, f"kill {kill}: lost {sorted(now - listed)[:5]}, unexpected {sorted(listed - now)[:5]}"
                # the spatial index holds what the table holds
                box = Within(Polygon(points=[(-1.0, -1.0), (1e4, -1.0), (1e4, 1e4), (-1.0, 1e4)]))
                assert {t["id"] for t in await bb.retrieve_raw(Spec(type="bbt_landmark", geometry=box))} == listed
            assert not acked_ids - now, f"kill {kill}: acknowledged tokens lost, e.g. {sorted(acked_ids - now)[:5]}"
            stored_seqs = sorted(by_batch)
            assert stored_seqs == list(range(len(stored_seqs))), f"kill {kill}: stored batches {stored_seqs} are not a prefix"
            for b in batches:
                got = by_batch.get(b.seq, [])
                assert len(got) in (0, b.size), f"kill {kill}: batch {b.seq} is half there ({len(got)} of {b.size})"
                assert got or not b.posts_acked, f"kill {kill}: acknowledged batch {b.seq} lost"
                assert sorted((t.attrs for t in got), key=lambda a: a.name) == (b.landmarks() if got else [])
                assert all(t.geometry == Point(x=float(b.seq), y=float(kill)) and t.stamp == b.pose_stamp for t in got)
            stored_ids = now
            # poses: the newest acknowledged one is there exactly; the newest stored one is in the stream's
            # order (a batch's pose goes before its posts)
            assert last_acked_pose is not None
            stamp, pose = last_acked_pose
            p = await bb.lookup_pose(parent="local", child="vehicle", stamp=stamp)
            assert (p.x, p.y) == (pose.x, pose.y) and math.isclose(p.yaw, pose.yaw, abs_tol=1e-12)
            edge = (await bb.frames()).edge("local", "vehicle")
            assert edge is not None and edge.newest is not None and edge.newest >= stamp
            n = len(stored_seqs)
            if n:
                assert edge.newest in [b.pose_stamp for b in batches[n - 1 : n + 1]], f"kill {kill}: newest pose {edge.newest}"
            if armed:
                # what the held commit journaled survives although it was never acknowledged
                assert any(not b.posts_acked for b in batches if b.seq in by_batch) or edge.newest > stamp, \
                    f"kill {kill}: the held commit is gone"
        assert held_kills >= 20
        assert len(acked_ids) > 500
    finally:
        await bb.close()
        zygote.close()
