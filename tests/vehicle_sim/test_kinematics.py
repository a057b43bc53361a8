"""Navlab and Terregator kinematics against closed forms, limits and the 7 m minimum turning radius."""

from __future__ import annotations

import math
from dataclasses import dataclass

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wire.drive import DriveCommand
from vehicle_sim.kinematics import NAVLAB, TERREGATOR, VehicleState, integrate_arc, limits_of, step


@dataclass(frozen=True)
class Cmd:
    speed: float
    curvature: float = 0.0
    turn_rate: float | None = None


def run(state: VehicleState, cmd, seconds: float, dt: float, params) -> list[VehicleState]:
    out = [state]
    for _ in range(int(round(seconds / dt))):
        state = step(state, cmd, dt, params)
        out.append(state)
    return out


@pytest.mark.parametrize("params", [NAVLAB, TERREGATOR], ids=["navlab", "terregator"])
def test_straight_line_at_steady_speed(params):
    v = 0.8 if params is TERREGATOR else 5.0
    s0 = VehicleState(x=1.0, y=2.0, yaw=math.radians(30), v=v)
    s = run(s0, Cmd(v), 10.0, 0.01, params)[-1]
    assert s.x == pytest.approx(1.0 + v * 10 * math.cos(math.radians(30)), abs=1e-9)
    assert s.y == pytest.approx(2.0 + v * 10 * math.sin(math.radians(30)), abs=1e-9)
    assert s.yaw == pytest.approx(math.radians(30), abs=1e-12)


@pytest.mark.parametrize("params, v, k", [(NAVLAB, 4.0, 0.1), (NAVLAB, 7.0, -1 / 7), (TERREGATOR, 0.5, 0.4)], ids=["navlab-left", "navlab-right-min-radius", "terregator"])
def test_constant_arc_matches_closed_form(params, v, k):
    s0 = VehicleState(v=v, kappa=k, omega=v * k)
    T = 6.0
    for dt in (0.01, 0.1):
        s = run(s0, Cmd(v, k), T, dt, params)[-1]
        th = v * k * T
        assert s.yaw == pytest.approx(math.atan2(math.sin(th), math.cos(th)), abs=1e-9)
        assert s.x == pytest.approx(math.sin(th) / k, abs=1e-9)
        assert s.y == pytest.approx((1 - math.cos(th)) / k, abs=1e-9)


def test_integrate_arc_small_turns_are_continuous():
    a = integrate_arc(0, 0, 0.3, 2.0, 1e-10)
    b = integrate_arc(0, 0, 0.3, 2.0, 2e-9)
    assert a[0] == pytest.approx(b[0], abs=1e-8) and a[1] == pytest.approx(b[1], abs=1e-8)


def test_navlab_top_speed_and_acceleration_limit():
    states = run(VehicleState(), Cmd(50.0), 20.0, 0.02, NAVLAB)
    speeds = [s.v for s in states]
    assert max(speeds) <= 28 / 3.6 + 1e-12
    assert speeds[-1] == pytest.approx(28 / 3.6, rel=1e-3)
    acc = [(b - a) / 0.02 for a, b in zip(speeds, speeds[1:])]
    assert max(acc) <= NAVLAB.max_accel + 1e-9
    # braking is limited too
    states = run(states[-1], Cmd(0.0), 10.0, 0.02, NAVLAB)
    dec = [(a.v - b.v) / 0.02 for a, b in zip(states, states[1:])]
    assert max(dec) <= NAVLAB.max_decel + 1e-9
    assert states[-1].v == pytest.approx(0.0, abs=1e-3)


def test_navlab_speed_lag_is_first_order_when_unsaturated():
    # a small step: the lag never asks for more than the acceleration limit
    v_cmd = 0.2
    s = run(VehicleState(), Cmd(v_cmd), NAVLAB.speed_lag, 0.001, NAVLAB)[-1]
    assert s.v == pytest.approx(v_cmd * (1 - math.exp(-1.0)), rel=1e-6)


