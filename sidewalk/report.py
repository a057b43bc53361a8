"""The run report: `report.json` (schema below) and `trajectory.png`."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Optional, Sequence

import numpy as np
from pydantic import BaseModel, ConfigDict

__all__ = [
    "StepReport",
    "ErrorSummary",
    "BlackboardUsage",
    "RunReport",
    "write_report",
    "plot_trajectory",
    "KIND_COLOURS",
]


class StepReport(BaseModel):
    """One mission step: its name, outcome, reason and when it ended [s sim time]."""

    model_config = ConfigDict(frozen=True)

    name: str
    success: bool
    sim_time_s: Optional[float] = None
    reason: str = ""


class ErrorSummary(BaseModel):
    """An error series summarised [m]."""

    model_config = ConfigDict(frozen=True)

    rms: Optional[float] = None
    max: Optional[float] = None
    final: Optional[float] = None


class BlackboardUsage(BaseModel):
    """What the blackboard node counted during the run."""

    model_config = ConfigDict(frozen=True, extra="allow")

    posts: int = 0
    retrieves: int = 0
    monitors: int = 0
    bytes: int = 0


class RunReport(BaseModel):
    """Everything `sidewalk run` measured; written as `report.json`."""

    model_config = ConfigDict(frozen=True)

    success: bool
    reason: str = ""
    mission: str
    world: str
    vehicle: str
    seed: int
    perception: bool
    pose_error: tuple[float, float] = (0.0, 0.0)
    map_error_m: float = 0.0
    sim_time_s: float
    wall_time_s: float
    rtf_requested: float
    rtf_achieved: float
    distance_m: float
    steps: list[StepReport]
    cross_track_error_m: ErrorSummary
    position_error_m: ErrorSummary
    goal_error_m: Optional[float] = None
    collisions: int
    off_path_s: float
    sim_events: dict[str, int] = {}
    blackboard: BlackboardUsage
    modules: dict[str, float]
    exit_codes: dict[str, Optional[int]] = {}


#: Fill colours for world object kinds on the trajectory plot.
KIND_COLOURS = {
    "road": "#9a9a9a",
    "sidewalk": "#c8c8c8",
    "intersection": "#b8b8b8",
    "driveway": "#b0a898",
    "grass": "#b5d99c",
    "slope": "#a8a8c8",
    "stairs": "#8c8ca8",
    "building": "#8b6f5a",
    "tree": "#3d7a35",
    "mailbox": "#2455a4",
}


def write_report(report: RunReport, out_dir: Path) -> Path:
    """Write `report.json` into out_dir and return its path."""
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "report.json"
    path.write_text(json.dumps(report.model_dump(mode="json"), indent=2, sort_keys=False) + "\n")
    return path


def plot_trajectory(
    path: Path,
    *,
    objects: Sequence[tuple[str, np.ndarray]],
    route: Optional[np.ndarray],
    truth: Optional[np.ndarray],
    estimate: Optional[np.ndarray],
    title: str,
    margin_m: float = 20.0,
) -> Path:
    """Draw the map, planned route, true and estimated paths (all `world` [m]) into a PNG.

    The view spans the route and both paths plus `margin_m` [m].
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon as MplPolygon

    fig, ax = plt.subplots(figsize=(9, 9), dpi=110)
    order = {"grass": 0, "road": 1, "driveway": 1, "sidewalk": 2, "intersection": 2, "slope": 3, "stairs": 3}
    for kind, coords in sorted(objects, key=lambda o: order.get(o[0], 5)):
        coords = np.asarray(coords, dtype=float)
        colour = KIND_COLOURS.get(kind, "#d0d0d0")
        if coords.ndim == 2 and len(coords) >= 3:
            ax.add_patch(MplPolygon(coords, closed=True, facecolor=colour, edgecolor="#666666", lw=0.3))
        elif coords.size >= 2:
            c = coords.reshape(-1)[:2]
            ax.plot(c[0], c[1], "o", color=colour, ms=4)
    if route is not None and len(route) >= 2:
        ax.plot(route[:, 0], route[:, 1], "--", color="#e08a00", lw=1.5, label="planned route")
    if truth is not None and len(truth) >= 2:
        ax.plot(truth[:, 0], truth[:, 1], "-", color="#c01818", lw=1.6, label="true path")
        ax.plot(truth[0, 0], truth[0, 1], "s", color="#c01818", ms=6)
    if estimate is not None and len(estimate) >= 2:
        ax.plot(estimate[:, 0], estimate[:, 1], "-", color="#1840c0", lw=1.0, label="estimated path")
    ax.set_aspect("equal")
    ax.autoscale_view()
    shown = [a for a in (route, truth, estimate) if a is not None and len(a)]
    if shown:
        pts = np.concatenate([np.asarray(a, dtype=float)[:, :2] for a in shown])
        (x0, y0), (x1, y1) = pts.min(axis=0) - margin_m, pts.max(axis=0) + margin_m
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
    ax.set_xlabel("x [m] (world)")
    ax.set_ylabel("y [m] (world)")
    ax.set_title(title)
    ax.legend(loc="best", fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return path
