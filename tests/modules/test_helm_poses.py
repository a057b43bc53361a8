"""The HELM's moving vehicle position has no holes when the HELM falls behind its odometry.

A real blackboard node and a real HELM process; the test plays the simulator's drive interface: it
publishes the sim clock and odometry of a vehicle driving a circle. A loaded machine at a high RTF
holds a process up for tens of milliseconds, seconds of sim time, and the odometry that queued
meanwhile reaches the HELM in one burst; the test sends such a burst. Every pose period of it must
still be on the blackboard: a PILOT propagates a delayed perception fix through this history, and a
hole there, interpolated straight across a curve, bends the fix (issue 15's campus tour failed by
truth that way).
"""

from __future__ import annotations

import asyncio
import math
import os
import sys

import pytest

from blackboard import BlackboardClient, NetworkConfig
from blackboard.testing import start_node
from runtime import Link
from tests._odometry import CircleDrive, circle_odometry
from tests.modules._procs import spawn, stop

pytestmark = pytest.mark.e2e


async def test_odometry_that_queued_while_the_helm_was_held_up_is_all_posted():
    ns = f"hp{os.getpid()}"
    node = start_node(namespace=ns, types=("modules.vocabulary",))
    link = Link.open(NetworkConfig(namespace=ns, connect=(node.endpoint,)))
    root = f"sidewalk/{ns}"
    helm = None
    drive = CircleDrive(link.put, f"sidewalk/{ns}/sim/odom", f"sidewalk/{ns}/sim/clock")
    try:
        drive.start()
        helm = await asyncio.to_thread(spawn, [sys.executable, "-m", "codger.helm", "--vehicle", "terregator",
                                               "--ns", ns, "--connect", node.endpoint], "SIDEWALK-READY helm")
        async with BlackboardClient(node.client_net(), source="test-pilot") as bb:

            async def newest() -> float:
                info = await bb.frames()
                edge = info.edge("local", "vehicle")
                return -math.inf if edge is None or edge.newest is None else edge.newest

            async def until_posted(stamp: float) -> None:
                while await newest() < stamp - 1e-9:
                    pass

            await asyncio.wait_for(until_posted(circle_odometry(drive.k).stamp), 30.0)
            # the burst: 3 s sim of odometry at once, as a held-up HELM receives it; then the simulator goes on
            burst_from, last = await drive.burst(60)
            await asyncio.wait_for(until_posted(circle_odometry(last).stamp), 30.0)
            worst_xy = worst_yaw = 0.0
            for j in range(burst_from, last + 1):
                want = circle_odometry(j)
                got = await bb.lookup_pose(parent="local", child="vehicle", stamp=want.stamp)
                worst_xy = max(worst_xy, math.hypot(got.x - want.x, got.y - want.y))
                worst_yaw = max(worst_yaw, abs(math.remainder(got.yaw - want.yaw, 2 * math.pi)))
            # posted every 0.1 s [sim]: interpolating a 2 m circle across one period is off by 0.6 mm;
            # across a hole of a second, by 6 cm
            assert worst_xy < 0.002, f"local←vehicle strays {worst_xy:.4f} m from the odometry in the burst"
            assert worst_yaw < 1e-3, worst_yaw
    finally:
        await drive.halt()
        code = stop(helm) if helm is not None else 0
        link.close()
        node.stop()
    assert code == 0
