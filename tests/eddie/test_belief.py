"""A vision module's belief on real Zenoh sessions over loopback: a frame waits for the controller's pose of its stamp."""

from __future__ import annotations

import asyncio
import os

import numpy as np

from eddie.messages.controller import ControllerState
from eddie.modules.sensing import Belief
from eddie.toolkit import Module
from tests.eddie._net import net_pair


def _state(stamp: float, x: float) -> ControllerState:
    return ControllerState(stamp=stamp, x=x, y=0.0, yaw=0.0, v=3.0, curvature=0.0)


async def _pair(tag: str) -> tuple[Module, Module, Belief]:
    listen, connect, _ = net_pair(f"bel{tag}{os.getpid()}")
    ctrl = await Module("controller", listen).__aenter__()
    vision = await Module("road_following", connect).__aenter__()
    await vision.wait_connected(10.0)
    belief = Belief(vision, (0.0, 0.0, 0.0))
    # the subscription propagates: the controller repeats its first state until the belief holds it
    first = asyncio.ensure_future(belief.reached(10.0, timeout_s=30.0))
    while not first.done():
        ctrl.publish("state", _state(10.0, 30.0))
        await asyncio.wait({first}, timeout=0.05)
    assert first.result() is True
    return ctrl, vision, belief


async def _close(*ms: Module) -> None:
    for m in ms:
        await m.__aexit__(None, None, None)


async def test_a_frame_newer_than_the_newest_pose_waits_for_the_pose_of_its_stamp():
    ctrl, vision, belief = await _pair("wait")
    try:
        # a capture at 12 s while the controller's stream is still at 10 s (30 m): the newest pose is 6 m off
        assert belief.local_at(12.0)[0] == 30.0
        waiting = asyncio.ensure_future(belief.reached(12.0, timeout_s=30.0))
        await asyncio.wait({waiting}, timeout=0.2)
        assert not waiting.done(), "no pose at or past 12 s yet: the frame must wait"
        ctrl.publish("state", _state(11.0, 33.0))
        ctrl.publish("state", _state(13.0, 39.0))
        assert await waiting is True
        np.testing.assert_allclose(belief.local_at(12.0), [36.0, 0.0, 0.0])  # between 11 s and 13 s, not the newest
        assert belief._waiting == []
    finally:
        await _close(vision, ctrl)


async def test_a_controller_that_stays_silent_lets_the_frame_go_after_the_timeout():
    ctrl, vision, belief = await _pair("silent")
    try:
        assert await belief.reached(9.5, timeout_s=0.01) is True  # an older stamp: at once
        assert await belief.reached(20.0, timeout_s=0.3) is False
        assert belief._waiting == []
    finally:
        await _close(vision, ctrl)


async def test_in_lock_step_a_frame_does_not_wait(monkeypatch):
    ctrl, vision, belief = await _pair("lockstep")
    try:
        monkeypatch.setenv("SIDEWALK_LOCKSTEP", "1")
        assert await belief.reached(20.0, timeout_s=30.0) is True
    finally:
        await _close(vision, ctrl)


async def test_a_frame_is_paired_with_a_pose_from_the_trail_a_held_up_controller_hands_on():
    ctrl, vision, belief = await _pair("trail")
    try:
        # the vehicle turns at 1 rad/s between 10 s and 12 s; the controller, held up, publishes 12 s with the
        # periods it missed as the state's trail
        turn = [(10.0 + 0.1 * i, 30.0 + np.sin(0.1 * i), 1.0 - np.cos(0.1 * i), 0.1 * i) for i in range(1, 20)]
        got = asyncio.ensure_future(belief.reached(12.0, timeout_s=30.0))
        ctrl.publish("state", ControllerState(stamp=12.0, x=30.0 + np.sin(2.0), y=1.0 - np.cos(2.0), yaw=2.0, v=1.0,
                                              curvature=1.0, trail=tuple(turn)))
        assert await got is True
        np.testing.assert_allclose(belief.local_at(11.0), [30.0 + np.sin(1.0), 1.0 - np.cos(1.0), 1.0], atol=1e-9)
    finally:
        await _close(vision, ctrl)
