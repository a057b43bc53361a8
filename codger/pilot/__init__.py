"""The PILOT on the blackboard (seed §2.3.3): its five parts pipelined as in the paper's Figure 6; `python -m codger.pilot`.

One file per part: `driving_monitor.DrivingMonitor`, `driving_unit_finder.DrivingUnitFinder`,
`position_estimator.PositionEstimator`, `driving_unit_navigator.DrivingUnitNavigator`,
`local_path_planner.LocalPathPlanning`; `pilot.Pilot` wires them. Their cores are `modules.pilot`.
"""

from codger.pilot.pilot import Pilot

__all__ = ["Pilot"]
