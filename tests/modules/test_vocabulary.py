"""Vocabulary models: validation, immutability, wire round trips (msgpack and JSON), registration."""

from __future__ import annotations

import json
import math

import msgpack
import pytest
from pydantic import ValidationError

import modules.vocabulary as voc
from modules.vocabulary import (
    Destination, DetectedObject, DrivingConstraints, DrivingUnitDescription, ExitCondition,
    FlatShape, Heartbeat, LineFix, LocalPathConstraints, LocalPathPlan, MapColour, MapObject, Mission, MissionStatus,
    MissionStep, MissionStepSpec, PerceptionResult, PlanPose, PointFix, Pose, PositionEstimate, RoutePlan,
    RouteSegmentDescription, SegmentResult, SlopeShape, StepConstraints, StepOutcome, StepResult, Trigger,
)

SQUARE = ((0.0, 0.0), (4.0, 0.0), (4.0, 3.0), (0.0, 3.0))
COV = (0.04, 0.0, 0.0, 0.0, 0.04, 0.0, 0.0, 0.0, 0.001)


def _sidewalk() -> MapObject:
    return MapObject(
        object_id="sw1", kind="sidewalk", role="path", cost=1.0,
        colour=MapColour(type="GRAY", nominal=(150, 150, 150)), shape=FlatShape(), polygon=SQUARE,
    )


def _slope() -> MapObject:
    return MapObject(
        object_id="sl1", kind="slope", role="path", cost=1.5,
        shape=SlopeShape(rise=1.5, axis_deg=90.0), polygon=SQUARE,
    )


def _result(status: str = "perceived") -> PerceptionResult:
    return PerceptionResult(
        unit_id="u1", segment_id="s1", status=status, failure_reason="" if status == "perceived" else "no sidewalk",
        captured_at=12.5, sensor="colored-range", view_frame=SQUARE,
        detected=(DetectedObject(object_id="sw1", kind="sidewalk", outline=SQUARE, surface="flat"),),
        navigable_region=SQUARE, fix=LineFix(point=(1.0, 2.0), direction=0.3, lateral_var=0.01, yaw=0.3, yaw_var=1e-4),
    )


def _segment() -> RouteSegmentDescription:
    return RouteSegmentDescription(
        segment_id="p1/0", plan_id="p1", segment_index=0, mode="go-through-slope", path_object_ids=("sl1",),
        centreline=((0.0, 1.5), (4.0, 1.5)), width_m=3.0, length_m=4.0,
        exit=ExitCondition(point=(4.0, 1.5), gate=((4.0, 0.0), (4.0, 3.0)), heading=0.0),
        constraints=DrivingConstraints(keep="right", lateral_offset_m=-0.5, speed_limit=1.0),
        objects=(_slope(), _sidewalk()),
    )


def _samples() -> list:
    mission_steps = (
        MissionStepSpec(name="to A", destination=Destination(place="A")),
        MissionStepSpec(name="to xy", destination=Destination(xy=(3.0, 4.0)),
                        constraints=StepConstraints(keep="left", avoid_stairs=True, speed_limit=1.2),
                        trigger=Trigger(action="wait", wait_s=5.0)),
    )
    return [
        _sidewalk(),
        _slope(),
        MapObject(object_id="t1", kind="tree", role="obstacle", center=(2.0, 2.0), radius=0.3),
        Mission(mission_id="m1", name="tour", steps=mission_steps, vehicle="navlab"),
        MissionStep(mission_id="m1", step_index=1, name="to xy", destination=Destination(xy=(3.0, 4.0))),
        StepResult(mission_id="m1", step_index=0, success=False, reason="unknown place 'Q'"),
        MissionStatus(mission_id="m1", name="tour", state="running", current_step=0, step_count=2,
                      steps=(StepOutcome(step_index=0, name="to A", state="running", started_at=1.0),)),
        RoutePlan(plan_id="p1", mission_id="m1", step_index=0, node_ids=("a", "b"), edge_ids=("e1",), segment_count=1,
                  length_m=4.0, cost=4.0, polyline=((0.0, 0.0), (4.0, 0.0)), start_xy=(0.0, 0.0), goal_xy=(4.0, 0.0)),
        _segment(),
        SegmentResult(segment_id="p1/0", plan_id="p1", segment_index=0, success=True, end_xy=(4.0, 1.4)),
        DrivingUnitDescription(unit_id="u1", segment_id="s1", unit_index=0, mode="follow-road", region=SQUARE,
                               centreline=((0.0, 1.5), (4.0, 1.5)), objects=(_sidewalk(),)),
        DrivingUnitDescription(unit_id="u1", segment_id="s1", unit_index=0, mode="follow-road", region=SQUARE,
                               centreline=((0.0, 1.5), (4.0, 1.5)), status="perceived"),
        _result(),
        PerceptionResult(unit_id="u2", segment_id="s1", status="perceived", captured_at=3.0, sensor="colour",
                         fix=PointFix(pose=Pose(x=1.0, y=2.0, yaw=0.1), covariance=COV)),
        PositionEstimate(pose=Pose(x=1.0, y=2.0, yaw=0.1), covariance=COV, source="perception", unit_id="u2"),
        LocalPathConstraints(unit_id="u1", segment_id="s1", region=SQUARE, track=((0.0, 1.0), (4.0, 1.0)),
                             obstacles=(((1.0, 1.0), (1.5, 1.0), (1.5, 1.5)),)),
        LocalPathPlan(seq=3, segment_id="s1", unit_ids=("u1",),
                      poses=(PlanPose(x=0, y=0, yaw=0, speed=1.0), PlanPose(x=1, y=0, yaw=0, speed=0.0))),
        Heartbeat(module="captain", seq=4, sim_time=2.0, wall_time=1e9, period_s=1.0, pid=42),
    ]


