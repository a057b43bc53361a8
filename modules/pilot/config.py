"""PILOT configuration: vehicle presets, pipeline look-ahead, perception mode, estimator start."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from modules.pilot.driving_units import DrivingUnitConfig
from modules.pilot.fix_gate import FIX_GATE
from modules.pilot.kalman import OdometryNoise
from modules.pilot.local_path_constraints import NavigatorConfig
from modules.pilot.planner import PlannerConfig
from modules.pilot.speed_profile import SpeedConfig

__all__ = ["PilotConfig", "PerceptionMode", "VehicleName", "pilot_config_for"]

#: on: wait for PERCEPTION (map fallback per unit on timeout); off: dead reckoning on the map;
#: auto: like on, but after `max_perception_misses` unanswered units in a row drive on the map
#: until PERCEPTION answers again.
PerceptionMode = Literal["on", "off", "auto"]
VehicleName = Literal["navlab", "terregator"]


class PilotConfig(BaseModel):
    """Everything the PILOT process needs besides the network: vehicle model, pipeline, estimator."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    vehicle: VehicleName = "navlab"
    perception: PerceptionMode = "auto"
    perception_timeout_s: float = Field(30.0, gt=0.0, description="sim time to wait for PERCEPTION per unit [s] (its wall-clock work counts × RTF)")
    max_perception_misses: int = Field(2, ge=1, description="auto mode: unanswered units before dead reckoning")
    lookahead_m: float = Field(14.0, gt=0.0, description="post driving units starting this far ahead [m]")
    tick_s: float = Field(0.2, gt=0.0, description="PILOT loop period [s] sim")
    correction_period_s: float = Field(1.0, gt=0.0, description="repost world←local and the estimate every [s] sim")
    max_speed: float = Field(2.0, gt=0.0, description="speed when the segment sets no limit [m/s]")
    stuck_timeout_s: float = Field(60.0, gt=0.0, description="no progress for this long fails the segment [s] sim")
    helm: str = Field("helm", description="the module driving the vehicle: while its heartbeat is silent the stuck timer waits")
    final_goal_settle_s: float = Field(3.0, gt=0.0, description="standing this long at the last unit's goal ends the segment [s] sim")
    replan_idle_s: float = Field(10.0, gt=0.0, description="no progress and no new plan for this long: plan again [s] sim")
    max_plan_failures: int = Field(8, ge=1, description="consecutive planning failures that fail the segment")
    start_pose: tuple[float, float, float] | None = Field(None, description="world←vehicle at start (x [m], y [m], yaw [rad])")
    start_sigma_xy: float = Field(0.3, gt=0.0, description="[m]")
    start_sigma_yaw: float = Field(math.radians(3.0), gt=0.0, description="[rad]")
    landmark_replan_m: float = Field(0.3, ge=0.0, description="a landmark fix moving the estimate farther than this replans [m]")
    landmark_gate: float = Field(13.8, gt=0.0, description="χ² gate (2 dof, 99.9 %) a landmark_fix must pass to be used")
    fix_gate: float | None = Field(FIX_GATE, gt=0.0, description="χ² gate (3 dof, 99.9 %) a PERCEPTION fix must pass (None: every fix applied)")
    min_goal_ahead_m: float = Field(2.0, ge=0.0, description="intermediate goals closer than this along the path are skipped [m]")
    region_extension_m: float = Field(0.0, ge=0.0, description="the map region reaches this far past a segment's ends [m]")
    seed: int = 0
    units: DrivingUnitConfig = DrivingUnitConfig()
    navigator: NavigatorConfig = NavigatorConfig()
    planner: PlannerConfig = PlannerConfig()
    speed: SpeedConfig = SpeedConfig()
    odometry: OdometryNoise = OdometryNoise()


def pilot_config_for(vehicle: VehicleName, **overrides) -> PilotConfig:
    """Return the PILOT configuration preset for `vehicle` with field overrides applied."""
    # Navlab (2.1 m wide van, 7 m turning radius) on 6 m roads: keep right means the right lane.
    # Terregator (1.8 m wide, turns in place) on 2–3.5 m campus walks: the margin cannot be the full
    # half-width, so the centre keeps 0.5 m from the edges.
    if vehicle == "navlab":
        base = dict(
            vehicle="navlab",
            # The Navlab's frame is its rear axle; the body reaches 4.6 m ahead: check points along it.
            # A goal it need not stop at, out of reach forward (a fix moved the estimate sideways close
            # to it), is moved towards the vehicle's line before the planner may reverse.
            planner=PlannerConfig(kind="dubins", turning_radius=7.0, footprint_x=(0.0, 1.5, 3.0), fallback_kind="reeds_shepp",
                                  relax_fractions=(0.25, 0.5, 0.75, 1.0)),
            navigator=NavigatorConfig(margin=1.2, keep_offset=1.5, body_half_width=1.15, obstacle_clearance=1.4,
                                      footprint_x=(0.0, 1.5, 3.0), max_goal_backoff=5.0),
            units=DrivingUnitConfig(unit_length=8.0, corridor_half_width=8.0, view_offset=6.0),
            lookahead_m=24.0,
            region_extension_m=4.0,
            max_speed=4.0,
        )
    else:
        base = dict(
            vehicle="terregator",
            planner=PlannerConfig(kind="se2"),
            navigator=NavigatorConfig(margin=0.5, keep_offset=0.3, body_half_width=1.0, obstacle_clearance=1.1),
            units=DrivingUnitConfig(unit_length=6.0, corridor_half_width=4.0, view_offset=4.0),
            lookahead_m=12.0,
            max_speed=0.8,
        )
    base.update({k: v for k, v in overrides.items() if v is not None})
    return PilotConfig(**base)
