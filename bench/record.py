"""What recording a run costs: the recorder's CPU and the MCAP file's size per minute of sim time.

Runs one short mission with the recorder (as every `sidewalk run` does) and, unless told not to, the
same mission without it, and prints one JSON object:

- `recorder_cpu_s_per_sim_min`: the recorder process's CPU (user + system) [s] per recorded sim minute;
- `mcap_bytes_per_sim_min`: the file's size [bytes] per recorded sim minute (`mcap_bytes`, `recorded_sim_s`);
- `messages_per_sim_min`, `channels`: what was recorded;
- `others_cpu_s_with`, `others_cpu_s_without`: the CPU of every other process of the run with and
  without the recorder [s] (what its subscriptions cost the publishers and the blackboard);
- `rtf_with`, `rtf_without`, `success_with`, `success_without`: the missions themselves.

The recorded span is the recording's own (from the simulator's first clock to the end, start-up included).
"""

from __future__ import annotations

import asyncio
import tempfile
from pathlib import Path

__all__ = ["run", "DEFAULT_MISSION"]

_REPO = Path(__file__).resolve().parents[1]
#: The short mission of the end-to-end tests when the checkout has it, else the default campus tour.
DEFAULT_MISSION = str(_REPO / "tests" / "sidewalk" / "data" / "short-hop.yaml") \
    if (_REPO / "tests" / "sidewalk" / "data" / "short-hop.yaml").exists() else "campus-tour"


def _mission(out: Path, mission: str, rtf: float, seed: int, record: bool):
    from sidewalk.launcher import RunConfig, run_mission

    cfg = RunConfig(world="campus", mission=mission, rtf=rtf, seed=seed, out=out, record=record, max_wall_time_s=600.0)
    return asyncio.run(run_mission(cfg))


def run(*, mission: str = DEFAULT_MISSION, rtf: float = 20.0, seed: int = 3, without: bool = True) -> dict:
    """Run the mission with (and without) the recorder; return the figures (see module docstring)."""
    from sidewalk.recording import open_recording

    with tempfile.TemporaryDirectory(prefix="sidewalk-bench-record-") as d:
        out = Path(d) / "with"
        rep = _mission(out, mission, rtf, seed, True)
        path = out / "run.mcap"
        rec = open_recording(path)
        t0, t1 = rec.time_range()
        channels = rec.channels()
        span_min = max(1e-9, (t1 - t0) / 60.0)
        messages = sum(c.count or 0 for c in channels.values())
        cpu = rep.modules["recorder"].cpu_s if "recorder" in rep.modules else 0.0
        result = {
            "mission": Path(mission).stem,
            "rtf_requested": rtf,
            "recorded_sim_s": round(t1 - t0, 2),
            "mission_sim_s": rep.sim_time_s,
            "recorder_cpu_s": round(cpu, 3),
            "recorder_cpu_s_per_sim_min": round(cpu / span_min, 4),
            "mcap_bytes": path.stat().st_size,
            "mcap_bytes_per_sim_min": round(path.stat().st_size / span_min),
            "messages": messages,
            "messages_per_sim_min": round(messages / span_min),
            "channels": len(channels),
            "others_cpu_s_with": round(sum(v.cpu_s for k, v in rep.modules.items() if k != "recorder"), 3),
            "rtf_with": rep.rtf_achieved,
            "success_with": rep.success,
        }
        if without:
            rep0 = _mission(Path(d) / "without", mission, rtf, seed, False)
            result.update({
                "others_cpu_s_without": round(sum(v.cpu_s for v in rep0.modules.values()), 3),
                "rtf_without": rep0.rtf_achieved,
                "success_without": rep0.success,
            })
    return result
