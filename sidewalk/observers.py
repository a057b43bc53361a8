"""The processes of a run that only watch it: the recorder (always) and the NAVIGATION MONITOR (`--monitor`).

They start right after the blackboard node (the recorder monitors its tokens; under EDDIE right after
the router) and before the simulator and the modules, so that they see the run from its first message;
they stop after them. Every process is a client of the router (`wire.flags`), and a client's session
opens with the router's subscriptions already declared to it: a module's very first message reaches
the recorder (as peers, the first could leave before a new peer had learnt of the recorder).
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

from sidewalk.supervisor import ProcessPlan

__all__ = ["observer_plans", "RECORDING_NAME", "monitor_url"]

#: The recording's file name in a run's output directory (beside report.json).
RECORDING_NAME = "run.mcap"


def monitor_url(port: int, host: str = "127.0.0.1") -> str:
    """Return the address of the monitor page."""
    return f"http://{host}:{port}/"


def observer_plans(out: Path, zflags: tuple[str, ...], *, record: bool = True, monitor_port: Optional[int] = None,
                   arch: str = "codger") -> list[ProcessPlan]:
    """Return the recorder's (writing `out`/run.mcap) and, with a port, the monitor's process plans."""
    plans = []
    if record:
        plans.append(ProcessPlan("recorder", ("-m", "sidewalk", "record", "--out", str(Path(out) / RECORDING_NAME),
                                              "--arch", arch, *zflags)))
    if monitor_port is not None:
        plans.append(ProcessPlan("monitor", ("-m", "sidewalk", "monitor", "--port", str(monitor_port), "--arch", arch, *zflags)))
    return plans
