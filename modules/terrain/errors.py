"""The root of every error the terrain libraries (elevation maps, pyramid, locus, matching, planner) raise."""

from __future__ import annotations

from modules.errors import ModuleError

__all__ = ["TerrainError", "TerrainPlanningError", "InadmissibleStart", "InadmissibleGoal", "NoAdmissiblePath"]


class TerrainError(ModuleError):
    """Base of every error the terrain libraries raise (a grid of the wrong shape, a query outside the map)."""


class TerrainPlanningError(TerrainError):
    """The cross-country planner cannot plan; `constraints` names the constraints that stood in the way."""

    def __init__(self, message: str, constraints: tuple = ()) -> None:
        super().__init__(message)
        self.constraints = constraints


class InadmissibleStart(TerrainPlanningError):
    """The start configuration violates a constraint (or lies off the map)."""


class InadmissibleGoal(TerrainPlanningError):
    """No configuration at the goal satisfies the constraints (or it lies off the map)."""


class NoAdmissiblePath(TerrainPlanningError):
    """The search found no admissible path from the start to the goal within its budget."""
