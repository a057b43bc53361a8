"""PILOT + HELM over real Zenoh: blackboard node, simulator, PILOT and HELM each in its own OS process.

The test plays the MAP NAVIGATOR: it posts one route segment (the dorm walk on the campus map) and
waits for the PILOT's segment result; it reads the simulator's ground truth to check the vehicle
really drove there. PERCEPTION is not running: the PILOT drives by dead reckoning on the map.
"""

from __future__ import annotations

import asyncio
import json
import math
import os
import signal
import subprocess
import sys

import pytest

from blackboard import AttrPredicate, BlackboardClient, NetworkConfig, Spec
from blackboard.testing import start_node
from runtime import Link
from modules.vocabulary import (
    DrivingConstraints, ExitCondition, MapObject, PerceptionResult, PointFix, Pose, RouteSegmentDescription,
)
from wire.drive import DriveCommand, TruthPose, decode
from tests.modules._procs import ROOT, spawn, stop

pytestmark = pytest.mark.e2e



def _spawn_sim_and_helm(procs: list[subprocess.Popen], conn: list[str], seed: int) -> None:
    """Start the simulator (campus, Terregator, RTF 4), then the HELM, each appended to `procs` once up."""
    procs.append(spawn([sys.executable, "-m", "sidewalk", "sim", "serve", "--world", "campus", "--vehicle", "terregator",
                        "--rtf", "4", "--seed", str(seed), *conn], "ready sim"))
    procs.append(spawn([sys.executable, "-m", "codger.helm", "--vehicle", "terregator", *conn], "SIDEWALK-READY helm"))


def _dorm_segment() -> RouteSegmentDescription:
    fc = json.loads((ROOT / "worlds" / "campus.map.geojson").read_text())
    feats = {f["properties"]["id"]: f for f in fc["features"]}
    sw = feats["sw_dorm"]
    ring = tuple(tuple(c) for c in sw["geometry"]["coordinates"][0][:-1])
    obj = MapObject(object_id="sw_dorm", kind="sidewalk", role="path", cost=1.0, polygon=ring)
    a, b = (0.3, -28.25), (0.22, -12.0)
    return RouteSegmentDescription(
        segment_id="test-seg-0", plan_id="test-plan", segment_index=0, mode="follow-road",
        path_object_ids=("sw_dorm",), centreline=(a, b), width_m=2.5, length_m=math.dist(a, b),
        exit=ExitCondition(point=b, gate=((-1.0, -12.0), (1.5, -12.0)), heading=math.pi / 2, radius_m=1.0),
        constraints=DrivingConstraints(keep="right", speed_limit=0.8, stop_at_exit=True),
        objects=(obj,),
    )


async def test_pilot_and_helm_drive_a_segment_by_dead_reckoning():
    ns = f"ph{os.getpid()}"
    node = start_node(namespace=ns, types=("modules.vocabulary",))
    procs: list[subprocess.Popen] = []
    net = node.client_net()
    link = None
    try:
        conn = ["--ns", ns, "--connect", node.endpoint]
        _spawn_sim_and_helm(procs, conn, 3)
        procs.append(spawn([sys.executable, "-m", "codger.pilot", "--vehicle", "terregator", "--perception", "off",
                             "--start-pose", f"0,-28,{math.pi / 2}", *conn], "SIDEWALK-READY pilot"))
        truth: list[TruthPose] = []
        at_rest = asyncio.Event()
        done = asyncio.Event()

        def on_truth(_key: str, payload: bytes) -> None:  # runs on the loop (Link hands samples over)
            tp = decode(TruthPose, payload)
            truth.append(tp)
            if done.is_set() and abs(tp.v) < 0.02:
                at_rest.set()

        link = Link.open(NetworkConfig(namespace=ns, connect=(node.endpoint,)))
        link.subscribe(f"sidewalk/{ns}/sim/truth", on_truth)
        async with BlackboardClient(net, source="test-map-navigator") as bb:
            seg = _dorm_segment()
            await bb.post(seg, frame="world", stamp=0.0)
            res = await bb.wait(
                Spec(type="segment_result", where=(AttrPredicate(path="segment_id", op="==", value="test-seg-0"),)),
                timeout=120.0,
            )
            done.set()
            assert res.attrs.success, res.attrs.reason
            assert "0/" in res.attrs.reason and "units perceived" in res.attrs.reason  # dead reckoning, reported
            # The vehicle really got there (truth, not the estimate).
            last = truth[-1]
            assert math.dist((last.x, last.y), (0.0, -12.0)) < 1.6
            units = await bb.retrieve(Spec(type="driving_unit", where=(AttrPredicate(path="segment_id", op="==", value="test-seg-0"),)))
            assert len(units) >= 2
            plans = await bb.retrieve(Spec(type="local_path_plan"))
            assert len(plans) >= 2 and all(p.attrs.frame == "local" for p in plans)
            # The moving vehicle position keeps up with the vehicle: the newest local←vehicle pose is
            # never more than ~0.1 s (one 10 Hz period, plus transport) behind the simulator's truth.
            lags = []
            for _ in range(10):
                info = await bb.frames()
                edge = info.edge("local", "vehicle")
                assert edge is not None and edge.newest is not None
                lags.append(truth[-1].stamp - edge.newest)
            assert min(lags) <= 0.2, lags
            t_end = truth[-1].stamp
            p1 = await bb.lookup_pose(parent="local", child="vehicle", stamp=t_end - 1.0)
            assert math.isfinite(p1.x)
            wl = await bb.lookup_pose(parent="world", child="local")
            assert abs(wl.x) < 0.5 and abs(wl.y + 28.0) < 0.5
            ests = await bb.retrieve(Spec(type="position_estimate", newest=True))
            assert ests and ests[0].attrs.source == "dead-reckoning"
            # The vehicle comes to rest at the exit (stop_at_exit): truth speed drops to ~0.
            await asyncio.wait_for(at_rest.wait(), 30.0)
    finally:
        if link is not None:
            link.close()
        codes = [stop(p) for p in reversed(procs)]
        node.stop()
    assert all(c == 0 for c in codes), codes


