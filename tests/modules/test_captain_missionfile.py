"""Mission files: the schema's forms parse; bad files give errors naming the line, column and field."""

from __future__ import annotations

from pathlib import Path

import pytest

from modules.captain import MissionFileError, load_mission, parse_mission
from modules.vocabulary import DEFAULT_TOLERANCE_M, Destination, MissionStart, StepConstraints, Trigger

GOOD = """\
mission: demo
description: a demo
world: campus
vehicle: navlab
start: {x: 1.5, y: -20, yaw_deg: 90}
steps:
  - name: first
    destination: quad
    constraints: [keep_right, avoid_stairs, {speed_limit: 1.5}]
    trigger: wait 5
    tolerance: 0.75
  - destination: {x: 10, y: -2.5}
    constraints: {keep_left: true, avoid_slope: true}
    trigger: {action: stop}
  - destination: {place: library}
"""


def test_good_mission_parses_every_form() -> None:
    m = parse_mission(GOOD, mission_id="demo-1")
    assert (m.mission_id, m.name, m.world, m.vehicle, m.description) == ("demo-1", "demo", "campus", "navlab", "a demo")
    s0, s1, s2 = m.steps
    assert s0.name == "first" and s0.destination == Destination(place="quad")
    assert s0.constraints == StepConstraints(keep="right", avoid_stairs=True, speed_limit=1.5)
    assert s0.trigger == Trigger(action="wait", wait_s=5.0)
    assert s1.name == "step 2" and s1.destination == Destination(xy=(10.0, -2.5))
    assert s1.constraints == StepConstraints(keep="left", avoid_slope=True)
    assert s1.trigger == Trigger(action="stop")
    assert s2.destination == Destination(place="library") and s2.trigger == Trigger(action="continue")
    assert m.start == MissionStart(x=1.5, y=-20.0, yaw_deg=90.0)
    assert (s0.tolerance, s1.tolerance, s2.tolerance) == (0.75, DEFAULT_TOLERANCE_M, 1.5)
    assert parse_mission("mission: x\nsteps:\n  - destination: quad\n").start is None


def test_an_off_road_point_is_the_point_itself() -> None:
    m = parse_mission("mission: x\nsteps:\n  - destination: {x: 395.1, y: 47.0, off_road: true}\n")
    assert m.steps[0].destination == Destination(xy=(395.1, 47.0), off_road=True)
    assert "off road" in m.steps[0].destination.describe()
    assert parse_mission("mission: x\nsteps:\n  - destination: {x: 1, y: 2}\n").steps[0].destination.off_road is False


def test_json_is_accepted() -> None:
    m = parse_mission('{"name": "j", "steps": [{"destination": "gym", "trigger": "wait 2.5s"}]}')
    assert m.name == "j" and m.steps[0].trigger.wait_s == 2.5


def _problems(text: str) -> list[tuple[int | None, str, str]]:
    with pytest.raises(MissionFileError) as ei:
        parse_mission(text, source="bad.yaml")
    return [(p.line, p.field, p.message) for p in ei.value.problems]


