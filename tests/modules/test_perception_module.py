"""The PERCEPTION process end to end: a real blackboard node (own process), a real simulator node
(capture queryable), the PERCEPTION module, all on loopback Zenoh; the test plays PILOT and HELM
(posts poses and driving units) and waits for the results PERCEPTION posts.

Nothing here is the answer: the pose PERCEPTION is given is 1 m and 3° off the truth, and the map
objects it is told about are displaced from the world (a rigid offset, and the walk drawn wider
than it is), so the fix must come back nearer the truth than the prior and the detected region
must follow the world, not the map."""

from __future__ import annotations

import asyncio
import io
import math

import numpy as np
import pytest
from shapely.geometry import LineString, Point, Polygon

from blackboard import AttrPredicate, BlackboardClient, Polygon as BbPolygon, Pose2D, Spec
from blackboard.testing import start_node
from wire.network import NetworkConfig
from wire.ports import free_port
from codger.perception.module import PerceptionConfig, PerceptionModule
from modules.perception.predicted import world_to_vehicle
from codger.blackboard_part import BlackboardPart
from runtime import run_module_async
from modules.vocabulary import DrivingUnitDescription, LineFix, PerceptionResult, PointFix
from modules.map_navigator.mapdata import map_object
from vehicle_sim.node import NodeConfig, SimNode
from vehicle_sim.worldfile import load_world

pytestmark = pytest.mark.timeout(120)

NS = "perctest"
#: How the map is wrong: every object moved by this much [m] (world frame) …
MAP_OFFSET = (-0.35, 0.2)
#: … and the walk drawn this much wider [m] on its east side than it is.
MAP_WIDENING = 0.6
#: How the prior pose is wrong: 0.8 m east, 0.6 m back (1.0 m), 3° to the left.
PRIOR_ERROR = (0.8, -0.6, math.radians(3.0))


def _displaced(o):
    """Return the map's version of world object `o`: moved by `MAP_OFFSET`, the walk `sw_dorm` widened."""
    dx, dy = MAP_OFFSET
    m = map_object(o)
    if m.polygon is None:
        return m.model_copy(update={"center": (m.center[0] + dx, m.center[1] + dy)})
    ring = [(x + dx, y + dy) for x, y in m.polygon]
    if o.id == "sw_dorm":
        east = max(x for x, _ in o.polygon)
        ring = [(x + MAP_WIDENING if x - dx >= east - 1e-6 else x, y) for x, y in ring]
    return m.model_copy(update={"polygon": tuple(ring)})


def _objects_near(world, pose, reach=20.0):
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    fan = Polygon([(x + c * a - s * b, y + s * a + c * b) for a, b in [(0, -1), (reach, -reach), (reach, reach), (0, 1)]])
    out = []
    for o in world.objects:
        g = Polygon(o.polygon) if o.polygon is not None else Point(o.center).buffer(o.radius)
        if g.intersects(fan):
            out.append(_displaced(o))
    return tuple(out)


def _unit(uid: str, pose, objects, region=None) -> DrivingUnitDescription:
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    if region is None:
        region = tuple((x + c * a - s * b, y + s * a + c * b) for a, b in [(5, -1.5), (10, -1.5), (10, 1.5), (5, 1.5)])
    centre = ((x + 5 * c, y + 5 * s), (x + 10 * c, y + 10 * s))
    return DrivingUnitDescription(unit_id=uid, segment_id="seg0", unit_index=0, mode="follow-road", region=region,
                                  centreline=centre, objects=objects, error_allowance_m=1.2)


def _pose_used(fix, prior):
    """Return the pose PERCEPTION drew its result with: the point fix, or the prior moved onto the fix's line."""
    if isinstance(fix, PointFix):
        return (fix.pose.x, fix.pose.y, fix.pose.yaw)
    d = np.array([math.cos(fix.direction), math.sin(fix.direction)])
    p0 = np.array(fix.point)
    on = p0 + d * float(np.dot(np.array(prior[:2]) - p0, d))
    return (float(on[0]), float(on[1]), fix.yaw if fix.yaw is not None else prior[2])