def test_navlab_steering_rate_limit_and_clip():
    states = run(VehicleState(v=3.0), Cmd(3.0, 1.0), 5.0, 0.01, NAVLAB)
    ks = [s.kappa for s in states]
    rates = [abs(b - a) / 0.01 for a, b in zip(ks, ks[1:])]
    assert max(rates) <= NAVLAB.max_curvature_rate + 1e-9
    assert ks[-1] == pytest.approx(1 / 7, rel=1e-6)
    assert max(abs(k) for k in ks) <= 1 / 7 + 1e-12


commands = st.builds(
    Cmd,
    speed=st.floats(-5.0, 20.0, allow_nan=False),
    curvature=st.floats(-2.0, 2.0, allow_nan=False),
    turn_rate=st.one_of(st.none(), st.floats(-3.0, 3.0, allow_nan=False)),
)


@settings(max_examples=150, deadline=None)
@given(cmds=st.lists(st.tuples(commands, st.integers(1, 60)), min_size=1, max_size=12),
       dt=st.sampled_from([0.005, 0.01, 0.02, 0.05, 0.1]),
       k0=st.floats(-1 / 7, 1 / 7), v0=st.floats(-2.0, 28 / 3.6))
def test_navlab_never_turns_tighter_than_7m(cmds, dt, k0, v0):
    """Whatever it is told, the Navlab's path never curves tighter than a 7 m radius."""
    s = VehicleState(v=v0, kappa=k0, omega=v0 * k0)
    for cmd, n in cmds:
        for _ in range(n):
            nxt = step(s, cmd, dt, NAVLAB)
            assert abs(nxt.kappa) <= 1 / 7 + 1e-12
            ds = math.hypot(nxt.x - s.x, nxt.y - s.y)
            dyaw = abs((nxt.yaw - s.yaw + math.pi) % (2 * math.pi) - math.pi)
            if ds > 1e-6:
                # a chord of length c on a circle of radius r subtends 2·asin(c / 2r) ≥ the turn
                assert dyaw <= 2 * math.asin(min(1.0, ds / 14.0)) * (1 + 1e-6) + 1e-12
            assert nxt.v <= 28 / 3.6 + 1e-9
            s = nxt


def test_terregator_turns_in_place():
    s0 = VehicleState(x=3.0, y=4.0, yaw=0.0)
    states = run(s0, Cmd(0.0, 0.0, turn_rate=0.5), 8.0, 0.01, TERREGATOR)
    assert all((s.x, s.y) == (3.0, 4.0) for s in states)
    assert states[-1].omega == pytest.approx(0.5, rel=1e-3)
    total = sum(abs((b.yaw - a.yaw + math.pi) % (2 * math.pi) - math.pi) for a, b in zip(states, states[1:]))
    assert total == pytest.approx(0.5 * 8.0 - 0.5 * TERREGATOR.lag, abs=0.05)  # ramp-up lag ≈ tau


def test_terregator_is_slow_and_track_limited():
    states = run(VehicleState(), Cmd(5.0), 10.0, 0.01, TERREGATOR)
    assert max(s.v for s in states) <= 1.0 + 1e-12
    assert states[-1].v == pytest.approx(1.0, rel=1e-3)
    s = run(VehicleState(), Cmd(1.0, 0.0, turn_rate=0.6), 10.0, 0.01, TERREGATOR)[-1]
    assert abs(s.v) + abs(s.omega) * TERREGATOR.track_width / 2 <= TERREGATOR.max_track_speed + 1e-9
    assert s.omega / s.v == pytest.approx(0.6, rel=1e-3)  # the ratio (the path) is kept


def test_limits_and_real_commands():
    lim = limits_of(NAVLAB)
    assert lim.min_turning_radius == 7.0 and lim.max_curvature == pytest.approx(1 / 7)
    assert lim.max_speed == pytest.approx(28 / 3.6) and not lim.turns_in_place
    assert limits_of(TERREGATOR).turns_in_place
    # the pydantic drive command works as an actuation
    s = step(VehicleState(), DriveCommand(speed=1.0, curvature=0.05), 0.1, NAVLAB)
    assert s.v > 0
