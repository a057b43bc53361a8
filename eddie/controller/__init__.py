"""The integrated controller (seed: Navlab 1990 §2.5): path tracking, velocity regulation, dead-reckoned position.

Pure core: `integrated_controller.IntegratedController` with its parts `velocity`, `nudge`, `arbiter`,
`path_record`; the module: `controller_module.ControllerModule`, run with `python -m eddie.controller`.
"""

from eddie.controller.arbiter import ClientArbiter
from eddie.controller.controller_module import ControllerModule
from eddie.controller.integrated_controller import ControllerConfig, IntegratedController
from eddie.controller.nudge import NudgeSum
from eddie.controller.path_record import PathRecord
from eddie.controller.velocity import VelocityRegulator

__all__ = ["ClientArbiter", "ControllerModule", "ControllerConfig", "IntegratedController", "NudgeSum", "PathRecord",
           "VelocityRegulator"]
