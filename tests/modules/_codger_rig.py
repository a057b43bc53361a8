"""Start a CODGER rig for end-to-end tests: blackboard node, simulator, HELM and a PILOT that drives nothing."""

from __future__ import annotations

import math
import os
import subprocess
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

from blackboard.testing import NodeProcess, start_node
from tests.modules._procs import SPAWN_TIMEOUT_S, spawn, stop

__all__ = ["CodgerRig", "codger_rig"]

Pose = tuple[float, float, float]  # x [m], y [m], heading [rad], world frame


@dataclass
class CodgerRig:
    """A running node and its processes; `start` adds one more module on the same namespace."""

    node: NodeProcess
    conn: list[str]
    procs: list[subprocess.Popen] = field(default_factory=list)
    codes: list[int] = field(default_factory=list)

    def start(self, args: list[str], ready: str, timeout: float = SPAWN_TIMEOUT_S) -> subprocess.Popen:
        """Start `python -m …args` connected to the rig's node; return once it printed `ready`."""
        p = spawn([sys.executable, *args, *self.conn], ready, timeout=timeout)
        self.procs.append(p)
        return p


@contextmanager
def codger_rig(tag: str, *, world: str, truth: Pose, pilot_pose: Pose, seed: int,
               sim_timeout: float = SPAWN_TIMEOUT_S) -> Iterator[CodgerRig]:
    """Start node, simulator (Navlab at `truth`, RTF 2), HELM and a PILOT told `pilot_pose` with perception off.

    On exit every process is stopped (last started first) and the exit codes land in `rig.codes`; the caller
    asserts them after the block so that a failed assertion inside it is not hidden.
    """
    node = start_node(namespace=f"{tag}{os.getpid()}", types=("modules.vocabulary",))
    rig = CodgerRig(node=node, conn=["--ns", node.namespace, "--connect", node.endpoint])
    try:
        rig.start(["-m", "sidewalk", "sim", "serve", "--world", world, "--vehicle", "navlab",
                   f"--start={truth[0]},{truth[1]},{math.degrees(truth[2])}", "--rtf", "2", "--seed", str(seed)],
                  "ready sim", timeout=sim_timeout)
        rig.start(["-m", "codger.helm", "--vehicle", "navlab"], "SIDEWALK-READY helm")
        rig.start(["-m", "codger.pilot", "--vehicle", "navlab", "--perception", "off",
                   "--start-pose", ",".join(str(v) for v in pilot_pose)], "SIDEWALK-READY pilot")
        yield rig
    finally:
        rig.codes.extend(stop(p) for p in reversed(rig.procs))
        node.stop()
