"""Local navigation vocabulary: driving units, position estimates, local path constraints and plans.

Seed §2.3.3: the PILOT's DRIVING MONITOR cuts a route segment into driving units and tells
PERCEPTION where and what to see (not how); PERCEPTION posts its result once, as a
`perception_result` token, and sets the driving unit's status;
the DRIVING UNIT NAVIGATOR plots local path constraints; the LOCAL PATH PLANNER posts local path
plans from the current pose through all driving units to the far edge of the newest, which the HELM
tracks.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from modules.vocabulary._base import Cov3, Frozen, NonNeg, Polyline2, Pose, Ring, finite, token_type
from modules.vocabulary.mapdata import MapObject
from modules.vocabulary.route import NavigationMode
from wire.se2 import PoseFields

__all__ = [
    "UnitStatus", "DrivingUnitDescription", "PositionEstimate", "LocalPathConstraints", "PlanPose",
    "LocalPathPlan",
]

#: Lifecycle of a driving unit: pending (waiting for PERCEPTION), perceived, failed, cancelled.
UnitStatus = Literal["pending", "perceived", "failed", "cancelled"]


@token_type("driving_unit")
class DrivingUnitDescription(Frozen):
    """Where and what PERCEPTION should see in one driving unit (world frame), and how far it got.

    `region` is the ground area of the unit; `centreline` the planned track through it; `objects` the
    predicted map objects visible there; `error_allowance_m` [m] and `heading_allowance_rad` [rad]
    bound the vehicle position uncertainty PERCEPTION must allow for. PERCEPTION updates only
    `status` (pending → perceived or failed); what it saw is its own `perception_result` token.
    """

    unit_id: str
    segment_id: str
    unit_index: Annotated[int, Field(ge=0)]
    mode: NavigationMode
    region: Ring
    centreline: Polyline2
    objects: tuple[MapObject, ...] = ()
    error_allowance_m: NonNeg = 0.5
    heading_allowance_rad: NonNeg = 0.05
    status: UnitStatus = "pending"
    frame: Literal["world"] = "world"


@token_type("position_estimate")
class PositionEstimate(Frozen):
    """The POSITION ESTIMATOR's vehicle pose in the world frame with covariance, and what fed it."""

    pose: Pose
    covariance: Cov3
    source: Literal["dead-reckoning", "perception"]
    unit_id: str | None = None


@token_type("local_path_constraints")
class LocalPathConstraints(Frozen):
    """Where the local path may go in one driving unit: region, obstacles, track, margin, speed.

    All coordinates in `frame`; `track` is the desired line (centreline shifted by the lateral
    offset); `margin_m` [m] is the clearance to keep from the region's edge and obstacles;
    `speed_limit` [m/s]; `stop_at_end`: come to rest at the end of the track.
    """

    unit_id: str
    segment_id: str
    frame: Literal["world", "local"] = "world"
    region: Ring
    obstacles: tuple[Ring, ...] = ()
    track: Polyline2
    margin_m: NonNeg = 0.3
    speed_limit: Annotated[float, Field(gt=0.0)] | None = None
    stop_at_end: bool = False


class PlanPose(PoseFields, Frozen):
    """A pose of a local path plan with the speed to hold there [m/s] (negative: reversing)."""

    x: finite
    y: finite
    yaw: finite
    speed: finite


@token_type("local_path_plan")
class LocalPathPlan(Frozen):
    """A local path plan for the HELM: poses with speeds in `frame`, newest `seq` wins.

    Runs from the vehicle's pose at planning time through all driving units in `unit_ids` to the far
    edge of the newest. `stop_at_end`: the HELM stops at the last pose; otherwise it slows to a stop
    there only if no newer plan has arrived. `sensed_at` [s sim] is the newest capture stamp among
    the perceived driving units the plan was built on (None: planned on the map alone); the HELM
    copies it into its drive commands, so sense-to-act latency can be measured.
    """

    seq: Annotated[int, Field(ge=0)]
    segment_id: str
    unit_ids: tuple[str, ...] = ()
    frame: Literal["world", "local"] = "local"
    poses: Annotated[tuple[PlanPose, ...], Field(min_length=2)]
    stop_at_end: bool = False
    sensed_at: Annotated[float, Field(ge=0.0)] | None = None
