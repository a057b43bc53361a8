"""The integrated controller's core: immediate vs queued, priorities, ramps, nudges, dead reckoning a recorded path."""

from __future__ import annotations

import math

import pytest

from modules.helm.tracker import tracker_config_for
from wire.drive import Odometry

from eddie.controller import ControllerConfig, IntegratedController
from eddie.messages.controller import DeadReckon, Nudge, PathCommand, Release, SpeedLimit, Stop


def _ctl(vehicle: str = "navlab") -> IntegratedController:
    return IntegratedController(ControllerConfig(tracker=tracker_config_for(vehicle), control_hz=10.0, nudge_tau_s=1.0))


def _od(t: float, x: float, y: float = 0.0, yaw: float = 0.0, v: float = 0.0, dist: float | None = None) -> Odometry:
    return Odometry(stamp=t, x=x, y=y, yaw=yaw, v=v, omega=0.0, distance=x if dist is None else dist)


def test_immediate_replaces_and_queued_appends():
    c = _ctl()
    c.odometry(_od(0.0, 0.0))
    a = PathCommand(client="vision", points=((0, 0), (10, 0)), speed=1.0)
    assert c.command(a, 0.0).accepted
    assert c.command(PathCommand(client="vision", mode="queued", points=((10, 0), (20, 5)), speed=1.0), 0.1).accepted
    assert c.path_message(0.1).path == ((0, 0), (10, 0), (20, 5))
    assert c.command(PathCommand(client="vision", points=((0, 1), (5, 1)), speed=1.0), 0.2).accepted
    assert c.path_message(0.2).path == ((0, 1), (5, 1))
    kinds = [e.kind for e in c.take_events()]
    assert kinds == ["immediate_tracking", "queued_tracking", "immediate_tracking"]


def test_a_lower_priority_client_is_refused_while_a_higher_one_holds_control():
    c = _ctl()
    c.odometry(_od(0.0, 0.0))
    line = ((0.0, 0.0), (10.0, 0.0))
    assert c.command(PathCommand(client="vision", priority=1, points=line), 0.0).accepted
    assert c.command(PathCommand(client="obstacles", priority=5, points=line), 0.1).accepted
    ack = c.command(PathCommand(client="vision", priority=1, points=line), 0.2)
    assert not ack.accepted and ack.holder == "obstacles" and "priority 5" in ack.reason
    assert not c.command(Release(client="vision"), 0.3).accepted
    assert c.command(Release(client="obstacles"), 0.4).accepted
    assert c.command(PathCommand(client="vision", priority=1, points=line), 0.5).accepted
    assert c.state(0.5).client == "vision"
    assert c.command(Stop(client="bumper", priority=0, reason="soft bumper"), 0.6).accepted  # anyone may stop
    assert c.state(0.6).mode == "stopped" and c.path is None
    assert any(e.kind == "refused" and e.client == "vision" for e in c.take_events())


def test_a_path_refused_for_its_priority_is_shown_as_offered_until_a_path_is_taken():
    c = _ctl()
    c.odometry(_od(0.0, 0.0))
    assert c.command(PathCommand(client="road_following", priority=2, points=((0.0, 0.0), (10.0, 0.0))), 0.0).accepted
    assert c.command(Stop(client="obstacle_stop", priority=10, reason="obstacle 8 m ahead"), 0.1).accepted
    assert c.command(SpeedLimit(client="obstacle_stop", priority=10, speed=0.0), 0.1).accepted
    assert c.path_message(0.1).offered == ()
    swerve = ((0.0, 0.0), (5.0, 1.5), (10.0, 1.5))
    assert not c.command(PathCommand(client="road_following", priority=2, points=swerve), 0.2).accepted
    assert c.path_changed
    msg = c.path_message(0.2)
    assert msg.path == () and msg.offered == swerve and msg.offered_client == "road_following"
    assert c.command(SpeedLimit(client="obstacle_stop", priority=10, speed=None), 0.3).accepted
    assert c.command(Release(client="obstacle_stop"), 0.3).accepted
    assert c.command(PathCommand(client="road_following", priority=2, points=swerve), 0.4).accepted
    msg = c.path_message(0.4)
    assert msg.path == swerve and msg.offered == () and msg.offered_client == ""


