"""Fault injection: the same four faults for both architectures, injected at a sim time by the launcher.

`kill-perception` SIGKILLs the perception module and starts it again; `kill-central` does the same
to the central piece (CODGER: the blackboard node; EDDIE: the map manager); `wedge` SIGSTOPs the
module that plans the vehicle's local paths for `WEDGE_S` [s] sim, then SIGCONTs it;
`position-jump` moves the position estimate by `JUMP_M` [m] (CODGER: world←local posted on the
blackboard from the launcher's own client, as a position fix would move it; EDDIE: unavailable
until its navigator takes fixes from outside). A fault whose target the run lacks is recorded as not
injected, with the reason — never faked.
"""

from __future__ import annotations

import asyncio
import math
import signal
from typing import Literal, Optional

from pydantic import BaseModel, ConfigDict, Field

from sidewalk.compare.errors import CompareError
from sidewalk.run_record import FaultEvent

__all__ = ["FaultName", "FaultSpec", "FAULTS", "TARGETS", "WEDGE_S", "JUMP_M", "parse_fault", "inject_fault"]

FaultName = Literal["kill-perception", "position-jump", "kill-central", "wedge"]

#: Every fault, in the order the comparison runs them.
FAULTS: tuple[str, ...] = ("kill-perception", "position-jump", "kill-central", "wedge")

#: How long a wedged module stays stopped [s] sim.
WEDGE_S = 5.0

#: How far the position jump moves the estimate [m].
JUMP_M = 2.0

#: architecture → fault → the process it hits (None: the architecture has no such part yet).
TARGETS: dict[str, dict[str, Optional[str]]] = {
    "codger": {"kill-perception": "perception", "kill-central": "blackboard", "wedge": "pilot", "position-jump": "blackboard"},
    "eddie": {"kill-perception": "vision", "kill-central": "map_manager", "wedge": "vision", "position-jump": None},
}


class FaultSpec(BaseModel):
    """One fault to inject: its name and when [s] sim after the mission's submission."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: FaultName
    at_s: float = Field(ge=0.0)

    def flag(self) -> str:
        """Return the `sidewalk run --fault` value."""
        return f"{self.name}@{self.at_s:g}"


def parse_fault(text: str) -> FaultSpec:
    """Parse NAME@T (T [s] sim after submission); raise CompareError naming the flag."""
    name, sep, at = text.partition("@")
    if name not in FAULTS:
        raise CompareError(f"--fault {text!r}: unknown fault {name!r}; known: {', '.join(FAULTS)}")
    try:
        t = float(at) if sep else math.nan
    except ValueError:
        t = math.nan
    if not (math.isfinite(t) and t >= 0):
        raise CompareError(f"--fault {text!r}: wants NAME@SECONDS with seconds ≥ 0 (sim, after submission)")
    return FaultSpec(name=name, at_s=t)  # type: ignore[arg-type]


async def _wait_sim(system, until: float, *, timeout_wall: float) -> None:  # noqa: ANN001 - SystemRun
    """Return once the sim clock heard reached `until` [s] (or `timeout_wall` [s] passed)."""
    loop = asyncio.get_running_loop()
    end = loop.time() + timeout_wall
    while system.stamps()[1] < until and loop.time() < end:
        await asyncio.sleep(0.02)  # polling the recorder's clock: the sim clock has no event to wait on


async def inject_fault(system, spec: FaultSpec, arch: str) -> FaultEvent:  # noqa: ANN001 - sidewalk.system.SystemRun
    """Inject one fault into a running system now; return what was done, with sim stamps [s]."""
    target = TARGETS.get(arch, {}).get(spec.name)
    at = system.stamps()[1]
    if target is None or target not in system.plans:
        why = f"{arch} has no part for {spec.name}" if target is None else f"the run has no {target} process"
        return FaultEvent(name=spec.name, injected=False, at_sim_s=at, detail=why)
    if spec.name in ("kill-perception", "kill-central"):
        await system.kill(target)
        killed = system.stamps()[1]
        await system.restart(target)
        return FaultEvent(name=spec.name, target=target, injected=True, at_sim_s=killed, restored_sim_s=system.stamps()[1],
                          detail=f"{target} SIGKILLed and started again")
    if spec.name == "wedge":
        proc = system.sup.procs[target].proc
        proc.send_signal(signal.SIGSTOP)
        try:
            await _wait_sim(system, at + WEDGE_S, timeout_wall=WEDGE_S * 4 + 10)
        finally:
            proc.send_signal(signal.SIGCONT)
        return FaultEvent(name=spec.name, target=target, injected=True, at_sim_s=at, restored_sim_s=system.stamps()[1],
                          detail=f"{target} SIGSTOPped for {WEDGE_S:g} s sim, then SIGCONTed")
    # position-jump (CODGER): world←local moved JUMP_M to the vehicle's left, posted like the PILOT's correction
    from wire.se2 import Pose2D

    wl = await system.bb.lookup_pose(parent="world", child="local", stamp=None)
    heading = (await system.bb.lookup_pose(parent="world", child="vehicle", stamp=None)).yaw
    moved = Pose2D(x=wl.x - JUMP_M * math.sin(heading), y=wl.y + JUMP_M * math.cos(heading), yaw=wl.yaw)
    await system.bb.post_pose(parent="world", child="local", pose=moved, stamp=at, hold=None)
    return FaultEvent(name=spec.name, target="world←local", injected=True, at_sim_s=at, restored_sim_s=None,
                      detail=f"world←local posted {JUMP_M:g} m off on the blackboard")
