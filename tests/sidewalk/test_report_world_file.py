"""A run on a world given as a file (a generated layout) with actors gets its report: the stops read the world from the file."""

from pathlib import Path

import pytest

from sidewalk.report import build_report
from sidewalk.run_record import load_record
from vehicle_sim.generated import suburb

DATA = Path(__file__).parent / "data"


@pytest.mark.timeout(120)  # quiet run ~5 s
def test_a_report_with_actors_on_a_world_file_reads_the_world_from_the_file(tmp_path):
    paths = suburb.write(suburb.generate(3), tmp_path)
    rec = load_record(DATA / "two-hop.run_record.json.gz")
    rec = rec.model_copy(update={"world": "suburb_3", "actors": str(paths[3])})
    with pytest.raises(FileNotFoundError, match="no world file for 'suburb_3'"):
        build_report(rec)  # by name alone the world is nowhere: what every --with-actors run of a layout ended in
    rep = build_report(rec.model_copy(update={"world_file": str(paths[0])}))
    assert rep.world == "suburb_3" and rep.stops.min_actor_clearance_m is not None
