"""Road markings: validated in the world file, painted by the renderer, absent from maps and from unmarked worlds."""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest

from vehicle_sim.markings import dash_pieces
from vehicle_sim.scene import Scene
from vehicle_sim.worldfile import Marking, WorldFileError, load_world, parse_world, world_path


def _with(props_update: dict, kind: str = "road") -> dict:
    doc = json.loads(world_path("schenley").read_text())
    d = copy.deepcopy(doc)
    for f in d["features"]:
        if f["properties"]["id"] == ("road_golf" if kind == "road" else "fairway"):
            f["properties"].update(props_update)
    return d


def test_bad_markings_name_the_file_and_the_field() -> None:
    cases = [
        ({"markings": [{"colour": "orange", "line": [[0, 0], [5, 0]], "width": 0.1}]}, "road", "markings.0.colour"),
        ({"markings": [{"colour": "white", "line": [[0, 0]], "width": 0.1}]}, "road", "markings.0.line"),
        ({"markings": [{"colour": "white", "line": [[0, 0], [5, 0]], "width": 0.1, "dash": [3, 0]}]}, "road", "markings.0.dash"),
        ({"markings": [{"colour": "white", "line": [[0, 0], [5, 0]], "width": 0.1, "dahs": [3, 3]}]}, "road", "markings.0.dahs"),
        ({"markings": [{"colour": "white", "line": [[0, 0], [5, 0]], "width": 0.1}]}, "grass", "properties.markings"),
    ]
    for update, kind, field in cases:
        with pytest.raises(WorldFileError) as err:
            parse_world(_with(update, kind), source="bad.world.geojson")
        msg = str(err.value)
        assert "bad.world.geojson" in msg and field in msg, msg


def test_dashes_are_painted_pieces() -> None:
    m = Marking(colour="yellow", line=((0.0, 0.0), (10.0, 0.0), (10.0, 10.0)), width=0.1, dash=(3.0, 1.0))
    pieces = dash_pieces(m)
    lengths = [float(np.linalg.norm(np.diff(p, axis=0), axis=1).sum()) for p in pieces]
    assert lengths == pytest.approx([3.0] * 5)
    assert pieces[2].tolist() == [[8.0, 0.0], [10.0, 0.0], [10.0, 1.0]]  # the third piece turns the corner
    assert dash_pieces(m.model_copy(update={"dash": None}))[0].tolist() == [[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]]


def test_the_renderer_paints_the_lines_where_the_world_says() -> None:
    w = load_world("schenley")
    scene = Scene(w, seed=0)
    assert scene.paint is not None
    ys = np.arange(-4.0, 4.0, 0.02)
    codes = scene.paint.codes_at(np.full(ys.size, 10.0), ys)
    yellow = ys[codes == 1]
    white = ys[codes == 2]
    assert yellow.size and abs(yellow.mean()) < 0.03 and 0.2 < np.ptp(yellow) < 0.4  # the double line about the spine
    assert set(np.round(white[np.abs(white) > 3.0])) == {-4.0, 4.0} or np.allclose(np.abs(white).mean(), 3.55, atol=0.05)
    # and the camera sees yellow where the centre line is, in the right lane looking along the road
    from vehicle_sim.sensors import CaptureRequest, capture

    cap = capture(scene, (10.0, -1.75, 0.0), 1.0, CaptureRequest(laser=False), vehicle="navlab")
    img = cap.camera_image.astype(float)
    row = img[200]
    yellowish = (row[:, 0] > row[:, 2] + 60) & (row[:, 1] > row[:, 2] + 40)
    assert yellowish.any() and np.flatnonzero(yellowish).mean() < 160  # left of centre: the spine is to the left
    # an unmarked world has no paint at all (its images are what they were)
    assert Scene(load_world("campus"), seed=0).paint is None


def test_maps_do_not_state_markings() -> None:
    w = load_world("schenley")
    m = load_world("schenley", kind="map")
    assert any(o.markings for o in w.objects) and not any(o.markings for o in m.objects)
    assert all(not o.as_mapped().markings for o in w.objects)
