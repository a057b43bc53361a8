"""The navigator's core (seed: Navlab 1990 §2.5): world←local kept from position fixes, with the PILOT's filter.

The PILOT's `PoseFilter` (an EKF on world←vehicle) is the library: it predicts with the controller's
`local` motion and updates with point and line fixes. A fix is related to the present through the
motion since its stamp: the local pose at the fix comes with the fix (or from the navigator's own
short buffer of the controller's states). world←local = world←vehicle ∘ (local←vehicle)⁻¹ changes
only when a fix arrives, never by prediction. Fixes pass the PILOT's gate (`modules.pilot.fix_gate`):
one far outside the estimate's uncertainty is refused and counted, and refusals in a row doubt the estimate.
"""

from __future__ import annotations

import math

import numpy as np

from modules.pilot.fix_gate import DOUBT_SIGMA_XY, DOUBT_SIGMA_YAW, FIX_GATE, REFUSALS_TO_DOUBT, FixGate
from modules.pilot.kalman import EstimatorError, FixRefused, LineFix, PointFix, PoseFilter
from wire.se2 import compose

from eddie.errors import BadMessage
from eddie.messages.navigator import LineFixMessage, PointFixMessage, WorldFromLocal
from eddie.navigator.local_pose_buffer import LocalPoseBuffer

__all__ = ["Navigator", "FIX_GATE", "REFUSALS_TO_DOUBT", "DOUBT_SIGMA_XY", "DOUBT_SIGMA_YAW"]


class Navigator:
    """Keep world←local; start from the vehicle's world pose `start` (x, y, yaw) with std `sigma_xy` [m], `sigma_yaw` [rad]."""

    def __init__(self, start: tuple[float, float, float], *, sigma_xy: float = 1.0, sigma_yaw: float = math.radians(5.0),
                 buffer_s: float = 10.0, gate: float | None = FIX_GATE) -> None:
        self.start = np.asarray(start, dtype=np.float64)
        self.start_cov = np.diag([sigma_xy**2, sigma_xy**2, sigma_yaw**2])
        self.buffer = LocalPoseBuffer(buffer_s)
        self.filter: PoseFilter | None = None
        self.local: np.ndarray | None = None
        self.stamp = 0.0
        self.fix_gate = FixGate()
        self._unusable = 0
        self.gate = gate

    @property
    def fixes_used(self) -> int:
        """Return how many fixes were applied."""
        return self.fix_gate.used

    @property
    def fixes_rejected(self) -> int:
        """Return how many fixes were refused by the gate or unusable."""
        return self.fix_gate.refused + self._unusable

    @property
    def refused_in_row(self) -> int:
        """Return how many fixes in a row the gate refused."""
        return self.fix_gate.refused_in_row

    @property
    def started(self) -> bool:
        """Return whether the first controller pose has arrived (world←local is known)."""
        return self.filter is not None

    def on_passed(self, stamp: float, x: float, y: float, yaw: float) -> None:
        """Keep a local←vehicle pose the controller passed through at `stamp` [s] (a state's trail), for pairing fixes.

        The filter predicts on the states alone: one odometry increment per state, whatever its trail.
        """
        self.buffer.add(stamp, x, y, yaw)

    def on_local(self, stamp: float, x: float, y: float, yaw: float) -> None:
        """Take the controller's local←vehicle pose at `stamp` [s]: start, or predict with the motion since the last."""
        pose = np.array([x, y, yaw], dtype=np.float64)
        self.buffer.add(stamp, x, y, yaw)
        if self.filter is None:
            self.filter = PoseFilter(self.start, self.start_cov, gate=self.gate)
            self.stamp = stamp
        else:
            self.filter.predict(PoseFilter.motion(self.local, pose))
        self.local = pose

    def world_from_local(self) -> WorldFromLocal | None:
        """Return world←local now (None before the first controller pose)."""
        if self.filter is None or self.local is None:
            return None
        w = self.filter.world_from_local(self.local)
        return WorldFromLocal.from_pose2d(w, stamp=self.stamp, fixes_used=self.fixes_used)

    def _local_at(self, msg: PointFixMessage | LineFixMessage) -> np.ndarray:
        if msg.local is not None:
            return msg.local.to_pose2d().as_array()
        pose = self.buffer.at(msg.stamp)
        if pose is None:
            raise BadMessage(f"fix from {msg.source or '?'} at {msg.stamp:.2f} s: no local pose given and none buffered then",
                             sender=msg.source or "?", field="local")
        return pose

    def fix(self, msg: PointFixMessage | LineFixMessage, now: float) -> WorldFromLocal:
        """Apply a fix (at sim time `now` [s]); return the new world←local. Raise BadMessage for an unusable fix."""
        if self.filter is None or self.local is None:
            raise BadMessage("fix before the first controller pose: world←local is not started", sender=msg.source or "?",
                             field="stamp")
        motion = PoseFilter.motion(self._local_at(msg), self.local)
        try:
            if isinstance(msg, PointFixMessage):
                cov = np.diag([msg.sigma_xy**2, msg.sigma_xy**2, msg.sigma_yaw**2])
                self.filter.update_point(PointFix(pose=msg.to_pose2d().as_array(), cov=cov), motion_since=motion)
            else:
                self.filter.update_line(LineFix(point=np.array([msg.x, msg.y]), angle=msg.angle, cross_var=msg.sigma_cross**2,
                                                yaw=msg.yaw, yaw_var=None if msg.sigma_yaw is None else msg.sigma_yaw**2),
                                        motion_since=motion)
        except FixRefused as exc:
            self.fix_gate.on_refused(self.filter)
            raise BadMessage(f"fix from {msg.source or '?'}: {exc} ({self.refused_in_row} in a row)", sender=msg.source or "?",
                             field="sigma") from None
        except EstimatorError as exc:
            self._unusable += 1
            raise BadMessage(f"fix from {msg.source or '?'}: {exc}", sender=msg.source or "?", field="sigma") from None
        self.fix_gate.on_used()
        self.stamp = now
        out = self.world_from_local()
        assert out is not None
        return out

    def world_pose(self, local: np.ndarray) -> np.ndarray:
        """Return the world pose (3,) of a local pose under the current world←local."""
        w = self.world_from_local()
        assert w is not None
        return compose(w.to_pose2d().as_array(), np.asarray(local, dtype=np.float64))