def _across(poly: Polygon, ahead: float) -> tuple[float, float]:
    """Return the (right, left) vehicle-frame y [m] where the line x = `ahead` [m] leaves `poly` (vehicle frame)."""
    cut = poly.intersection(LineString([(ahead, -20.0), (ahead, 20.0)]))
    ys = np.asarray(cut.coords)[:, 1] if cut.geom_type == "LineString" else np.concatenate([np.asarray(g.coords)[:, 1] for g in cut.geoms])
    return float(ys.min()), float(ys.max())


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
        truth = (world.start.x, world.start.y, world.start.yaw)  # the simulated vehicle stands here
        prior = (truth[0] + PRIOR_ERROR[0], truth[1] + PRIOR_ERROR[1], truth[2] + PRIOR_ERROR[2])
        prior_err = math.dist(prior[:2], truth[:2])
        # The test is the HELM and the position estimator: it believes the vehicle stands at the prior.
        await bb.post_pose(parent="world", child="local", pose=Pose2D(), stamp=0.0, hold=None)
        await bb.post_pose(parent="local", child="vehicle", pose=Pose2D(x=prior[0], y=prior[1], yaw=prior[2]), stamp=0.0, hold=None)
        task = asyncio.create_task(run_module_async(
            "perception", lambda rt: PerceptionModule(rt, PerceptionConfig(vehicle="terregator", max_wait_s=1.0)).run(),
            net, parts=(BlackboardPart(),), install_signals=False, stdout=io.StringIO(), heartbeat_period=0.2))
        objects = _objects_near(world, prior)
        good = _unit("seg0.u0", prior, objects)
        await bb.post(good, frame="world", geometry=BbPolygon(points=good.region), stamp=0.0)
        # a unit whose map is badly wrong (its sidewalk 15 m to the side, on the lawn): the unit says why
        shifted = tuple(o.model_copy(update={"polygon": tuple((x + 15.0, y) for x, y in o.polygon)}) if o.kind == "sidewalk" else o
                        for o in objects)
        bad = _unit("seg0.u1", prior, shifted).model_copy(update={"unit_index": 1})
        await bb.post(bad, frame="world", geometry=BbPolygon(points=bad.region), stamp=0.0)

        async def answered(uid: str) -> tuple[DrivingUnitDescription, PerceptionResult]:
            spec = Spec(type="driving_unit", where=(AttrPredicate(path="unit_id", op="==", value=uid),
                                                    AttrPredicate(path="status", op="!=", value="pending")))
            unit = (await bb.wait(spec, timeout=60.0)).attrs
            # the result was posted once, as its own token, before the unit's status was set
            own = await bb.retrieve(Spec(type="perception_result", where=(AttrPredicate(path="unit_id", op="==", value=uid),)))
            assert len(own) == 1 and isinstance(own[0].attrs, PerceptionResult)
            assert own[0].attrs.status == unit.status
            return unit, own[0].attrs

        u0, res = await answered("seg0.u0")
        assert u0.status == "perceived", res.failure_reason
        assert res.sensor == "colour"  # only flat objects predicted: colour alone
        assert any(d.kind == "sidewalk" for d in res.detected)

        # the fix comes back nearer the truth than the prior (up to the map's own displacement)
        assert res.fix is not None
        if isinstance(res.fix, PointFix):
            fix_err = math.dist((res.fix.pose.x, res.fix.pose.y), truth[:2])
            assert fix_err < 0.6 < prior_err, (fix_err, prior_err)
        else:
            assert isinstance(res.fix, LineFix)
            n = np.array([-math.sin(res.fix.direction), math.cos(res.fix.direction)])
            fix_err = abs(float(np.dot(np.array(res.fix.point) - np.array(truth[:2]), n)))
            prior_across = abs(float(np.dot(np.array(prior[:2]) - np.array(truth[:2]), n)))
            assert fix_err < 0.5 < prior_across, (fix_err, prior_across)
        if res.fix.kind == "point" or res.fix.yaw is not None:
            yaw = res.fix.pose.yaw if isinstance(res.fix, PointFix) else res.fix.yaw
            assert abs(yaw - truth[2]) < abs(prior[2] - truth[2])

        # the navigable region follows the world: its width and its edges are the walk's, not the map's
        assert res.navigable_region is not None
        seen = Polygon(world_to_vehicle(np.asarray(res.navigable_region), _pose_used(res.fix, prior)))
        walk = Polygon(world_to_vehicle(np.asarray(world.object("sw_dorm").polygon), truth))
        mapped = next(o for o in objects if o.object_id == "sw_dorm")
        told = Polygon(world_to_vehicle(np.asarray(mapped.polygon), prior))  # what echoing the map would give
        for ahead in (5.0, 7.0):
            r_seen, l_seen = _across(seen, ahead)
            r_walk, l_walk = _across(walk, ahead)
            r_told, l_told = _across(told, ahead)
            assert abs((l_seen - r_seen) - (l_walk - r_walk)) < 0.3, (ahead, l_seen - r_seen, l_walk - r_walk)
            assert abs((l_told - r_told) - (l_walk - r_walk)) > 0.5  # the map's walk is another shape
            assert abs(r_seen - r_walk) < 0.35 and abs(l_seen - l_walk) < 0.35, (ahead, (r_seen, l_seen), (r_walk, l_walk))
            assert max(abs(r_told - r_walk), abs(l_told - l_walk)) > 0.6  # the map, drawn at the prior, is not the world

        u1, res1 = await answered("seg0.u1")
        assert u1.status == "failed"
        assert "no predicted path object found" in res1.failure_reason
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
