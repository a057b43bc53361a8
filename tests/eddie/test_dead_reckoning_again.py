"""Road following sends the rest of its dead-reckoned path again when the controller lost it.

Issue 36's lock-step grid: EDDIE's integrated controller, killed and restarted while the AMV dead-reckoned
through an intersection, came back with no path; road following slept until the exit's gate, which the
vehicle at rest never reached, and the mission failed. Nobody holding an idle controller while a dead
reckoning is under way means the controller lost it (a restart, or a hold lifted after a stop cleared it).
"""

from __future__ import annotations

from eddie.messages.controller import ControllerState, DeadReckon
from eddie.road_following.dead_reckoning import DeadReckoning

THROUGH = ((0.0, 0.0), (10.0, 0.0), (10.0, 10.0))


def _state(x: float, y: float, client: str, mode: str) -> ControllerState:
    return ControllerState(stamp=1.0, x=x, y=y, yaw=0.0, v=0.0, curvature=0.0, client=client, mode=mode)  # type: ignore[arg-type]


def _sent() -> DeadReckoning:
    dr = DeadReckoning("road_following")
    dr.sent(DeadReckon(client="road_following", priority=2, points=THROUGH, speed=1.0))
    return dr


def test_a_restarted_controller_gets_the_rest_of_the_path_once():
    dr = _sent()
    assert dr.again(_state(3.0, 0.0, "road_following", "dead_reckon")) is None  # it drives it
    again = dr.again(_state(4.0, 0.2, "", "idle"))  # restarted: nobody holds it, it drives nothing
    assert again is not None and again.points is not None
    assert again.points[0] == (4.0, 0.0) and again.points[-2:] == ((10.0, 0.0), (10.0, 10.0))
    assert again.speed == 1.0 and again.client == "road_following" and again.priority == 2
    assert dr.again(_state(4.0, 0.2, "", "idle")) is None  # asked once; the controller's answer is awaited
    assert dr.again(_state(4.5, 0.0, "road_following", "dead_reckon")) is None  # taken
    assert dr.again(_state(6.0, 0.0, "", "stopped")) is not None  # lost again: asked again


def test_nothing_is_sent_while_another_client_holds_it_or_after_the_end_or_once_vision_resumed():
    dr = _sent()
    assert dr.again(_state(4.0, 0.0, "obstacle_stop", "stopped")) is None  # a hold: not ours to override
    assert dr.again(_state(4.0, 0.0, "", "tracking")) is None
    assert dr.again(_state(10.0, 9.8, "", "idle")) is None  # at the end: done
    assert dr.command is None
    dr = _sent()
    dr.ended()
    assert dr.again(_state(4.0, 0.0, "", "idle")) is None