async def test_perception_fixes_correct_a_wrong_start_pose():
    """The test plays PERCEPTION: it answers each driving unit with its region and a point fix from truth."""
    ns = f"pp{os.getpid()}"
    node = start_node(namespace=ns, types=("modules.vocabulary",))
    procs: list[subprocess.Popen] = []
    link = None
    try:
        conn = ["--ns", ns, "--connect", node.endpoint]
        _spawn_sim_and_helm(procs, conn, 5)
        # The PILOT is told a start pose 0.6 m off the truth (0, -28): only perception can correct it.
        procs.append(spawn([sys.executable, "-m", "codger.pilot", "--vehicle", "terregator", "--perception", "on",
                             "--start-pose", f"0.6,-28.3,{math.pi / 2}", *conn], "SIDEWALK-READY pilot"))
        truth: list[TruthPose] = []
        loop = asyncio.get_running_loop()
        truth_seen = asyncio.Event()

        def on_truth(_k: str, b: bytes) -> None:
            truth.append(decode(TruthPose, b))
            loop.call_soon_threadsafe(truth_seen.set)

        link = Link.open(NetworkConfig(namespace=ns, connect=(node.endpoint,)))
        link.subscribe(f"sidewalk/{ns}/sim/truth", on_truth)
        commands: list[DriveCommand] = []
        link.subscribe(f"sidewalk/{ns}/sim/cmd", lambda _k, b: commands.append(decode(DriveCommand, b)))
        # Under load the first driving unit can come before the test's truth subscription has a pose.
        await asyncio.wait_for(truth_seen.wait(), 30.0)
        async with BlackboardClient(node.client_net(), source="test-perception") as bb:
            answered: list[str] = []
            captured: set[float] = set()

            # Registered before the segment is posted, so no driving unit goes by unseen.
            units = bb.monitor(Spec(type="driving_unit", where=(AttrPredicate(path="status", op="==", value="pending"),)))
            await units.start()

            async def perceive() -> None:
                async for ev in units:
                    if ev.kind != "new":
                        continue
                    du = ev.token.attrs
                    tp = truth[-1]
                    res = PerceptionResult(
                        unit_id=du.unit_id, segment_id=du.segment_id, status="perceived", captured_at=tp.stamp,
                        sensor="colour", frame="world", navigable_region=du.region,
                        fix=PointFix(pose=Pose(x=tp.x, y=tp.y, yaw=tp.yaw),
                                     covariance=(0.05**2, 0, 0, 0, 0.05**2, 0, 0, 0, 0.01**2)),
                    )
                    # PERCEPTION's answer is a perception_result token (the PILOT reads nothing else); the unit gets only its status.
                    captured.add(tp.stamp)
                    await bb.post(res, frame="world", stamp=tp.stamp)
                    await bb.update(ev.token.id, du.model_copy(update={"status": "perceived"}), expected_version=ev.token.version)
                    answered.append(du.unit_id)

            mon_task = asyncio.ensure_future(perceive())
            await bb.post(_dorm_segment(), frame="world", stamp=0.0)
            res = await bb.wait(
                Spec(type="segment_result", where=(AttrPredicate(path="segment_id", op="==", value="test-seg-0"),)),
                timeout=120.0,
            )
            if mon_task.done():
                mon_task.result()  # the stand-in PERCEPTION failed: show why, not a bare count
            mon_task.cancel()
            assert res.attrs.success, res.attrs.reason
            assert len(answered) >= 2
            n = len(answered)
            assert f"{n}/{n} units perceived" in res.attrs.reason
            est_tok = (await bb.retrieve(Spec(type="position_estimate", newest=True)))[0]
            est = est_tok.attrs
            t = min(truth, key=lambda tp: abs(tp.stamp - est_tok.stamp))  # truth when the estimate was made
            # Corrected: the estimate is far closer to the truth than the 0.67 m start error.
            assert math.dist((est.pose.x, est.pose.y), (t.x, t.y)) < 0.3
            fixes = await bb.retrieve(Spec(type="position_estimate", where=(AttrPredicate(path="source", op="==", value="perception"),)))
            assert fixes
            # sense → act: plans and the HELM's drive commands carry the capture stamp they derive from
            plans = [t.attrs for t in await bb.retrieve(Spec(type="local_path_plan"))]
            assert any(p.sensed_at is not None for p in plans)
            assert {p.sensed_at for p in plans if p.sensed_at is not None} <= captured
            sensed = {c.sensed_at for c in commands if c.sensed_at is not None}
            assert sensed and sensed <= captured
    finally:
        if link is not None:
            link.close()
        codes = [stop(p) for p in reversed(procs)]
        node.stop()
    assert all(c == 0 for c in codes), codes


