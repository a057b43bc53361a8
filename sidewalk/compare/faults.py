"""Fault injection: the same four faults for both architectures, injected at a sim time by the launcher.

`kill-perception` SIGKILLs the perception module and starts it again; `kill-central` does the same
to the central piece (CODGER: the blackboard node; EDDIE: the map manager); `wedge` SIGSTOPs the
module that plans the vehicle's local paths (CODGER: the PILOT; EDDIE: road following) for `WEDGE_S` [s] sim, then SIGCONTs it;
`position-jump` moves the position estimate by `JUMP_M` [m] (CODGER: the launcher's own blackboard
client posts a perception result for a driving unit PERCEPTION has not answered yet, carrying a
tight point fix `JUMP_M` to the left of the PILOT's estimate — the PILOT takes it like any fix;
EDDIE: the same tight point fix sent to the navigator's inbox, as landmark matching sends fixes). A fault whose target the run lacks is recorded as not
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

#: How long [s] wall the CODGER jump waits for a driving unit PERCEPTION has not answered yet.
OPEN_UNIT_WAIT_S = 30.0

#: architecture → fault → the process it hits (None: the architecture has no such part yet).
TARGETS: dict[str, dict[str, Optional[str]]] = {
    "codger": {"kill-perception": "perception", "kill-central": "blackboard", "wedge": "pilot", "position-jump": "pilot"},
    "eddie": {"kill-perception": "road_following", "kill-central": "map_manager", "wedge": "road_following", "position-jump": "navigator"},
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
    if arch == "eddie":
        return await _eddie_jump(system, at)
    # position-jump (CODGER): a fix JUMP_M to the left of the PILOT's estimate, for a driving unit PERCEPTION has not answered yet
    return await _codger_jump(system, at)


async def _eddie_jump(system, at: float) -> FaultEvent:  # noqa: ANN001 - the EDDIE system run
    """Send EDDIE's navigator a tight point fix `JUMP_M` [m] left of its estimate (world), as landmark matching sends fixes."""
    from eddie.messages.controller import Position, PositionQuery
    from eddie.messages.navigator import LocalPose, PointFixMessage, WorldFromLocal, WorldFromLocalQuery
    from eddie.toolkit import Module

    async with Module("fault_injector", system.net) as m:
        loop = asyncio.get_running_loop()
        end = loop.time() + 10.0
        while True:
            try:
                pos = await m.request("controller", "position", PositionQuery(), reply_type=Position, timeout=3.0)
                wl = await m.request("navigator", "world_from_local", WorldFromLocalQuery(), reply_type=WorldFromLocal, timeout=3.0)
                break
            except Exception as exc:  # a fresh session may not see the services yet: ask again until the deadline
                if loop.time() > end:
                    return FaultEvent(name="position-jump", injected=False, at_sim_s=at, detail=f"no position to jump from: {exc}")
                await asyncio.sleep(0.2)
        c, s = math.cos(wl.yaw), math.sin(wl.yaw)
        x, y, yaw = wl.x + c * pos.x - s * pos.y, wl.y + s * pos.x + c * pos.y, wl.yaw + pos.yaw
        fx, fy = x - JUMP_M * math.sin(yaw), y + JUMP_M * math.cos(yaw)
        await m.send("navigator", PointFixMessage(stamp=pos.stamp, x=fx, y=fy, yaw=yaw, sigma_xy=0.1, sigma_yaw=0.01,
                                                  local=LocalPose(x=pos.x, y=pos.y, yaw=pos.yaw), source="fault-injector"))
    return FaultEvent(name="position-jump", target="navigator", injected=True, at_sim_s=pos.stamp, restored_sim_s=None,
                      detail=f"a fix {JUMP_M:g} m left of the estimate ({x:.2f}, {y:.2f}) sent to the navigator")


async def _codger_jump(system, at: float) -> FaultEvent:  # noqa: ANN001 - SystemRun
    """Post a perception result with a point fix `JUMP_M` [m] left of the PILOT's estimate (world) for the newest open unit."""
    from blackboard import Spec
    from modules.vocabulary import PerceptionResult, PointFix, Pose

    bb = system.bb
    loop = asyncio.get_running_loop()
    end = loop.time() + OPEN_UNIT_WAIT_S
    while True:  # the PILOT posts units ahead of the vehicle: wait for one PERCEPTION has not answered yet
        answered = {t.attrs.unit_id for t in await bb.retrieve(Spec(type="perception_result"))}
        units = sorted((t for t in await bb.retrieve(Spec(type="driving_unit")) if t.attrs.unit_id not in answered),
                       key=lambda t: t.stamp)
        if units:
            break
        if loop.time() > end:
            return FaultEvent(name="position-jump", injected=False, at_sim_s=at,
                              detail=f"no driving unit was waiting for PERCEPTION within {OPEN_UNIT_WAIT_S:g} s")
        await asyncio.sleep(0.05)
    unit = units[-1].attrs
    est = await bb.lookup_pose(parent="world", child="vehicle", stamp=None)
    x = est.x - JUMP_M * math.sin(est.yaw)
    y = est.y + JUMP_M * math.cos(est.yaw)
    now = system.stamps()[1]
    fix = PointFix(pose=Pose(x=x, y=y, yaw=est.yaw), covariance=(0.01, 0.0, 0.0, 0.0, 0.01, 0.0, 0.0, 0.0, 1e-4))
    res = PerceptionResult(unit_id=unit.unit_id, segment_id=unit.segment_id, status="perceived", captured_at=now,
                           sensor="colour", frame="world", fix=fix)
    await bb.post(res, frame="world", geometry=None, stamp=now)
    return FaultEvent(name="position-jump", target="pilot", injected=True, at_sim_s=now, restored_sim_s=None,
                      detail=f"a fix {JUMP_M:g} m left of the estimate ({est.x:.2f}, {est.y:.2f}) posted for unit {unit.unit_id}")
