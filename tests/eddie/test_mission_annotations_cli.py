"""`sidewalk eddie annotate` / `annotations`: the file a person inspects, and clear errors for bad input."""

from __future__ import annotations

import json
import subprocess
import sys

from eddie.annotated_map import load_annotations


def _sidewalk(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "sidewalk", *args], capture_output=True, text=True, timeout=120)


def test_annotate_then_query(tmp_path) -> None:
    out = tmp_path / "amv.geojson"
    r = _sidewalk("eddie", "annotate", "--world", "north_hills", "--mission", "amv-delivery", "--out", str(out))
    assert r.returncode == 0, r.stderr
    anns = load_annotations(out)
    assert any(a.type == "dead_reckon_intersection" for a in anns)
    r = _sidewalk("eddie", "annotations", str(out), "--type", "set_speed", "--within", "-20,80,20,80,20,115,-20,115", "--json")
    assert r.returncode == 0, r.stderr
    rows = json.loads(r.stdout)
    assert sorted(row["data"]["speed"] for row in rows) == [0.5, 3.0]  # slow before Oak/Maple, cruise after it


def test_bad_input_one_line_errors(tmp_path) -> None:
    bad = tmp_path / "bad.geojson"
    bad.write_text('{"type": "FeatureCollection", "features": [{"type": "Feature", "id": "a", "geometry": null, "properties": {}}]}')
    for args, needle in [
        (("eddie", "annotations", str(bad)), "feature 0"),
        (("eddie", "annotations", str(tmp_path / "none.geojson")), "none.geojson"),
        (("eddie", "annotations", str(bad), "--within", "1,2,3"), "--within"),
        (("eddie", "annotate", "--world", "north_hills", "--mission", "nope", "--out", str(tmp_path / "x.geojson")), "nope"),
        (("eddie", "annotate", "--world", "north_hills", "--mission", "amv-delivery", "--map", str(tmp_path / "m.geojson"),
          "--out", str(tmp_path / "x.geojson")), "m.geojson"),
    ]:
        r = _sidewalk(*args)
        assert r.returncode == 2, (args, r.stdout, r.stderr)
        assert needle in r.stderr and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
