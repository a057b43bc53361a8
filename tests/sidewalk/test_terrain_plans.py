"""A CODGER run of a cross-country mission starts the TERRAIN module over the start and the off-road goal; a road mission does not."""

from __future__ import annotations

import pytest

from sidewalk.codger_run import TERRAIN_MARGIN_M, build_plans
from sidewalk.launcher import RunConfig, prepare_run

pytestmark = pytest.mark.timeout(120)  # quiet run ~3 s (the worlds' files read)


def _plans(tmp_path, world: str, mission: str) -> dict:
    cfg = RunConfig(world=world, mission=mission, out=tmp_path, record=False)
    setup = prepare_run(cfg)
    return setup, {p.name: p for p in build_plans(cfg, setup, "ns", "tcp/127.0.0.1:7447")}


def test_a_cross_country_run_maps_the_terrain_between_the_believed_start_and_the_goal(tmp_path) -> None:
    setup, plans = _plans(tmp_path, "cross_country", "cross-country")
    args = plans["terrain"].args
    assert args[:4] == ("-m", "sidewalk", "up", "terrain")
    x0, y0, x1, y1 = (float(v) for v in next(a for a in args if a.startswith("--bounds=")).split("=", 1)[1].split(","))
    sx, sy, _ = setup.start_belief
    gx, gy = setup.mission.steps[0].destination.xy
    assert (x0, y0) == pytest.approx((min(sx, gx) - TERRAIN_MARGIN_M, min(sy, gy) - TERRAIN_MARGIN_M), abs=0.06)
    assert (x1, y1) == pytest.approx((max(sx, gx) + TERRAIN_MARGIN_M, max(sy, gy) + TERRAIN_MARGIN_M), abs=0.06)


def test_a_road_mission_runs_no_terrain_module(tmp_path) -> None:
    _, plans = _plans(tmp_path, "campus", "campus-tour")
    assert "terrain" not in plans
