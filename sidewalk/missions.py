"""Mission names: `campus-tour` is worlds/campus-tour.yaml; a path names its own file.

Apart from the launcher so that `sidewalk submit` resolves a name without loading what runs a mission.
"""

from __future__ import annotations

from pathlib import Path

from wire.mapfile import WORLDS_DIR

__all__ = ["mission_path"]


def mission_path(name_or_path: str | Path) -> Path:
    """Resolve a mission name ("campus-tour") to worlds/<name>.yaml, or return an existing file path."""
    p = Path(name_or_path)
    if p.suffix in (".yaml", ".yml", ".json") or p.exists():
        if not p.exists():
            raise FileNotFoundError(f"mission file {p} does not exist")
        return p
    candidate = WORLDS_DIR / f"{name_or_path}.yaml"
    if not candidate.exists():
        known = sorted(q.stem for q in WORLDS_DIR.glob("*.yaml"))
        raise FileNotFoundError(f"no mission named {str(name_or_path)!r} (looked for {candidate}); known: {known}")
    return candidate
