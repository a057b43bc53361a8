"""Landmark matching as an EDDIE process: position fixes from the landmarks in view, sent to the navigator.

`python -m eddie.landmark_matching --vehicle V --map FILE --start-pose X,Y,YAW [--asleep]`

Seed: Navlab 1990 §2.5 — landmark matching runs between the triggers "start / stop landmark
matching" and sends fixes to the navigator. Each cycle: capture a frame (no truth), note the
controller's `local` pose then (the controller keeps no history, so the fix carries it), match the
map objects in view with PERCEPTION's object finder and calibrator around the believed pose, and
send a point or line fix.
"""

from __future__ import annotations

import logging

from eddie.landmark_matching.landmark_matching import fix_message, landmark_fix
from eddie.modules.sensing import Belief, capture_frame, objects_in_view
from eddie.modules.switched import Switch, run_switched
from eddie.toolkit.module import Module
from modules.map_navigator import MapData
from modules.perception import PerceptionPipeline, ResolutionTable, colored_range_image
from modules.perception.monitor import SENSORS

__all__ = ["LandmarkMatching"]

log = logging.getLogger("eddie.landmark_matching.landmark_matching")

#: a match may use a frame up to this old [s sim]: one the simulator rendered for road following (5 frames/s)
#: serves, so an instant is rendered once (issue 39); the fix is of the pose at the frame's own stamp
SHARED_FRAME_AGE_S = 0.2


class LandmarkMatching:
    """The landmark matching loop on one module endpoint."""

    def __init__(self, m: Module, map_data: MapData, *, vehicle: str, start: tuple[float, float, float],
                 awake: bool = True, period_s: float = 2.0) -> None:
        self.m = m
        self.map = map_data
        self.switch = Switch(awake)
        self.belief = Belief(m, start)
        self.pipeline = PerceptionPipeline(ResolutionTable(SENSORS[vehicle]))
        self.period_s = period_s

    async def cycle(self) -> str:
        """Match one frame; send the fix if there is one."""
        frame = await capture_frame(self.m, max_age_s=SHARED_FRAME_AGE_S)
        poses = await self.belief.at_capture(frame.stamp)
        if poses is None:
            return "no controller pose at the capture"
        local, prior = poses
        fix, why = landmark_fix(self.pipeline, colored_range_image(frame), objects_in_view(self.map, tuple(prior)), tuple(prior))
        if fix is None:
            return why
        msg = fix_message(fix, tuple(local), "landmark_matching")
        await self.m.send("navigator", msg)
        return f"{fix.kind} fix sent ({fix.n_used} observations)"

    async def run(self) -> None:
        """Sleep until woken, then match a frame every `period_s` [s] sim while awake."""
        await run_switched(self.m, self.switch, self.cycle, period_s=self.period_s)
