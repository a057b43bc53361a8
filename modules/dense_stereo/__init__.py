"""Today's stereo baseline beside FIDO: OpenCV's semi-global matching (dense disparity) and, for the
vehicle's motion, pyramidal Lucas–Kanade tracks of Shi–Tomasi corners with depth from that disparity.

Plain libraries, no transport, no truth. Obstacles come from the laser's height-map detector run on
the dense points (`modules.perception.obstacles.obstacles_from_points`), and the motion from FIDO's
own solver (`modules.fido.estimate_motion`), so a comparison with FIDO compares the front ends.
"""

from modules.dense_stereo.lk_motion import LkConfig, LkMemory, LkStep, lk_step
from modules.dense_stereo.sgbm import SgbmConfig, disparity_depth, disparity_points, sgbm_disparity

__all__ = ["LkConfig", "LkMemory", "LkStep", "lk_step", "SgbmConfig", "disparity_depth", "disparity_points", "sgbm_disparity"]
