"""The navigator: fixes move world←local toward the truth from an off start; push vs request delivery per subscriber."""

from __future__ import annotations

import asyncio
import math
import os
import subprocess
import sys

import numpy as np

from wire.drive import TruthPose, decode
from wire.keys import SimKeys
from wire.network import NetworkConfig
from wire.ports import free_port
from wire.se2 import compose

from eddie.errors import NoSuchModule
from eddie.messages.controller import Position, PositionQuery
from eddie.messages.navigator import LineFixMessage, LocalPose, PointFixMessage, WorldFromLocal, WorldFromLocalQuery
from eddie.navigator import Navigator
from eddie.toolkit import Module
from tests.eddie._net import retry
from tests.modules._procs import spawn, stop


def test_a_line_fix_corrects_only_across_the_line_using_the_buffered_local_pose():
    nav = Navigator((2.0, 1.0, 0.0), sigma_xy=1.0)
    for i in range(11):  # the vehicle drives 1 m along local x; truth: world = local + (0, 0)
        nav.on_local(i * 0.1, i * 0.1, 0.0, 0.0)
    # true world pose now is (1.0, 0.0); the estimate is off by (2, 1). A line fix along y = 0 (taken at 0.5 s).
    w = nav.fix(LineFixMessage(stamp=0.5, x=0.0, y=0.0, angle=0.0, sigma_cross=0.05, source="lines"), now=1.0)
    est = compose(np.array([w.x, w.y, w.yaw]), np.array([1.0, 0.0, 0.0]))
    assert abs(est[1]) < 0.1  # across the line: corrected
    assert abs(est[0] - 3.0) < 0.3  # along it: unobserved, still off
    try:
        nav.fix(LineFixMessage(stamp=50.0, x=0.0, y=0.0, angle=0.0, source="late"), now=1.0)
    except Exception as exc:  # noqa: BLE001
        assert "no local pose" in str(exc) and "late" in str(exc)
    else:
        raise AssertionError("a fix outside the buffer must be refused")


def test_a_fix_is_paired_with_the_pose_the_controller_passed_through_at_its_stamp_from_a_states_trail():
    # a circle of 2 m at 1 m/s in local; world = local shifted by (2, 1); states at 0 s and 3 s only, the
    # poses between handed on as the second state's trail (a controller held up for 3 s [sim])
    def local(t: float) -> tuple[float, float, float]:
        return 2.0 * math.sin(0.5 * t), 2.0 * (1.0 - math.cos(0.5 * t)), 0.5 * t

    def world(t: float) -> np.ndarray:
        x, y, yaw = local(t)
        return np.array([x + 2.0, y + 1.0, yaw])

    def fixed(trail: bool) -> np.ndarray:
        nav = Navigator((2.3, 0.7, 0.0), sigma_xy=1.0)  # the start estimate 0.4 m off
        nav.on_local(0.0, *local(0.0))
        if trail:
            for i in range(1, 30):
                nav.on_passed(i * 0.1, *local(i * 0.1))
        nav.on_local(3.0, *local(3.0))
        w0 = world(1.5)
        w = nav.fix(PointFixMessage(stamp=1.5, x=w0[0], y=w0[1], yaw=w0[2], sigma_xy=0.02, sigma_yaw=0.002, source="lm"), now=3.0)
        return compose(np.array([w.x, w.y, w.yaw]), np.array(local(3.0)))

    assert np.hypot(*(fixed(trail=True) - world(3.0))[:2]) < 0.05
    # without the trail the pose at 1.5 s is read off the chord of 3 s of the circle
    assert np.hypot(*(fixed(trail=False) - world(3.0))[:2]) > 0.3


def test_a_fix_far_outside_the_estimates_uncertainty_is_refused_and_counted():
    nav = Navigator((10.0, 5.0, 0.3), sigma_xy=0.5, sigma_yaw=math.radians(3.0))
    for i in range(21):
        nav.on_local(i * 0.1, i * 0.1, 0.0, 0.0)
    # a fix that agrees within its uncertainty (0.3 m, 2°) is applied
    w = nav.fix(PointFixMessage(stamp=2.0, x=12.0, y=5.9, yaw=0.33, sigma_xy=0.1, sigma_yaw=0.02, source="lm"), now=2.0)
    assert nav.fixes_used == 1
    before = (w.x, w.y, w.yaw)
    # a wrong association: the right place but a heading 80° off, claimed to within 0.02 rad
    try:
        nav.fix(PointFixMessage(stamp=2.0, x=12.0, y=5.9, yaw=0.33 - 1.4, sigma_xy=0.1, sigma_yaw=0.02, source="lm"), now=2.0)
    except Exception as exc:  # noqa: BLE001
        assert "refused" in str(exc) and "Mahalanobis" in str(exc)
    else:
        raise AssertionError("a fix 1.4 rad off a 3° estimate must be refused")
    after = nav.world_from_local()
    assert nav.fixes_rejected == 1 and nav.fixes_used == 1
    assert (after.x, after.y, after.yaw) == before
    # with the gate off, the same fix drags the heading
    loose = Navigator((10.0, 5.0, 0.3), sigma_xy=0.5, sigma_yaw=math.radians(3.0), gate=None)
    loose.on_local(0.0, 0.0, 0.0, 0.0)
    w = loose.fix(PointFixMessage(stamp=0.0, x=10.0, y=5.0, yaw=0.3 - 1.4, sigma_xy=0.1, sigma_yaw=0.02, source="lm"), now=0.0)
    assert abs(w.yaw - 0.3) > 1.0


