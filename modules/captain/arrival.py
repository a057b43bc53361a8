"""Arrival is claimed at rest: a step that ends in a stop is done once the vehicle stands still, not as it reaches its goal.

The robot's own rule, from its own odometry (the `local` pose, which never jumps with a position
fix): at rest when it moved slower than `REST_SPEED_MPS` [m/s] and turned slower than
`REST_YAW_RATE` [rad/s] for `REST_HOLD_S` [s sim] on end. Both architectures use it: CODGER's PILOT
before it reports the exit of a segment that stops there, EDDIE's mission service before it ends a
step that stops (a `stop` or `wait` trigger, and the mission's last step). A vehicle that has not come
to rest `REST_TIMEOUT_S` [s sim] after its arrival is claimed anyway, and the claim says so.
"""

from __future__ import annotations

import math

__all__ = ["RestDetector", "REST_SPEED_MPS", "REST_YAW_RATE", "REST_HOLD_S", "REST_TIMEOUT_S"]

#: slower than this [m/s] is standing still
REST_SPEED_MPS = 0.05
#: turning slower than this [rad/s] (a skid-steer vehicle turns on the spot) is standing still
REST_YAW_RATE = 0.02
#: standing still this long [s sim] is at rest
REST_HOLD_S = 1.0
#: an arrival not at rest this long after it [s sim] is claimed anyway
REST_TIMEOUT_S = 30.0


class RestDetector:
    """Tell from odometry poses (`local`, fed in sim-time order) whether the vehicle is at rest; pure."""

    def __init__(self, *, speed_mps: float = REST_SPEED_MPS, yaw_rate: float = REST_YAW_RATE, hold_s: float = REST_HOLD_S) -> None:
        self.speed_mps, self.yaw_rate, self.hold_s = speed_mps, yaw_rate, hold_s
        self._last: tuple[float, float, float, float] | None = None
        #: since when [s sim] the vehicle has stood still (None: it moves, or nothing was fed yet)
        self.still_since: float | None = None

    def feed(self, t: float, x: float, y: float, yaw: float) -> None:
        """Take the odometry pose (x, y [m], yaw [rad] in `local`) at sim time `t` [s]."""
        last = self._last
        if last is not None and t <= last[0]:
            return  # the same period again (or an older one): no new motion to judge
        self._last = (t, x, y, yaw)
        if last is None:
            return
        dt = t - last[0]
        turned = abs(math.remainder(yaw - last[3], math.tau))
        moving = math.hypot(x - last[1], y - last[2]) > self.speed_mps * dt or turned > self.yaw_rate * dt
        if moving:
            self.still_since = None
        elif self.still_since is None:
            self.still_since = last[0]

    def at_rest(self, t: float) -> bool:
        """Return whether the vehicle has stood still for `hold_s` at sim time `t` [s]."""
        return self.still_since is not None and t - self.still_since >= self.hold_s
