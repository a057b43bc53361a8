"""End to end: EDDIE stops for a pedestrian standing in its lane and drives on once the lane is clear.

`sidewalk run --arch eddie --actors FILE`: the simulator places the walker (truth); EDDIE's obstacle
stop, switched on by the mission's `start_obstacles` trigger, stops the controller before it; the
report (truth) counts the stop and the closest approach.
"""

from pathlib import Path

import pytest

from tests.sidewalk._cli import run_report

DATA = Path(__file__).resolve().parent / "data"


@pytest.mark.missions
@pytest.mark.e2e
@pytest.mark.timeout(300)
def test_eddie_stops_for_a_walker_in_its_lane_and_resumes(tmp_path):
    report, stderr = run_report(tmp_path, "--arch", "eddie", "--world", "north_hills", "--mission", str(DATA / "oak-walker.yaml"),
                                "--actors", str(DATA / "oak-walker.actors.yaml"), "--rtf", "4", "--seed", "1",
                                "--max-wall-time", "200", wall_s=280)
    assert report["architecture"] == "eddie"
    assert report["collisions"] == 0, report["reason"]
    stops = report["stops"]
    held = [s for s in stops["spans"] if s["actor"] == "walker"]
    assert held and stops["obstacle_stops"] >= 1, stops  # it stood still on the way with the walker ahead in the lane
    assert held[0]["y"] < 0.0 - 4.0  # before the walker (at y = 0), not past it
    assert stops["min_actor_clearance_m"] is not None and 0.3 < stops["min_actor_clearance_m"] < 8.0
    assert report["success"], f"{report['reason']}\n{stderr[-3000:]}"  # it drove on and got there
    controller_log = (tmp_path / "logs" / "controller.log").read_text()
    assert "stop client=obstacle_stop obstacle" in controller_log and "released client=obstacle_stop" in controller_log
