"""Truth at the edges of the command line: a world file never reaches the robot as its map, a map states nothing
only a world says, and JSON output holds no NaN (real `sidewalk` subprocesses where a user would meet it)."""

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

from sidewalk.json_out import dumps
from sidewalk.launcher import LaunchError, RunConfig, prepare_run
from sidewalk.robot_map import MissingMapError, map_beside
from tests.sidewalk._cli import one_line_error, sidewalk
from vehicle_sim.mapgen import map_with_error
from vehicle_sim.worldfile import WORLDS_DIR, load_world
from wire.mapfile import WorldFileError, load_map_file


@pytest.fixture()
def world_file(tmp_path: Path) -> Path:
    """A copy of the campus world in a directory of its own, its map not (yet) beside it."""
    d = tmp_path / "elsewhere"
    d.mkdir()
    return Path(shutil.copy(WORLDS_DIR / "campus.world.geojson", d / "campus.world.geojson"))


@pytest.mark.timeout(60)  # ~2 s
def test_world_file_never_hands_the_world_to_the_robot(world_file, tmp_path):
    with pytest.raises(MissingMapError, match="campus.map.geojson does not exist"):
        map_beside(world_file)
    with pytest.raises(LaunchError, match="no map beside this world"):
        prepare_run(RunConfig(world=str(world_file), out=tmp_path / "out"))
    # with the map written beside it, that map is what the robot gets: the map's error, not 0
    sibling = Path(shutil.copy(WORLDS_DIR / "campus.map.geojson", world_file.with_name("campus.map.geojson")))
    setup = prepare_run(RunConfig(world=str(world_file), out=tmp_path / "out"))
    assert setup.map_file == sibling
    assert setup.map_error.path_max_m > 0.1
    assert map_beside("campus") == WORLDS_DIR / "campus.map.geojson"


@pytest.mark.timeout(120)  # ~28 s on a loaded machine (load 6 on 2 cores): two `sidewalk` processes
def test_run_and_annotate_refuse_a_world_without_its_map_in_one_line(world_file, tmp_path):
    one_line_error(sidewalk("run", "--world", str(world_file), "--out", str(tmp_path / "o")),
                   "error:", "campus.map.geojson does not exist")
    assert not (tmp_path / "o" / "report.json").exists()
    one_line_error(sidewalk("eddie", "annotate", "--world", str(world_file), "--mission", "campus-tour",
                            "--out", str(tmp_path / "a.geojson")), "campus.map.geojson does not exist")
    assert not (tmp_path / "a.geojson").exists()


@pytest.mark.timeout(120)  # ~10 s on a loaded machine
def test_the_map_reader_refuses_world_only_fields(tmp_path):
    for name in ("campus", "north_hills", "schenley"):
        load_map_file(name, kind="map")  # the shipped maps state none
        with pytest.raises(WorldFileError, match="world-only fields") as err:
            load_map_file(WORLDS_DIR / f"{name}.world.geojson", kind="map")
        assert "appearance" in str(err.value) and "weather" in str(err.value)
    # a world handed over as the map is refused in one line before anything starts
    one_line_error(sidewalk("run", "--map", str(WORLDS_DIR / "campus.world.geojson"), "--out", str(tmp_path / "o")),
                   "--map", "world-only fields")


@pytest.mark.timeout(60)  # ~2 s
def test_a_map_error_map_states_no_appearance_weather_or_markings(tmp_path):
    for name in ("campus", "schenley"):
        world = load_world(name)
        assert any(o.appearance is not None for o in world.objects) and world.weather is not None
        path = map_with_error(world, 1.0, np.random.default_rng([0, 11])).save(tmp_path / f"{name}.map.geojson")
        text = path.read_text()
        for field in ('"appearance"', '"markings"', '"weather"', '"actors"'):
            assert field not in text, (name, field)
        load_map_file(path, kind="map")  # the map reader takes it
    assert any(o.markings for o in load_world("schenley").objects)  # schenley's world has markings to lose
    # what `sidewalk run --map-error` writes for the robot
    setup = prepare_run(RunConfig(mission="schenley-drive", world="schenley", map_error_m=1.0, out=tmp_path / "run"))
    assert setup.map_file == tmp_path / "run" / "map.geojson"
    assert '"appearance"' not in setup.map_file.read_text() and '"markings"' not in setup.map_file.read_text()


def _strict(text: str):
    def refuse(const: str):
        raise AssertionError(f"{const} in JSON output")

    return json.loads(text, parse_constant=refuse)


def test_json_output_writes_null_for_what_is_not_a_number():
    assert _strict(dumps({"a": math.nan, "b": [1.0, math.inf, (-math.inf, 2)], "c": {"d": float("nan")}})) == \
        {"a": None, "b": [1.0, None, [None, 2]], "c": {"d": None}}
    assert _strict(dumps(np.float64("nan"))) is None


@pytest.mark.timeout(180)  # ~30 s on a loaded machine: one frame rendered and segmented
def test_perception_eval_json_holds_no_nan():
    p = sidewalk("perception", "eval", "--json", "--frames", "1", timeout=170)
    assert p.returncode == 0, p.stderr
    report = _strict(p.stdout)
    assert report["focus_frames"] == 0  # no slope or stairs in view: the focus means are not numbers
    assert any(v is None for m in report["mean_iou_focus"].values() for v in m.values())
