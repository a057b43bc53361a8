"""The controller's `state` stream has no holes when the controller falls behind its odometry.

A real controller process; the test plays the simulator (sim clock and the odometry of a vehicle
driving a circle) and listens to the stream. A loaded machine at a high RTF holds a process up for
seconds of sim time, and the odometry that queued meanwhile reaches it in one burst; the test sends
such a burst. The vision modules and the navigator pair each capture with the controller's pose at
its stamp, interpolated in the poses of this stream: every control period of the burst must be
there, in a state or in the `trail` of odometry the next state carries.
"""

from __future__ import annotations

import asyncio
import math
import os
import sys

from wire.keys import SimKeys
from wire.network import NetworkConfig
from wire.ports import free_port

from eddie.messages.controller import ControllerState
from eddie.toolkit import Module
from tests._odometry import STEP, CircleDrive, circle_odometry
from tests.modules._procs import spawn, stop


async def test_odometry_that_queued_while_the_controller_was_held_up_is_all_in_its_state_stream():
    ns = f"css{os.getpid()}"
    ep = f"tcp/127.0.0.1:{free_port()}"
    keys = SimKeys(ns)
    ctl = None
    async with Module("tester", NetworkConfig(namespace=ns, listen=(ep,))) as me:
        drive = CircleDrive(me.link.put, keys.odom, keys.clock)
        states: list[ControllerState] = []
        seen = asyncio.Event()
        want_stamp = [math.inf]

        def on_state(s: ControllerState) -> None:
            states.append(s)
            if s.stamp >= want_stamp[0] - 1e-9:
                seen.set()

        me.subscribe("controller", "state", ControllerState, on_state)
        try:
            drive.start()
            ctl = await asyncio.to_thread(spawn, [sys.executable, "-m", "eddie.controller", "--vehicle", "terregator",
                                                  "--ns", ns, "--connect", ep], "SIDEWALK-READY controller")
            want_stamp[0] = circle_odometry(drive.k).stamp
            await asyncio.wait_for(seen.wait(), 30.0)
            # the burst: 3 s sim of odometry at once, as a held-up controller receives it; then the simulator goes on
            burst_from, last = await drive.burst(60)
            seen.clear()
            want_stamp[0] = circle_odometry(last).stamp
            await asyncio.wait_for(seen.wait(), 30.0)
            t0, t1 = circle_odometry(burst_from).stamp, circle_odometry(last).stamp
            poses = [(s.stamp, s.x, s.y) for s in states] + [(t, x, y) for s in states for t, x, y, _ in s.trail]
            stamps = sorted({p[0] for p in poses if t0 - 0.1 <= p[0] <= t1})
            gaps = [b - a for a, b in zip(stamps, stamps[1:])]
            # a pose per control period (10 Hz sim): no gap longer than a period and an odometry step
            assert stamps and max(gaps) <= 0.1 + STEP + 1e-6, f"holes in the controller's poses during the burst: {max(gaps):.2f} s"
            assert any(s.trail for s in states)
            for t, x, y in (p for p in poses if t0 - 0.1 <= p[0] <= t1):  # each pose is the odometry of its stamp
                want = circle_odometry(round(t / STEP))
                assert abs(want.stamp - t) < 1e-6 and math.hypot(x - want.x, y - want.y) < 1e-6
        finally:
            await drive.halt()
            code = stop(ctl) if ctl is not None else 0
    assert code == 0