def test_an_overconfident_estimate_that_drifted_lets_consistent_fixes_in_again_but_not_a_gross_mismatch():
    # the estimate believes it is within 0.1 m, but the truth is 1.8 m to its left; the vehicle drives 1 m
    # along x between fixes (refusals from one place doubt once: tests/modules/test_fix_gate.py)
    nav = Navigator((10.0, 5.0, 0.0), sigma_xy=0.1, sigma_yaw=math.radians(0.5))
    nav.on_local(0.0, 0.0, 0.0, 0.0)
    used_at = None
    for k in range(1, 12):
        nav.on_local(float(k), float(k), 0.0, 0.0)
        truth = PointFixMessage(stamp=float(k), x=10.0 + k, y=6.8, yaw=0.0, sigma_xy=0.2, sigma_yaw=0.02, source="lm")
        try:
            w = nav.fix(truth, now=float(k))
        except Exception as exc:  # noqa: BLE001
            assert "refused" in str(exc) and f"{k} in a row" in str(exc)
            continue
        used_at = k
        break
    assert used_at is not None and used_at > 1, "the first fix is refused; refusals in a row must let it in later"
    assert abs(w.y - 6.8) < 0.5 and nav.refused_in_row == 0
    # a heading 80° off stays out however often and from wherever it comes: the doubt is capped at 10°
    nav2 = Navigator((10.0, 5.0, 0.0), sigma_xy=0.1, sigma_yaw=math.radians(0.5))
    nav2.on_local(0.0, 0.0, 0.0, 0.0)
    for k in range(1, 30):
        nav2.on_local(float(k), float(k), 0.0, 0.0)
        wrong = PointFixMessage(stamp=float(k), x=10.0 + k, y=5.0, yaw=-1.4, sigma_xy=0.1, sigma_yaw=0.02, source="lm")
        try:
            nav2.fix(wrong, now=float(k))
        except Exception:  # noqa: BLE001
            pass
    assert nav2.fixes_used == 0 and abs(nav2.world_from_local().yaw) < 1e-9
    sig = np.sqrt(np.diag(nav2.filter.cov))  # the caps, and the odometry noise of the metres since
    assert sig[0] <= 3.05 and sig[2] <= math.radians(10.5)


async def test_fixes_pull_world_from_local_to_the_truth_pushed_or_on_request():
    ns = f"nav{os.getpid()}"
    ep = f"tcp/127.0.0.1:{free_port()}"
    procs: list[subprocess.Popen] = []
    conn = ["--ns", ns, "--connect", ep]
    try:
        procs.append(spawn([sys.executable, "-m", "sidewalk", "sim", "serve", "--world", "campus", "--vehicle", "terregator",
                            "--rtf", "2", "--seed", "7", "--ns", ns, "--mode", "router", "--listen", ep], "ready sim", timeout=180))
        procs.append(spawn([sys.executable, "-m", "eddie.controller", "--vehicle", "terregator", *conn], "SIDEWALK-READY controller", timeout=180))
        async with Module("landmarks", NetworkConfig(namespace=ns, connect=(ep,))) as me:
            await me.wait_connected(10.0)
            truth: list[TruthPose] = []
            me.link.subscribe(SimKeys(ns).truth, lambda _k, p: truth.append(decode(TruthPose, p)))
            while not truth:
                await asyncio.sleep(0.05)
            t0 = truth[-1]
            off = f"{t0.x + 1.5},{t0.y - 1.0},{t0.yaw + 0.08}"
            procs.append(spawn([sys.executable, "-m", "eddie.navigator", "--start-pose", off, "--deliver", "world_from_local=push",
                                *conn], "SIDEWALK-READY navigator", timeout=180))
            procs.append(spawn([sys.executable, "-m", "eddie.navigator", "--name", "navr", "--start-pose", off,
                                "--deliver", "world_from_local=request", *conn], "SIDEWALK-READY navr", timeout=180))
            pushed: list[WorldFromLocal] = []
            pushed_r: list[WorldFromLocal] = []
            me.subscribe("navigator", "world_from_local", WorldFromLocal, pushed.append)
            me.subscribe("navr", "world_from_local", WorldFromLocal, pushed_r.append)
            pos = await retry(lambda: me.request("controller", "position", PositionQuery(), reply_type=Position))
            local = np.array([pos.x, pos.y, pos.yaw])

            def err(w: WorldFromLocal) -> float:
                est = compose(np.array([w.x, w.y, w.yaw]), local)
                return math.dist(est[:2], (truth[-1].x, truth[-1].y))

            w0 = await retry(lambda: me.request("navr", "world_from_local", WorldFromLocalQuery(), reply_type=WorldFromLocal))
            assert err(w0) > 1.5 and w0.fixes_used == 0
            tp = truth[-1]
            for _ in range(3):
                fix = PointFixMessage(stamp=pos.stamp, x=tp.x, y=tp.y, yaw=tp.yaw, sigma_xy=0.1, sigma_yaw=0.02,
                                      local=LocalPose(x=pos.x, y=pos.y, yaw=pos.yaw), source="landmarks")
                await me.send("navigator", fix)
                await me.send("navr", fix)
            async with asyncio.timeout(30):
                while not (pushed and pushed[-1].fixes_used == 3):
                    await asyncio.sleep(0.05)
                while True:
                    w = await me.request("navr", "world_from_local", WorldFromLocalQuery(), reply_type=WorldFromLocal)
                    if w.fixes_used == 3:
                        break
                    await asyncio.sleep(0.05)
            assert err(pushed[-1]) < 0.3 and err(w) < 0.3
            assert not pushed_r  # the request-only navigator pushes nothing
            try:
                await me.request("navigator", "world_from_local", WorldFromLocalQuery(), timeout=1.0)
            except NoSuchModule:
                pass
            else:
                raise AssertionError("the push-only navigator must not answer requests")
    finally:
        for p in reversed(procs):
            stop(p)
