"""EDDIE's mission service: missions in on the mission keys, statuses out, steps judged by belief; `python -m eddie.mission_service`."""

from eddie.mission_service.mission_progress import MissionProgress, MissionRouteError, StepGoal, mission_route, step_goals
from eddie.mission_service.mission_service import MissionService

__all__ = ["MissionProgress", "MissionRouteError", "StepGoal", "mission_route", "step_goals", "MissionService"]