@pytest.mark.parametrize("text,line,field,needle", [
    ("steps:\n  - destination: quad\n", 1, "mission", "required"),
    ("mission: x\n", 1, "steps", "required"),
    ("mission: x\nsteps: []\n", 2, "steps", "at least one"),
    ("mission: x\nsteps:\n  - name: a\n", 3, "steps[0].destination", "required"),
    ("mission: x\nsteps:\n  - destination: quad\n    colour: red\n", 4, "steps[0].colour", "unknown field"),
    ("mission: x\nsteps:\n  - destination: {x: 1}\n", 3, "steps[0].destination", "both x and y"),
    ("mission: x\nsteps:\n  - destination: {x: 1, y: north}\n", 3, "steps[0].destination.y", "finite number"),
    ("mission: x\nsteps:\n  - destination: quad\n    constraints: [keep_middle]\n", 4, "steps[0].constraints.keep_middle", "unknown constraint"),
    ("mission: x\nsteps:\n  - destination: quad\n    constraints: [keep_right, keep_left]\n", 4, "steps[0].constraints.keep_left", "exclude"),
    ("mission: x\nsteps:\n  - destination: quad\n    constraints: [speed_limit]\n", 4, "steps[0].constraints.speed_limit", "needs a value"),
    ("mission: x\nsteps:\n  - destination: quad\n    constraints: [{speed_limit: -1}]\n", 4, "steps[0].constraints.speed_limit", "> 0"),
    ("mission: x\nsteps:\n  - destination: quad\n    constraints: [{speed_limit: 50}]\n", 4, "steps[0].constraints.speed_limit", "m/s"),
    ("mission: x\nsteps:\n  - destination: quad\n    trigger: jump\n", 4, "steps[0].trigger", "must be stop"),
    ("mission: x\nsteps:\n  - destination: quad\n    trigger: {action: wait}\n", 4, "steps[0].trigger.seconds", "needs seconds"),
    ("mission: x\nsteps:\n  - destination: quad\n    trigger: {action: stop, seconds: 3}\n", 4, "steps[0].trigger.seconds", "only meaningful"),
    ("mission: x\nvehicle: car\nsteps:\n  - destination: quad\n", 2, "vehicle", "terregator"),
    ("mission: x\nsteps:\n  - destination: quad\n  - 42\n", 4, "steps[1]", "mapping"),
    ("mission: x\nsteps:\n  - destination: [1, 2]\n", 3, "steps[0].destination", "mapping"),
    ("mission: x\nsteps:\n  - destination: quad\n    tolerance: 0\n", 4, "steps[0].tolerance", "> 0"),
    ("mission: x\nsteps:\n  - destination: quad\n    tolerance: near\n", 4, "steps[0].tolerance", "finite number"),
    ("mission: x\nstart: {x: 1, y: 2}\nsteps:\n  - destination: quad\n", 2, "start.yaw_deg", "required"),
    ("mission: x\nstart: {x: 1, y: 2, yaw_deg: east}\nsteps:\n  - destination: quad\n", 2, "start.yaw_deg", "finite number"),
    ("mission: x\nstart: {x: 1, y: 2, yaw_deg: 0, z: 3}\nsteps:\n  - destination: quad\n", 2, "start.z", "unknown field"),
    ("mission: x\nstart: dorm\nsteps:\n  - destination: quad\n", 2, "start", "mapping"),
    ("mission: x\nsteps:\n  - destination: {x: 1, y: 2, off_road: maybe}\n", 3, "steps[0].destination.off_road", "true or false"),
    ("mission: x\nsteps:\n  - destination: {place: quad, off_road: true}\n", 3, "steps[0].destination", "not both"),
])
def test_bad_missions_name_line_and_field(text: str, line: int, field: str, needle: str) -> None:
    problems = _problems(text)
    assert any(p[0] == line and p[1] == field and needle in p[2] for p in problems), problems


def test_every_problem_is_reported_in_line_order_with_the_source() -> None:
    text = "mission: x\nvehicle: car\nsteps:\n  - destination: {x: 1, y: nope}\n    trigger: jump\n"
    with pytest.raises(MissionFileError) as ei:
        parse_mission(text, source="m.yaml")
    lines = [p.line for p in ei.value.problems]
    assert lines == sorted(lines) and len(lines) == 3
    assert "m.yaml:2:10: vehicle:" in str(ei.value)
    assert "m.yaml:4:28: steps[0].destination.y:" in str(ei.value)


@pytest.mark.parametrize("text,needle", [
    ("mission: x\nsteps: [\n", "not valid YAML"),
    ("", "empty mission"),
    ("- just\n- a list\n", "mapping"),
    ("mission: x\nmission: y\nsteps:\n  - destination: quad\n", "duplicate"),
])
def test_unparseable_files_are_rejected_with_a_location(text: str, needle: str) -> None:
    with pytest.raises(MissionFileError) as ei:
        parse_mission(text)
    assert needle in str(ei.value)
    assert ei.value.problems[0].line is not None


def test_unreadable_file_is_a_mission_error(tmp_path: Path) -> None:
    with pytest.raises(MissionFileError, match="cannot read"):
        load_mission(tmp_path / "missing.yaml")
    bad = tmp_path / "bad.yaml"
    bad.write_bytes(b"\xff\xfe mission")
    with pytest.raises(MissionFileError, match="not UTF-8 text"):
        load_mission(bad)
