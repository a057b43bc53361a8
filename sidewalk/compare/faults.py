"""Fault injection: faults in pairs that mean the same thing in both architectures, injected at a sim time by the launcher.

Each fault hits the part of each architecture that plays the same role (`TARGETS`, `ROLES`):
`kill-central` SIGKILLs the central piece every other module depends on (CODGER: the blackboard node;
EDDIE: the integrated controller) and starts it again; `kill-service` does the same to the other shared
service (CODGER has none; EDDIE: the map manager); `kill-perception` to the module that perceives the road
(CODGER: PERCEPTION; EDDIE: road following); `wedge-driver` SIGSTOPs the module that drives the vehicle
(CODGER: the HELM; EDDIE: the controller) and `wedge-planner` the one that plans its local paths (CODGER:
the PILOT; EDDIE: road following), each for `WEDGE_S` [s] sim, then SIGCONTs it;
`position-jump` moves the position estimate by `JUMP_M` [m] to the left: the simulator's odometry
slips (a wheel slip or encoder glitch, `wire.drive.OdometrySlip`), so the estimate of either
architecture, built on that odometry, jumps the same way whatever it does with position fixes (a
false fix would only test the fix gate both share, which refuses it). A fault whose target the run
lacks is recorded as not injected, with the reason — never faked.
"""

from __future__ import annotations

import asyncio
import math
from typing import Literal, Optional

from pydantic import BaseModel, ConfigDict, Field

from sidewalk.compare.errors import CompareError
from sidewalk.run_record import FaultEvent

__all__ = ["FaultName", "FaultSpec", "FAULTS", "RENAMED", "ROLES", "TARGETS", "WEDGE_S", "JUMP_M", "parse_fault", "inject_fault"]

FaultName = Literal["kill-central", "kill-service", "kill-perception", "wedge-driver", "wedge-planner", "position-jump"]

#: Every fault, in the order the comparison runs them.
FAULTS: tuple[str, ...] = ("kill-central", "kill-service", "kill-perception", "wedge-driver", "wedge-planner", "position-jump")

#: Faults by another name before issue 36 (each split or moved so that both architectures lose the same role).
RENAMED: dict[str, str] = {"wedge": "wedge-planner (the old `wedge`) or wedge-driver"}

#: How long a wedged module stays stopped [s] sim.
WEDGE_S = 5.0
#: the most wall time [s] a wedge waits for its 5 s sim: a safeguard against a sim clock that stopped, not a limit a slow
#: lock-step run should meet (at RTF 0.5 beside other work the 5 s sim take 10-20 s wall)
WEDGE_WAIT_WALL_S = 120.0

#: How far the position jump moves the estimate [m].
JUMP_M = 2.0

#: fault → the role it takes away, the same in both architectures.
ROLES: dict[str, str] = {
    "kill-central": "the central piece every module depends on",
    "kill-service": "the other shared service",
    "kill-perception": "road perception",
    "wedge-driver": "the module that drives the vehicle",
    "wedge-planner": "the module that plans the local path",
    "position-jump": "the position estimate (odometry slip)",
}

#: architecture → fault → the process it hits (None: the architecture has no such part).
TARGETS: dict[str, dict[str, Optional[str]]] = {
    "codger": {"kill-central": "blackboard", "kill-service": None, "kill-perception": "perception", "wedge-driver": "helm",
               "wedge-planner": "pilot", "position-jump": "sim"},
    "eddie": {"kill-central": "controller", "kill-service": "map_manager", "kill-perception": "road_following",
              "wedge-driver": "controller", "wedge-planner": "road_following", "position-jump": "sim"},
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
    if name not in FAULTS and name in RENAMED:
        raise CompareError(f"--fault {text!r}: {name!r} was split into pairs that hit the same role in both architectures: "
                           f"use {RENAMED[name]}")
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
    if spec.name.startswith("kill-"):
        await system.kill(target)
        killed = system.stamps()[1]
        await system.restart(target)
        return FaultEvent(name=spec.name, target=target, injected=True, at_sim_s=killed, restored_sim_s=system.stamps()[1],
                          detail=f"{target} SIGKILLed and started again")
    if spec.name.startswith("wedge-"):
        # through the supervisor, which does not restart it meanwhile: 5 s sim can outlast its 10 s wall watch
        system.sup.suspend(target)
        try:
            await _wait_sim(system, at + WEDGE_S, timeout_wall=WEDGE_WAIT_WALL_S)
        finally:
            system.sup.resume(target)
        return FaultEvent(name=spec.name, target=target, injected=True, at_sim_s=at, restored_sim_s=system.stamps()[1],
                          detail=f"{target} SIGSTOPped for {WEDGE_S:g} s sim, then SIGCONTed")
    return await _jump(system)


async def _jump(system) -> FaultEvent:  # noqa: ANN001 - SystemRun or EDDIE's system run
    """Have the simulator's odometry slip `JUMP_M` [m] to the vehicle's left: every estimate on it jumps."""
    from wire.drive import OdometrySlip, encode
    from wire.keys import SimKeys

    system.link.put(SimKeys(system.ns).slip, encode(OdometrySlip(dy=JUMP_M)))
    now = system.stamps()[1]
    return FaultEvent(name="position-jump", target="sim", injected=True, at_sim_s=now, restored_sim_s=None,
                      detail=f"the odometry slipped {JUMP_M:g} m to the vehicle's left")