def test_speed_ramps_up_and_down_within_the_limits():
    c = _ctl("navlab")
    tr = c.cfg.tracker
    c.odometry(_od(0.0, 0.0))
    c.command(PathCommand(client="v", points=((0, 0), (200, 0)), speed=5.0), 0.0)
    speeds = []
    for i in range(1, 80):
        speeds.append(c.tick(i * 0.1).speed)
    assert max(speeds) > 4.0
    rises = [b - a for a, b in zip(speeds, speeds[1:])]
    assert max(rises) <= tr.max_accel * 0.1 + 1e-9
    c.command(PathCommand(client="v", points=((0, 0), (200, 0)), speed=1.0), 8.0)
    slow = [c.tick(7.9 + i * 0.1).speed for i in range(1, 40)]
    drops = [a - b for a, b in zip([speeds[-1]] + slow, slow)]
    assert max(drops) <= tr.max_decel * 0.1 + 1e-9 and slow[-1] == pytest.approx(1.0)
    c.command(SpeedLimit(client="v", speed=0.5), 12.0)
    capped = [c.tick(11.8 + i * 0.1).speed for i in range(1, 30)]
    assert capped[-1] == pytest.approx(0.5) and capped[0] > 0.5  # the cap too is reached smoothly


def test_nudges_from_several_sources_add_up_and_decay():
    c = _ctl("navlab")
    c.odometry(_od(0.0, 0.0))
    c.command(PathCommand(client="v", points=((0, 0), (200, 0)), speed=2.0), 0.0)
    for i in range(1, 60):
        c.tick(i * 0.1)
    base = c.tick(6.0)
    c.command(Nudge(source="joystick", dv=-0.5, dk=0.02), 6.0)
    c.command(Nudge(source="bumper", dv=-0.3), 6.0)
    n = c.tick(6.0)
    assert n.speed == pytest.approx(base.speed - 0.8, abs=1e-6)
    assert n.curvature == pytest.approx(base.curvature + 0.02, abs=1e-6)
    later = c.tick(6.0 + 1.0)  # one time constant: e^-1 of the offsets remain
    assert later.speed == pytest.approx(base.speed - 0.8 * math.exp(-1.0), abs=0.05)
    gone = c.tick(6.0 + 20.0)
    assert gone.speed == pytest.approx(base.speed, abs=1e-3) and not c.nudge.active


def test_dead_reckoning_follows_a_stretch_of_the_recorded_path():
    c = _ctl("terregator")
    for i in range(0, 101):  # drive a quarter circle of radius 5 m (recorded as it goes)
        th = i / 100 * math.pi / 2
        c.odometry(_od(i * 0.1, 5 * math.sin(th), 5 - 5 * math.cos(th), th, dist=5 * th))
    ack = c.command(DeadReckon(client="map", odometer_from=5 * math.pi / 2, odometer_to=0.0, speed=0.5), 10.0)
    assert ack.accepted and c.state(10.0).mode == "dead_reckon"
    path = c.path_message(10.0).path
    assert len(path) > 20
    assert math.dist(path[0], (5.0, 5.0)) < 0.3 and math.dist(path[-1], (0.0, 0.0)) < 0.3
    refused = c.command(DeadReckon(client="map", odometer_from=100.0, odometer_to=120.0), 10.1)
    assert not refused.accepted and "no recorded path" in refused.reason


def test_drive_commands_carry_the_sensed_at_of_the_path_they_track():
    c = _ctl()
    c.odometry(_od(0.0, 0.0))
    assert c.tick(0.0).sensed_at is None
    c.command(PathCommand(client="vision", points=((0, 0), (10, 0)), speed=1.0, sensed_at=0.4), 0.5)
    assert c.tick(0.6).sensed_at == 0.4
    c.command(DeadReckon(client="map", points=((0, 0), (10, 0))), 0.7)
    assert c.tick(0.8).sensed_at is None


