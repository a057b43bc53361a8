"""The navigator (seed: Navlab 1990 §2.5): world←local from position fixes, pushed or answered on request.

Pure core: `navigator.Navigator` (the PILOT's `PoseFilter` as a library) with `local_pose_buffer`; the
module: `navigator_module.NavigatorModule`, run with `python -m eddie.navigator`.
"""

from eddie.navigator.local_pose_buffer import LocalPoseBuffer
from eddie.navigator.navigator import Navigator
from eddie.navigator.navigator_module import DELIVERY_MODES, NavigatorModule

__all__ = ["LocalPoseBuffer", "Navigator", "NavigatorModule", "DELIVERY_MODES"]
