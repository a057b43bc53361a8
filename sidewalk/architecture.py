"""The architecture seam of `sidewalk run`: what the launcher asks of CODGER and of EDDIE, and nothing else.

An architecture says what is prepared before anything starts (`prepare`: nothing for CODGER; EDDIE's
mission compiled into the annotated map kept for the record), which processes run (`plans`, in start
order, each `python -m sidewalk up NAME`), and which observer follows the run (`system`: a `SystemRun`,
which reads the estimate and the mission statuses — through the blackboard for CODGER, from EDDIE's
streams for EDDIE). The launcher (`sidewalk.launcher`) is the same for both; `sidewalk compare` counts
each architecture's glue from its plans' entry points.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Protocol

from sidewalk.run_setup import LaunchError, RunConfig, RunSetup
from sidewalk.supervisor import ProcessPlan
from sidewalk.system import SystemRun

__all__ = ["Architecture", "ARCHITECTURES", "architecture"]

#: The architectures `sidewalk run --arch` knows, by name.
ARCHITECTURES = ("codger", "eddie")


class Architecture(Protocol):
    """One architecture behind the seam: preparation, process plans, observer."""

    name: str

    def prepare(self, setup: RunSetup, out: Path) -> Any:
        """Prepare what the processes need before they start (raise LaunchError naming what is wrong); return it."""

    def plans(self, cfg: RunConfig, setup: RunSetup, ns: str, endpoint: str, prepared: Any) -> list[ProcessPlan]:
        """Return the run's processes in start order."""

    def system(self, plans: list[ProcessPlan], *, ns: str, endpoint: str, log_dir: Path, prepared: Any, secure: Path | None,
               lockstep: bool) -> SystemRun:
        """Return the observer that starts the plans and follows the run."""


def architecture(name: str) -> Architecture:
    """Return architecture `name` (LaunchError for one not in ARCHITECTURES)."""
    if name == "codger":
        from sidewalk.codger_run import CodgerArchitecture

        return CodgerArchitecture()
    if name == "eddie":
        from sidewalk.eddie_run import EddieArchitecture

        return EddieArchitecture()
    raise LaunchError(f"--arch {name!r}: expected one of {', '.join(ARCHITECTURES)}")
