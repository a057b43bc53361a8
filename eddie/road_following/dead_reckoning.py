"""Dead reckoning through an intersection (seed: Navlab 1990 §2.5, the trigger "dead reckon through the
intersection"): the path road following sent the controller while vision sleeps, kept until vision resumes.

The controller forgets it when it is restarted, and drops it when obstacle stop's hold is lifted (a stop
clears the tracked path); either way nobody holds the controller and it is idle or stopped, while road
following, asleep, would send nothing until the exit's gate wakes it — which the vehicle, at rest, never
reaches (issue 36's grid: EDDIE's AMV in lock-step stood until the mission failed after its integrated
controller was killed). So the rest of the path, from the vehicle's pose on, is sent again then.
"""

from __future__ import annotations

import numpy as np

from eddie.messages.controller import ControllerState, DeadReckon
from modules.pilot.polyline import PathLine

__all__ = ["DeadReckoning"]

#: a path shorter than this [m] ahead of the vehicle is done: nothing is sent again
DONE_WITHIN_M = 0.5


class DeadReckoning:
    """The dead-reckoned path a client sent (`local` [m]), and whether to send its rest again."""

    def __init__(self, client: str) -> None:
        self.client = client
        self.command: DeadReckon | None = None
        self._asked = False

    def sent(self, cmd: DeadReckon) -> None:
        """Keep `cmd` (with points), just sent to the controller."""
        self.command, self._asked = cmd, False

    def ended(self) -> None:
        """Vision resumed (or the mission ended): nothing to keep."""
        self.command, self._asked = None, False

    def again(self, st: ControllerState) -> DeadReckon | None:
        """Return the rest of the path to send again, given the controller's state `st`, or None.

        Only when nobody holds the controller and it drives nothing; once per time it lost the path
        (the controller's next state with this client holding it asks afresh).
        """
        cmd = self.command
        if cmd is None or cmd.points is None:
            return None
        if st.client == self.client:
            self._asked = False
            return None
        if st.client or st.mode not in ("idle", "stopped") or self._asked:
            return None
        rest = _rest(np.asarray(cmd.points, dtype=np.float64), np.array([st.x, st.y]))
        if rest is None:
            self.ended()
            return None
        self._asked = True
        return cmd.model_copy(update={"points": tuple((float(x), float(y)) for x, y in rest)})


def _rest(points: np.ndarray, xy: np.ndarray) -> np.ndarray | None:
    """Return the polyline `points` (N, 2) [m] from the point on it nearest `xy` on, or None when less than `DONE_WITHIN_M` is left."""
    line = PathLine.from_points(points)
    s, _ = line.project(xy)
    return line.slice(s, line.length) if line.length - s >= DONE_WITHIN_M else None
