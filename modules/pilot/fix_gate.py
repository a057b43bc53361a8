"""The fix gate: a position fix far outside the estimate's uncertainty is refused, and refusals in a row doubt the estimate.

The PILOT (CODGER) and the navigator (EDDIE) keep the vehicle position with the same `PoseFilter`
and the same gate, so the two architectures run the same algorithm. A fix whose innovation's squared
Mahalanobis distance exceeds `FIX_GATE` (χ² with 3 degrees of freedom at 99.9 %) is refused and
counted, not applied: a landmark matched to the wrong object, or a road edge seen at a bend, must
not turn the estimate. Refusals in a row mean the estimate, not the fixes, is wrong (an overconfident
filter drifting away would refuse every true fix after it): from the `REFUSALS_TO_DOUBT`-th on, each
refusal doubles the covariance, up to `DOUBT_SIGMA_XY` [m] / `DOUBT_SIGMA_YAW` [rad], so consistent
fixes get in again while a grossly wrong one stays out.

Only refusals from places apart doubt: after a doubling, the next one waits until the vehicle has moved
`DOUBT_STEP_M` [m] (in `world`, by the estimate). Many frames of one scene are one piece of evidence: a
vehicle creeping up to a crossing at 0.5 m/s sent 2–6 m-off fixes of the same wrong match several times a
second, and when each refusal doubled, a confident estimate opened to the wrong fix within 0.6 s (EDDIE on
generated suburb_4, issue 37: the estimate went 5.8 m and 13° off and the vehicle left the road).
"""

from __future__ import annotations

import math

import numpy as np

from modules.pilot.kalman import PoseFilter

__all__ = ["FixGate", "FIX_GATE", "REFUSALS_TO_DOUBT", "DOUBT_SIGMA_XY", "DOUBT_SIGMA_YAW", "DOUBT_STEP_M"]

#: A fix whose innovation's squared Mahalanobis distance exceeds this is refused (χ², 3 dof, 99.9 %).
FIX_GATE = 16.27
#: Refused fixes in a row after which each further refusal doubles the covariance.
REFUSALS_TO_DOUBT = 2
#: The doubt's ceiling: standard deviations [m], [rad] the covariance is not inflated beyond.
DOUBT_SIGMA_XY = 3.0
DOUBT_SIGMA_YAW = math.radians(10.0)
#: How far [m] the vehicle moves between two doublings: refusals from one place doubt once.
DOUBT_STEP_M = 0.7


class FixGate:
    """Count the fixes a gated `PoseFilter` used and refused, and doubt it after refusals in a row."""

    def __init__(self, *, refusals_to_doubt: int = REFUSALS_TO_DOUBT, doubt_sigma_xy: float = DOUBT_SIGMA_XY,
                 doubt_sigma_yaw: float = DOUBT_SIGMA_YAW, doubt_step_m: float = DOUBT_STEP_M) -> None:
        self.refusals_to_doubt = refusals_to_doubt
        self.doubt_sigma_xy = doubt_sigma_xy
        self.doubt_sigma_yaw = doubt_sigma_yaw
        self.doubt_step_m = doubt_step_m
        self.used = 0
        self.refused = 0
        self.refused_in_row = 0
        #: doublings since the last used fix
        self.doubled = 0
        self._doubted_at: np.ndarray | None = None

    def on_used(self) -> None:
        """A fix passed the gate and was applied."""
        self.used += 1
        self.refused_in_row = 0
        self.doubled = 0
        self._doubted_at = None

    def on_refused(self, filt: PoseFilter) -> None:
        """A fix was refused by `filt`'s gate: count it, and doubt `filt` from the `refusals_to_doubt`-th in a row on.

        A doubling waits until the estimate is `doubt_step_m` [m] from where the previous one happened.
        """
        self.refused += 1
        self.refused_in_row += 1
        if self.refused_in_row < self.refusals_to_doubt:
            return
        here = np.asarray(filt.pose[:2], dtype=np.float64)
        if self._doubted_at is not None and float(np.hypot(*(here - self._doubted_at))) < self.doubt_step_m:
            return
        filt.inflate(2.0, self.doubt_sigma_xy, self.doubt_sigma_yaw)
        self.doubled += 1
        self._doubted_at = here
