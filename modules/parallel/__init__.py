"""Parallel vision (Navlab 1990 ch. 4, the Warp on the Navlab): image operators over worker processes.

One small facility any pipeline can use: a `VisionPool` of N workers (the caller and N − 1 spawned
processes), frames in shared memory (`SharedFrame`), input partitioning into stripes that overlap
by the operator's width (`partition`), and `StripeOp`, the contract an operator meets to be split
(a module-level function over a stripe's halo, the overlap it reads, how its arrays are cut).
PERCEPTION's colored-range stages and SCARF use it; with one worker everything runs in the caller,
exactly as before. For a cycle that does not split into stripes, `run_frames` partitions a run of
frames instead (`frames`): whole frames among the workers, the stage carrying state in the caller.
"""

from modules.parallel.errors import ParallelError, StripePlanError, WorkerError
from modules.parallel.frames import Frame, FrameStages, run_frames
from modules.parallel.pool import VisionPool
from modules.parallel.shared_frame import ArrayRef, SharedFrame
from modules.parallel.stripe_op import StripeOp, run_stripe
from modules.parallel.stripes import PIXEL_QUANTUM, Stripe, aligned_for, partition

__all__ = [
    "ParallelError", "StripePlanError", "WorkerError",
    "VisionPool", "ArrayRef", "SharedFrame", "StripeOp", "run_stripe",
    "PIXEL_QUANTUM", "Stripe", "aligned_for", "partition",
    "Frame", "FrameStages", "run_frames",
]
