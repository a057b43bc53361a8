"""Vision road following (EDDIE): sees the road, plans in `local`, sends paths to the controller; `python -m eddie.road_following`."""

from eddie.road_following.road_following import (
    RoadFollowingConfig, RoadPath, plan_road_path, region_in_local, route_goal, route_to_local,
)
from eddie.road_following.road_following_module import RoadFollowing

__all__ = ["RoadFollowingConfig", "RoadPath", "plan_road_path", "region_in_local", "route_goal", "route_to_local", "RoadFollowing"]