def test_a_set_speed_trigger_caps_every_client_and_never_lifts_an_obstacle_hold():
    c = _ctl()
    t = 0.0
    c.odometry(_od(t, 0.0))
    assert c.command(PathCommand(client="vision", points=((0, 0), (200, 0)), speed=3.0), t).accepted
    c.set_mission_speed(0.5, t, "slow before an intersection")
    for _ in range(100):  # 10 s: the ramp has long reached any cap
        t += 0.1
        cmd = c.tick(t)
        c.odometry(_od(t, cmd.speed * t, v=cmd.speed))
    assert cmd.speed == pytest.approx(0.5)
    assert c.state(t).mission_speed == 0.5
    # an obstacle hold (a client's cap of 0) stays when the next trigger raises the mission speed
    assert c.command(SpeedLimit(client="obstacles", priority=10, speed=0.0), t).accepted
    c.set_mission_speed(3.0, t, "cruise after the intersection")
    for _ in range(50):
        t += 0.1
        cmd = c.tick(t)
    assert cmd.speed == 0.0
    assert [e.kind for e in c.take_events()].count("set_speed") == 2


def test_while_tracking_each_drive_command_carries_the_next_seconds_along_the_path():
    c = _ctl("terregator")
    c.odometry(_od(0.0, 0.0))
    c.command(PathCommand(client="v", points=((0, 0), (20, 0)), speed=0.8), 0.0)
    assert not c.tick(0.0).then  # the ramp starts: nothing moves yet
    cmd = c.tick(0.1)
    assert cmd.speed > 0.0 and cmd.duration == pytest.approx(0.1) and cmd.then
    assert sum(s.duration for s in cmd.then) == pytest.approx(c.cfg.max_hold_s)
    assert [s.speed for s in cmd.then] == sorted(s.speed for s in cmd.then)  # the predicted ramp up to speed
    # a nudge is summed into the command in hand alone; a stop carries nothing
    c.command(Nudge(source="joystick", dk=0.05), 0.2)
    assert not c.tick(0.2).then
    c.command(Stop(client="bumper", reason="test"), 0.3)
    stopped = c.tick(0.3)
    assert stopped.speed == 0.0 and not stopped.then


def test_a_controller_held_up_leaves_the_vehicle_where_one_on_time_would_have_it():
    """A new path 0.6 m to the right arrives; the controller sends one command and is then held up for 2 s sim
    (two loaded cores at RTF 50): the steps it sent behind the command drive the simulated Terregator
    (its own lags and limits) within a few centimetres and degrees of where a controller ticking every
    period gets it. One arc held alone (the command without its steps) turns it across the path."""
    from shapely.geometry import LineString, Point
    from vehicle_sim.simulator import SimConfig, Simulator
    from vehicle_sim.worldfile import load_world
    from eddie.controller.integrated_controller import ARC_OVERSHOOT_RAD

    world = load_world("campus")

    def drive(held: bool, steps: bool = True) -> tuple[float, float, float]:
        sim = Simulator(world, SimConfig(vehicle="terregator", seed=3, collisions_block=False), start=(0.0, -20.0, 0.0))
        tr = tracker_config_for("terregator").model_copy(update={"overshoot": ARC_OVERSHOOT_RAD})
        c = IntegratedController(ControllerConfig(tracker=tr, control_hz=10.0))

        def tick() -> None:
            o = sim.odom
            c.odometry(Odometry(stamp=sim.t, x=o.x, y=o.y, yaw=o.yaw, v=sim.state.v, omega=0.0, distance=0.0))
            cmd = c.tick(sim.t)
            sim.submit(cmd if steps else cmd.model_copy(update={"then": (), "duration": 2.0}))

        c.command(PathCommand(client="v", points=((0.0, 0.0), (30.0, 0.0)), speed=0.8), sim.t)
        for _ in range(30):  # up to speed on the first path
            tick()
            sim.advance(0.1)
        x0 = sim.odom.x
        new = ((x0 - 1.0, -0.6), (x0 + 20.0, -0.6))
        c.command(PathCommand(client="v", points=new, speed=0.8), sim.t)
        for k in range(20):
            if k == 0 or not held:
                tick()
            sim.advance(0.1)
        p = Point(sim.odom.x, sim.odom.y)
        return LineString(new).distance(p), sim.odom.x - x0, math.degrees(sim.odom.yaw)

    on_time, held, one_arc = drive(False), drive(True), drive(True, steps=False)
    assert held[1] > 1.5  # it kept driving all along
    assert abs(held[0] - on_time[0]) < 0.06 and abs(held[1] - on_time[1]) < 0.06 and abs(held[2] - on_time[2]) < 4.0
    assert abs(one_arc[2] - on_time[2]) > 8.0  # held alone, the arc turned the vehicle well past the on-time heading
