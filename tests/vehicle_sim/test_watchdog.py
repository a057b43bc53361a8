"""The command supervisor: immediate vs queued commands, durations, and the watchdog stopping the vehicle."""

from __future__ import annotations

import pytest

from wire.drive import MAX_DRIVE_STEPS, DriveCommand, DriveStep, decode, encode
from vehicle_sim.simulator import SimConfig, Simulator
from vehicle_sim.watchdog import STOP, CommandSupervisor
from vehicle_sim.worldfile import load_world


def cmd(speed, mode="immediate", duration=None, seq=0):
    return DriveCommand(speed=speed, mode=mode, duration=duration, seq=seq)


def test_open_ended_command_trips_without_refresh():
    sup = CommandSupervisor(timeout=0.5)
    sup.submit(cmd(1.0), t=0.0)
    assert sup.tick(0.49).command.speed == 1.0
    r = sup.tick(0.51)
    assert r.tripped and r.command == STOP
    assert not sup.tick(0.6).tripped  # trips once; stays stopped
    assert sup.tick(0.6).command == STOP


def test_refreshing_keeps_it_going():
    sup = CommandSupervisor(timeout=0.5)
    for i in range(10):
        sup.submit(cmd(1.0, seq=i), t=i * 0.4)
        assert not sup.tick(i * 0.4 + 0.39).tripped
    assert sup.tick(9 * 0.4 + 0.51).tripped


def test_queued_commands_run_back_to_back_then_stop():
    sup = CommandSupervisor(timeout=0.5)
    sup.submit(cmd(1.0, "queued", 2.0, seq=1), t=0.0)
    sup.submit(cmd(2.0, "queued", 1.0, seq=2), t=0.1)
    sup.submit(cmd(3.0, "queued", 1.0, seq=3), t=0.2)
    assert sup.tick(1.99).command.seq == 1  # timed commands are not subject to the 0.5 s refresh
    assert sup.tick(2.0).command.seq == 2
    assert sup.tick(2.99).command.seq == 2
    assert sup.tick(3.5).command.seq == 3
    r = sup.tick(4.0)
    assert r.exhausted and r.command == STOP


def test_immediate_replaces_and_clears_the_queue():
    sup = CommandSupervisor(timeout=0.5)
    sup.submit(cmd(1.0, "queued", 2.0, seq=1), t=0.0)
    sup.submit(cmd(2.0, "queued", 2.0, seq=2), t=0.0)
    sup.submit(cmd(5.0, "immediate", 1.0, seq=9), t=0.5)
    assert sup.tick(0.6).command.seq == 9 and sup.queued == 0
    assert sup.tick(1.5).exhausted


def test_queued_after_open_ended_supersedes_it():
    sup = CommandSupervisor(timeout=0.5)
    sup.submit(cmd(1.0, seq=1), t=0.0)
    sup.submit(cmd(2.0, "queued", 1.0, seq=2), t=0.2)
    assert sup.tick(0.25).command.seq == 2
    assert sup.tick(1.1).command.seq == 2
    assert sup.tick(1.2).exhausted


def test_queued_needs_a_duration():
    with pytest.raises(ValueError, match="duration"):
        DriveCommand(speed=1.0, mode="queued")


def _steps(*speeds, duration=0.5):
    return tuple(DriveStep(speed=v, curvature=0.1 * v, duration=duration) for v in speeds)


def test_steps_behind_an_immediate_command_run_in_order_then_the_vehicle_stops():
    sup = CommandSupervisor(timeout=0.5)
    sup.submit(DriveCommand(speed=1.0, duration=0.1, seq=7, sensed_at=3.0, then=_steps(2.0, 3.0)), t=10.0)
    assert sup.queued == 2
    assert sup.tick(10.05).command.speed == 1.0
    second = sup.tick(10.1).command  # the first step starts exactly where the command ends
    assert (second.speed, second.curvature, second.seq, second.sensed_at) == (2.0, 0.2, 7, 3.0)
    assert sup.tick(10.59).command.speed == 2.0
    assert sup.tick(10.6).command.speed == 3.0
    assert sup.tick(11.09).command.speed == 3.0  # timed steps are not subject to the 0.5 s refresh
    r = sup.tick(11.1)
    assert r.exhausted and r.command == STOP


def test_a_new_immediate_command_drops_the_steps_of_the_last():
    sup = CommandSupervisor(timeout=0.5)
    sup.submit(DriveCommand(speed=1.0, duration=0.1, then=_steps(2.0, 3.0, 4.0)), t=0.0)
    sup.tick(0.3)
    sup.submit(DriveCommand(speed=5.0, duration=0.1, then=_steps(6.0)), t=0.35)
    assert sup.queued == 1
    assert [sup.tick(t).command.speed for t in (0.4, 0.45, 0.9)] == [5.0, 6.0, 6.0]
    assert sup.tick(0.95).exhausted


def test_a_queued_command_brings_its_steps_behind_it():
    sup = CommandSupervisor(timeout=0.5)
    sup.submit(DriveCommand(speed=1.0, mode="queued", duration=1.0), t=0.0)
    sup.submit(DriveCommand(speed=2.0, mode="queued", duration=1.0, then=_steps(3.0)), t=0.0)
    sup.submit(DriveCommand(speed=4.0, mode="queued", duration=1.0), t=0.0)
    assert [sup.tick(t).command.speed for t in (0.5, 1.5, 2.2, 2.7)] == [1.0, 2.0, 3.0, 4.0]


def test_steps_need_a_timed_command_and_are_bounded():
    with pytest.raises(ValueError, match="timed"):
        DriveCommand(speed=1.0, then=_steps(1.0))
    with pytest.raises(ValueError, match="at most"):
        DriveCommand(speed=1.0, duration=0.1, then=_steps(*[1.0] * (MAX_DRIVE_STEPS + 1)))
    with pytest.raises(ValueError, match="greater than 0"):
        DriveStep(speed=1.0, duration=0.0)
    cmd = DriveCommand(speed=1.0, duration=0.1, then=_steps(2.0, 3.0) + (DriveStep(speed=0.0, turn_rate=0.4, duration=1.0),))
    assert decode(DriveCommand, encode(cmd)) == cmd
    assert decode(DriveCommand, encode(cmd, as_json=True)) == cmd


@pytest.mark.parametrize("vehicle, speed", [("terregator", 1.0), ("navlab", 5.0)])
def test_watchdog_stops_the_vehicle(vehicle, speed):
    sim = Simulator(load_world("campus"), SimConfig(vehicle=vehicle, seed=0, watchdog_timeout=0.5))
    sim.submit(DriveCommand(speed=speed, curvature=0.0))
    events = []
    for _ in range(30):  # keep feeding for 3 s
        sim.submit(DriveCommand(speed=speed, curvature=0.0))
        events += sim.advance(0.1)
    assert sim.state.v > 0.5 * speed and not [e for e in events if e.kind == "watchdog"]
    t_last = sim.supervisor.last_received
    assert t_last == pytest.approx(2.9)
    events = sim.advance(6.0)  # commands stop
    trips = [e for e in events if e.kind == "watchdog"]
    assert len(trips) == 1
    assert t_last + 0.5 <= trips[0].stamp <= t_last + 0.5 + 2 * sim.dt
    assert sim.state.v == pytest.approx(0.0, abs=1e-3)
    x = (sim.state.x, sim.state.y)
    sim.advance(1.0)
    assert (sim.state.x, sim.state.y) == pytest.approx(x, abs=1e-3)
