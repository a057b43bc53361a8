"""The PERCEPTION process end to end: a real blackboard node (own process), a real simulator node
(capture queryable), the PERCEPTION module, all on loopback Zenoh; the test plays PILOT and HELM
(posts poses and driving units) and waits for the results written back."""

from __future__ import annotations

import asyncio
import io
import math

import numpy as np
import pytest
from shapely.geometry import Point, Polygon

from blackboard import AttrPredicate, BlackboardClient, NetworkConfig, Polygon as BbPolygon, Pose2D, Spec
from blackboard.testing import start_node
from wire.network import NetworkConfig
from wire.ports import free_port
from modules.perception.module import PerceptionConfig, PerceptionModule
from modules.runtime import run_module_async
from modules.vocabulary import DrivingUnitDescription, LineFix, PerceptionResult, PointFix
from sidewalk.cli._perception import _map_object
from vehicle_sim.node import NodeConfig, SimNode
from vehicle_sim.worldfile import load_world

pytestmark = pytest.mark.timeout(120)

NS = "perctest"


def _objects_near(world, pose, reach=20.0):
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    fan = Polygon([(x + c * a - s * b, y + s * a + c * b) for a, b in [(0, -1), (reach, -reach), (reach, reach), (0, 1)]])
    out = []
    for o in world.objects:
        g = Polygon(o.polygon) if o.polygon is not None else Point(o.center).buffer(o.radius)
        if g.intersects(fan):
            out.append(_map_object(o))
    return tuple(out)


def _unit(uid: str, pose, objects, region=None) -> DrivingUnitDescription:
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    if region is None:
        region = tuple((x + c * a - s * b, y + s * a + c * b) for a, b in [(5, -1.5), (10, -1.5), (10, 1.5), (5, 1.5)])
    centre = ((x + 5 * c, y + 5 * s), (x + 10 * c, y + 10 * s))
    return DrivingUnitDescription(unit_id=uid, segment_id="seg0", unit_index=0, mode="follow-road", region=region,
                                  centreline=centre, objects=objects, error_allowance_m=0.5)


@pytest.fixture(scope="module")
def world():
    return load_world("campus")


async def test_perception_answers_driving_units_over_the_blackboard(world) -> None:
    node = await asyncio.to_thread(start_node, namespace=NS, types=("modules.vocabulary",))
    sim_ep = f"tcp/127.0.0.1:{free_port()}"
    sim = SimNode(world, NodeConfig(vehicle="terregator", rtf=1.0, seed=3),
                  NetworkConfig(namespace=NS, listen=(sim_ep,)))
    await asyncio.to_thread(sim.start)
    net = NetworkConfig(namespace=NS, connect=(node.endpoint, sim_ep))
    bb = await BlackboardClient.connect(net, source="test")
    task = None
    try:
        start = (world.start.x, world.start.y, world.start.yaw)
        # The test is the HELM and the position estimator: the vehicle stands still at its start pose.
        await bb.post_pose(parent="world", child="local", pose=Pose2D(), stamp=0.0, hold=None)
        await bb.post_pose(parent="local", child="vehicle", pose=Pose2D(x=start[0], y=start[1], yaw=start[2]), stamp=0.0, hold=None)
        task = asyncio.create_task(run_module_async(
            "perception", lambda rt: PerceptionModule(rt, PerceptionConfig(vehicle="terregator", max_wait_s=1.0)).run(),
            net, install_signals=False, stdout=io.StringIO(), heartbeat_period=0.2))
        good = _unit("seg0.u0", start, _objects_near(world, start))
        await bb.post(good, frame="world", geometry=BbPolygon(points=good.region), stamp=0.0)
        # a unit whose map is badly wrong (its sidewalk 15 m to the side, on the lawn): the unit says why
        shifted = tuple(o.model_copy(update={"polygon": tuple((x + 15.0, y) for x, y in o.polygon)}) if o.kind == "sidewalk" else o
                        for o in _objects_near(world, start))
        bad = _unit("seg0.u1", start, shifted).model_copy(update={"unit_index": 1})
        await bb.post(bad, frame="world", geometry=BbPolygon(points=bad.region), stamp=0.0)

        async def answered(uid: str) -> DrivingUnitDescription:
            spec = Spec(type="driving_unit", where=(AttrPredicate(path="unit_id", op="==", value=uid),
                                                    AttrPredicate(path="status", op="!=", value="pending")))
            return (await bb.wait(spec, timeout=60.0)).attrs

        u0 = await answered("seg0.u0")
        assert u0.status == "perceived", u0.result
        res = u0.result
        assert res is not None and res.sensor == "colour"  # only flat objects predicted: colour alone
        assert any(d.kind == "sidewalk" for d in res.detected)
        assert res.navigable_region is not None
        nav = Polygon(res.navigable_region)
        assert nav.contains(Point(start[0], start[1] + 6.0))  # the sidewalk ahead is navigable
        assert res.fix is not None
        if isinstance(res.fix, PointFix):
            assert math.hypot(res.fix.pose.x - start[0], res.fix.pose.y - start[1]) < 0.3
        else:
            assert isinstance(res.fix, LineFix)
            n = np.array([-math.sin(res.fix.direction), math.cos(res.fix.direction)])
            assert abs(np.dot(np.array(res.fix.point) - np.array(start[:2]), n)) < 0.3
        # the same result was posted on its own for whoever monitors perception results
        own = await bb.retrieve(Spec(type="perception_result", where=(AttrPredicate(path="unit_id", op="==", value="seg0.u0"),)))
        assert len(own) == 1 and isinstance(own[0].attrs, PerceptionResult)

        u1 = await answered("seg0.u1")
        assert u1.status == "failed"
        assert "no predicted path object found" in u1.result.failure_reason
    finally:
        if task is not None:
            task.cancel()
            try:
                await task
            except asyncio.CancelledError:
                pass
        await bb.close()
        await asyncio.to_thread(sim.stop)
        await asyncio.to_thread(node.stop)
