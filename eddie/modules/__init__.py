"""What EDDIE's perception and behaviour modules share: the believed pose and sensing (`sensing`), switching (`switched`).

The modules themselves are packages of their own, each run with `python -m eddie.<name>`:
`road_following`, `landmark_matching`, `obstacle_stop`, `mission_service`. Their cores are plain
functions over PERCEPTION's and the PILOT's libraries (`modules/`), so EDDIE and CODGER run the same algorithms.
"""

from eddie.modules.errors import EddieModuleError, NoRoadPath

__all__ = ["EddieModuleError", "NoRoadPath"]