async def test_pilot_killed_mid_segment_resumes_when_restarted():
    ns = f"pk{os.getpid()}"
    node = start_node(namespace=ns, types=("modules.vocabulary",))
    procs: list[subprocess.Popen] = []
    try:
        conn = ["--ns", ns, "--connect", node.endpoint]
        pilot_args = [sys.executable, "-m", "codger.pilot", "--vehicle", "terregator", "--perception", "off",
                      "--start-pose", f"0,-28,{math.pi / 2}", *conn]
        _spawn_sim_and_helm(procs, conn, 7)
        pilot = spawn(pilot_args, "SIDEWALK-READY pilot")
        async with BlackboardClient(node.client_net(), source="test-map-navigator") as bb:
            await bb.post(_dorm_segment(), frame="world", stamp=0.0)
            await bb.wait(Spec(type="local_path_plan"), timeout=60.0)
            pilot.kill()  # SIGKILL: no goodbye
            pilot.wait(10)
            assert stop(pilot) == -signal.SIGKILL
            assert procs[1].poll() is None  # the HELM is still up
            pilot = spawn(pilot_args, "SIDEWALK-READY pilot")
            procs.append(pilot)
            res = await bb.wait(
                Spec(type="segment_result", where=(AttrPredicate(path="segment_id", op="==", value="test-seg-0"),)),
                timeout=120.0,
            )
            assert res.attrs.success, res.attrs.reason
            results = await bb.retrieve(Spec(type="segment_result"))
            assert len(results) == 1  # resumed, not reported twice
    finally:
        codes = [stop(p) for p in reversed(procs)]
        node.stop()
    assert all(c == 0 for c in codes), codes


async def test_a_segment_whose_exit_the_vehicle_already_stands_in_ends_without_a_plan():
    # The exit is judged before planning: a vehicle already within the exit radius (a fix moved its
    # estimate there) must not be sent on a manoeuvre to a goal the segment no longer needs.
    ns = f"px{os.getpid()}"
    node = start_node(namespace=ns, types=("modules.vocabulary",))
    procs: list[subprocess.Popen] = []
    try:
        conn = ["--ns", ns, "--connect", node.endpoint]
        _spawn_sim_and_helm(procs, conn, 11)
        procs.append(spawn([sys.executable, "-m", "codger.pilot", "--vehicle", "terregator", "--perception", "off",
                             "--start-pose", f"0,-28,{math.pi / 2}", *conn], "SIDEWALK-READY pilot"))
        seg = _dorm_segment()
        a, b = (0.3, -28.25), (0.25, -22.0)  # 6.3 m long; its exit (radius 6.5 m) takes in the start
        seg = seg.model_copy(update={
            "centreline": (a, b), "length_m": math.dist(a, b),
            "exit": ExitCondition(point=b, gate=((-1.0, -22.0), (1.5, -22.0)), heading=math.pi / 2, radius_m=6.5)})
        async with BlackboardClient(node.client_net(), source="test-map-navigator") as bb:
            await bb.post(seg, frame="world", stamp=0.0)
            res = await bb.wait(
                Spec(type="segment_result", where=(AttrPredicate(path="segment_id", op="==", value="test-seg-0"),)),
                timeout=60.0,
            )
            assert res.attrs.success and "exit reached" in res.attrs.reason, res.attrs.reason
            assert await bb.retrieve(Spec(type="local_path_plan")) == []
            assert await bb.retrieve(Spec(type="driving_unit"))  # the pipeline ran: it posted units before ending
    finally:
        codes = [stop(p) for p in reversed(procs)]
        node.stop()
    assert all(c == 0 for c in codes), codes
