"""Obstacle stop lets go of a hold when the driving module's newer path, refused while it held, is clear.

Issue 37: on generated layouts EDDIE's obstacle stop held the vehicle for an object beside the road that the
path it stopped on ran into (the path came from an estimate that was off); road following's newer paths were
refused while it held ("'obstacle_stop' holds control at priority 10 > 2"), and obstacle stop watched only the
path it had stopped on, so the hold never lifted and the mission failed 60 s later. The controller now shows
the refused path as `offered` on its path stream, and a hold is lifted when that path is clear. The verdict on a
path is stubbed here (an obstacle at (8, 0) [m] `local`); `obstacle_ahead` itself is tested on real frames in
`test_eddie_modules.py`.
"""

from __future__ import annotations

import numpy as np
import pytest

from eddie.messages.controller import ControllerPath, Release, SpeedLimit, Stop
from eddie.obstacle_stop import obstacle_stop_module as osm
from eddie.obstacle_stop.obstacle_stop import ObstacleReport
from runtime.clock import SimClock

OBSTACLE = np.array([8.0, 0.0])
INTO_IT = ((0.0, 0.0), (20.0, 0.0))
AROUND_IT = ((0.0, 0.0), (4.0, 0.0), (8.0, 2.5), (20.0, 2.5))


class _Endpoint:
    """What `ObstacleStop` uses of its module: the sim clock, its subscriptions, what it sends and publishes."""

    def __init__(self) -> None:
        self.clock = SimClock()
        self.streams: dict[str, object] = {}
        self.sent: list[object] = []

    def subscribe(self, _module: str, stream: str, _type: type, callback) -> None:  # noqa: ANN001
        self.streams[stream] = callback

    async def send(self, _to: str, msg: object) -> None:
        self.sent.append(msg)

    def publish(self, _stream: str, _msg: object) -> None:
        return None


class _Frame:
    stamp = 10.0


def _verdict(_frame, _cfg, *, path_local, pose_local, speed):  # noqa: ANN001, ANN202
    if path_local is None:
        return ObstacleReport(blocked=False, stamp=10.0)
    pts = np.asarray(path_local, dtype=np.float64)
    fine = np.concatenate([np.linspace(a, b, 50) for a, b in zip(pts[:-1], pts[1:])])
    near = float(np.min(np.hypot(*(fine - OBSTACLE).T)))
    return ObstacleReport(blocked=near < 1.0, distance_m=8.0 if near < 1.0 else None, stamp=10.0)


@pytest.fixture
def stop(monkeypatch) -> osm.ObstacleStop:
    monkeypatch.setattr(osm, "obstacle_ahead", _verdict)
    m = _Endpoint()
    s = osm.ObstacleStop(m)  # type: ignore[arg-type]

    async def capture() -> _Frame:
        return _Frame()

    async def at_capture(_stamp: float):  # noqa: ANN202
        pose = np.zeros(3)
        return pose, pose

    s.capture = capture  # type: ignore[method-assign]
    s.belief.at_capture = at_capture  # type: ignore[method-assign]
    m.clock.advance(10.0)
    return s


def _path(path, offered=(), client="") -> ControllerPath:  # noqa: ANN001
    return ControllerPath(stamp=10.0, path=path, client="road_following" if path else "", mode="tracking" if path else "stopped",
                          offered=offered, offered_client=client)


@pytest.mark.asyncio
async def test_a_hold_is_lifted_when_the_newer_refused_path_is_clear(stop: osm.ObstacleStop) -> None:
    m = stop.m
    m.streams["path"](_path(INTO_IT))
    assert await stop.cycle() == "stopped"
    assert any(isinstance(x, Stop) for x in m.sent) and stop.stopped
    m.streams["path"](_path(()))  # the controller dropped its path for the stop
    assert await stop.cycle() == "blocked"  # still blocked along the path it stopped on, nothing newer offered
    m.streams["path"](_path((), offered=INTO_IT, client="road_following"))
    assert await stop.cycle() == "blocked"  # the newer path runs into it too: the hold stays
    m.sent.clear()
    m.streams["path"](_path((), offered=AROUND_IT, client="road_following"))
    assert await stop.cycle() == "released for a newer path"
    assert not stop.stopped
    assert [type(x) for x in m.sent] == [SpeedLimit, Release] and m.sent[0].speed is None  # type: ignore[attr-defined]


@pytest.mark.asyncio
async def test_a_stop_at_an_object_is_not_lifted_by_a_newer_path(stop: osm.ObstacleStop) -> None:
    m = stop.m
    m.streams["path"](_path(INTO_IT))
    assert await stop.cycle() == "stopped"
    stop.holding_at = "mailbox_3"
    m.streams["path"](_path((), offered=AROUND_IT, client="road_following"))
    m.sent.clear()
    assert await stop.cycle() == "blocked"
    assert stop.stopped and m.sent == []
