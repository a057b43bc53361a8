"""Missions as annotations (seed §3.3): compile a mission YAML over a map into trigger annotations along its route."""

from eddie.missions.errors import MissionCompileError
from eddie.missions.mission_compiler import (CRUISE_SPEED_M_S, INTERSECTION_SPEED_M_S, CompiledMission, compile_mission,
                                             compile_mission_files)
from eddie.missions.macros import gate, turn_at_intersection

__all__ = [
    "MissionCompileError", "CRUISE_SPEED_M_S", "INTERSECTION_SPEED_M_S", "CompiledMission", "compile_mission",
    "compile_mission_files", "gate", "turn_at_intersection",
]