@pytest.mark.parametrize("model", _samples(), ids=lambda m: type(m).__name__)
def test_round_trip_msgpack_and_json(model) -> None:
    cls = type(model)
    packed = msgpack.packb(model.model_dump(mode="json"))
    assert cls.model_validate(msgpack.unpackb(packed)) == model
    assert cls.model_validate(json.loads(model.model_dump_json())) == model


@pytest.mark.parametrize("model", _samples(), ids=lambda m: type(m).__name__)
def test_models_are_frozen(model) -> None:
    field = next(iter(type(model).model_fields))
    with pytest.raises(ValidationError):
        setattr(model, field, getattr(model, field))


def test_every_token_type_is_registered_with_the_blackboard() -> None:
    from blackboard.registry import default_registry

    for cls, name in voc.TOKEN_TYPES.items():
        assert default_registry.model(name) is cls, name
        assert default_registry.name_of(cls) == name


def test_destination_needs_exactly_one_of_place_and_xy() -> None:
    with pytest.raises(ValidationError, match="exactly one"):
        Destination()
    with pytest.raises(ValidationError, match="exactly one"):
        Destination(place="A", xy=(1.0, 2.0))
    assert Destination(place="A").describe() == "place 'A'"


def test_trigger_wait_needs_positive_time_and_others_none() -> None:
    with pytest.raises(ValidationError, match="wait_s > 0"):
        Trigger(action="wait")
    with pytest.raises(ValidationError, match="only meaningful"):
        Trigger(action="stop", wait_s=3.0)


def test_non_finite_numbers_and_bad_rings_are_rejected() -> None:
    with pytest.raises(ValidationError, match="finite"):
        Pose(x=math.nan, y=0.0)
    with pytest.raises(ValidationError, match="at least 3"):
        MapObject(object_id="a", kind="grass", role="none", polygon=((0, 0), (1, 1)))
    with pytest.raises(ValidationError, match="symmetric"):
        PointFix(pose=Pose(x=0, y=0), covariance=(1, 2, 0, 0, 1, 0, 0, 0, 1))


def test_a_map_object_states_a_colour_type_never_the_world_s_appearance() -> None:
    with pytest.raises(ValidationError, match="type"):
        MapObject(object_id="a", kind="sidewalk", role="path", polygon=SQUARE, colour={"mean": (150, 150, 150), "std": (8, 8, 8)})
    with pytest.raises(ValidationError, match="GRAY"):
        MapColour(type="GREY", nominal=(150, 150, 150))
    with pytest.raises(ValidationError, match="appearance"):
        MapObject(object_id="a", kind="sidewalk", role="path", polygon=SQUARE, appearance={"mean": (1, 2, 3), "std": (1, 1, 1)})
    with pytest.raises(ValidationError, match="reflectance"):
        MapObject(object_id="a", kind="sidewalk", role="path", polygon=SQUARE, reflectance=0.5)


def test_map_object_footprint_is_outline_xor_point() -> None:
    with pytest.raises(ValidationError, match="exactly one"):
        MapObject(object_id="a", kind="tree", role="obstacle")
    with pytest.raises(ValidationError, match="radius"):
        MapObject(object_id="a", kind="tree", role="obstacle", center=(0, 0))
    assert not MapObject(object_id="b", kind="building", role="obstacle", polygon=SQUARE).traversable


def test_the_driving_unit_carries_a_status_never_the_result() -> None:
    # PERCEPTION's result is written once, as its own perception_result token
    with pytest.raises(ValidationError, match="result"):
        DrivingUnitDescription(unit_id="u", segment_id="s", unit_index=0, mode="follow-road", region=SQUARE,
                               centreline=((0, 0), (1, 0)), status="perceived", result=_result())
    with pytest.raises(ValidationError, match="failure_reason"):
        PerceptionResult(unit_id="u", segment_id="s", status="failed", captured_at=0.0, sensor="colour")


def test_unknown_fields_are_rejected_by_name() -> None:
    with pytest.raises(ValidationError, match="colour_mode"):
        StepConstraints(colour_mode=True)


def test_line_fix_yaw_comes_with_variance() -> None:
    with pytest.raises(ValidationError, match="together"):
        LineFix(point=(0, 0), direction=0.0, lateral_var=0.1, yaw=0.2)


@pytest.mark.parametrize("model", _samples(), ids=lambda m: type(m).__name__)
def test_node_side_validation_accepts_and_decodes(model) -> None:
    from blackboard.registry import default_registry

    name = default_registry.name_of(model)
    raw = default_registry.validate_raw(name, msgpack.unpackb(msgpack.packb(model.model_dump(mode="json"))))
    assert default_registry.decode(name, raw) == model


def test_node_side_validation_names_the_bad_field() -> None:
    from blackboard.errors import InvalidTokenError
    from blackboard.registry import default_registry

    raw = _segment().model_dump(mode="json")
    raw["mode"] = "fly"
    with pytest.raises(InvalidTokenError, match="mode"):
        default_registry.validate_raw("route_segment", raw)
