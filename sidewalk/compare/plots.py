"""The comparison's PNG plots: per-run figures by architecture, and the speed sweep."""

from __future__ import annotations

from pathlib import Path

from sidewalk.compare.comparison import Comparison

__all__ = ["plot_comparison", "PLOTTED"]

#: The measures drawn as per-run dots by architecture: field → axis label. A run without a report is drawn as a
#: failure (✕ at 0) in `success` and counted under its architecture's name in every panel.
PLOTTED = {
    "success": "success by truth (✕: no report)",
    "goal_error_m": "goal error [m]",
    "mission_time_s": "mission time [s sim]",
    "position_error_rms_m": "position error rms [m]",
    "cross_track_error_rms_m": "cross-track error rms [m]",
    "sense_to_act_ms_p50": "sense-to-act p50 [ms sim]",
    "messages_per_s": "messages out / s sim",
    "cpu_s": "CPU [s]",
}


def plot_comparison(c: Comparison, out: Path) -> list[Path]:
    """Draw `measures.png` (and `speed_sweep.png` with a sweep) into `out`; return the files."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    archs = list(c.summary)
    every = [r for r in c.runs if r.fault is None and r.max_speed is None]
    base = [r for r in every if r.measures is not None]
    lost = {a: [r for r in every if r.architecture == a and r.measures is None] for a in archs}
    fig, axes = plt.subplots(2, 4, figsize=(15, 7), dpi=100)
    missions = list(dict.fromkeys(r.mission for r in every))
    markers = "os^Dv<>"
    ticks = [a + (f"\n{len(lost[a])} failed, no report" if lost[a] else "") for a in archs]
    for ax, (key, label) in zip(axes.flat, PLOTTED.items()):
        for i, a in enumerate(archs):
            for j, m in enumerate(missions):
                x = i + 0.1 * (j - (len(missions) - 1) / 2)
                ys = [getattr(r.measures, key) for r in base if r.architecture == a and r.mission == m]
                ys = [y for y in ys if y is not None]
                ax.plot([x] * len(ys), ys, markers[j % len(markers)], alpha=0.8, label=m if i == 0 else None)
                n_lost = sum(r.mission == m for r in lost[a])
                if key == "success" and n_lost:
                    ax.plot([x] * n_lost, [0.0] * n_lost, "x", color="#c01818", ms=9, mew=2)
        ax.set_xticks(range(len(archs)), ticks)
        ax.set_xlim(-0.6, len(archs) - 0.4)
        ax.set_title(label, fontsize=9)
    axes.flat[0].legend(fontsize=7)
    mode = "lock-step" if c.config.lockstep else f"real time, RTF {c.config.rtf:g}"
    fig.suptitle(f"per run, by architecture (seeds {', '.join(map(str, c.config.seeds))}, {mode})")
    fig.tight_layout()
    files = [out / "measures.png"]
    fig.savefig(files[0])
    plt.close(fig)
    if c.speed_sweep:
        fig, ax = plt.subplots(figsize=(6, 4), dpi=100)
        for a in archs:
            pts = [p for p in c.speed_sweep if p.architecture == a]
            ax.plot([p.max_speed for p in pts], [p.successes / max(1, p.runs) for p in pts], "o-", label=a)
        ax.set_xlabel("speed cap [m/s]")
        ax.set_ylabel("success rate (truth)")
        ax.set_ylim(-0.05, 1.05)
        ax.legend()
        fig.tight_layout()
        files.append(out / "speed_sweep.png")
        fig.savefig(files[-1])
        plt.close(fig)
    return files
