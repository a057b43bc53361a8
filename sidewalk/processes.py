"""Each architecture's robot processes: `sidewalk up NAME` → the package run as `python -m PACKAGE`.

One table for both architectures: `sidewalk up` starts from it, each architecture's plans
(`sidewalk.codger_run`, `sidewalk.eddie_run`) name their processes from it, and `sidewalk compare`'s
glue rule (`sidewalk.compare.glue`) counts from these entry points. The router, the blackboard node and
the simulator are the system's, not an architecture's: they go through their own Typer commands.
"""

from __future__ import annotations

__all__ = ["CODGER_PROCESSES", "EDDIE_PROCESSES", "UP_TARGETS"]

#: CODGER's processes (the Sidewalk paper's modules and the laser's OBSTACLE DETECTOR) → their packages
CODGER_PROCESSES: dict[str, str] = {
    "captain": "codger.captain",
    "map_navigator": "codger.map_navigator",
    "pilot": "codger.pilot",
    "helm": "codger.helm",
    "perception": "codger.perception",
    "obstacles": "codger.obstacles",
    "fido_obstacles": "codger.fido_obstacles",  # issue 41: FIDO's stereo in the laser's place (--obstacle-sensor fido)
    "terrain": "codger.terrain",  # issue 40: the elevation map from the laser, posted as terrain tiles
}

#: EDDIE's processes (issue 9: the integrated controller, the navigator, the annotated map manager, EDDIE's modules)
EDDIE_PROCESSES: dict[str, str] = {
    "controller": "eddie.controller",
    "navigator": "eddie.navigator",
    "map_manager": "eddie.map_manager",
    "mission_service": "eddie.mission_service",
    "road_following": "eddie.road_following",
    "landmark_matching": "eddie.landmark_matching",
    "obstacle_stop": "eddie.obstacle_stop",
    "fido_stop": "eddie.fido_stop",  # issue 41: runs as obstacle stop (its name) with FIDO's stereo
}

#: `sidewalk up NAME` → the package whose `__main__.main(argv)` runs it
UP_TARGETS: dict[str, str] = {**CODGER_PROCESSES, **EDDIE_PROCESSES}
