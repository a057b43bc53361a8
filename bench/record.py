"""What recording and watching a run cost: the recorder's CPU and the MCAP size per sim minute, the monitor's CPU.

Runs one mission (`--arch codger` or `eddie`) with the recorder (as every `sidewalk run` does) and, unless
told not to, the same mission without it; with `monitor`, the first run also serves the NAVIGATION
MONITOR with one page open in Debian's headless chromium (Playwright). Prints one JSON object:

- `recorder_cpu_s_per_sim_min`: the recorder process's CPU (user + system, start-up included) [s] per
  recorded sim minute; `recorder_steady_cpu_s_per_sim_min`: the same between its first and last
  heartbeat of the mission (the heartbeats carry the process's CPU; start-up excluded);
- `mcap_bytes_per_sim_min`: the file's size [bytes] per recorded sim minute (`mcap_bytes`, `recorded_sim_s`);
- `messages_per_sim_min`, `channels`: what was recorded;
- `mission_*`: the same over the mission alone (from its first to its last status on `/mission/events`;
  the simulator runs from the start, so the recording also holds the processes' start-up):
  `mission_window_sim_s`, `mission_messages_per_sim_min`, `mission_mcap_bytes_per_sim_min` (the file's
  size shared out by each message's JSON size: the chunks are zstd-compressed as a whole),
  `mission_recorder_cpu_s_per_sim_min` (from the recorder's heartbeats within the mission);
- `others_cpu_s_with`, `others_cpu_s_without`: the CPU of every other process of the run with and
  without the recorder [s] (what its subscriptions cost the publishers);
- `rtf_with`, `rtf_without`, `success_with`, `success_without`: the missions themselves;
- with `monitor`: `page_frames_per_s` (websocket frames the page received per wall second while
  connected; the server sends at most 20), `monitor_cpu_cores` (the monitor process's CPU per wall
  second over the same window, from its heartbeats: 1.0 is one core busy), `monitor_cpu_s_per_sim_min`,
  `monitor_cpu_s` (whole process) and `page_window_s`.

The recorded span is the recording's own (from the simulator's first clock to the end, start-up included).
"""

from __future__ import annotations

import asyncio
import json
import tempfile
import threading
import time
from pathlib import Path
from typing import Optional

__all__ = ["run", "DEFAULT_MISSION", "PageWatcher"]

_REPO = Path(__file__).resolve().parents[1]
#: The short mission of the end-to-end tests when the checkout has it, else the default campus tour.
DEFAULT_MISSION = str(_REPO / "tests" / "sidewalk" / "data" / "short-hop.yaml") \
    if (_REPO / "tests" / "sidewalk" / "data" / "short-hop.yaml").exists() else "campus-tour"
CHROMIUM = "/usr/bin/chromium"


class PageWatcher:
    """Keep one monitor page open in headless chromium on a thread; sample what it received [wall s, frames]."""

    def __init__(self, url: str, *, period_s: float = 1.0, connect_timeout_s: float = 300.0) -> None:
        self.url = url
        self.period_s = period_s
        self.connect_timeout_s = connect_timeout_s
        self.samples: list[tuple[float, int, int]] = []  # (wall [s], websocket frames, drawn frames)
        self.error: Optional[str] = None
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name="page-watcher", daemon=True)

    def start(self) -> None:
        """Start the browser thread (it waits for the page to answer)."""
        self._thread.start()

    def stop(self) -> None:
        """Close the page and the browser."""
        self._stop.set()
        self._thread.join(60)

    def _run(self) -> None:
        from playwright.sync_api import Error as PlaywrightError, sync_playwright

        try:
            with sync_playwright() as p:
                b = p.chromium.launch(executable_path=CHROMIUM, headless=True, args=["--no-sandbox", "--disable-gpu"])
                try:
                    page = b.new_page(viewport={"width": 1400, "height": 860})
                    end = time.monotonic() + self.connect_timeout_s
                    while not self._stop.is_set():
                        try:
                            page.goto(self.url, timeout=10_000)
                            break
                        except PlaywrightError:  # the monitor is not serving yet
                            if time.monotonic() > end:
                                raise
                            self._stop.wait(0.5)
                    while not self._stop.wait(self.period_s):
                        st = page.evaluate("window.monitorState")
                        if st and st.get("connected"):
                            self.samples.append((time.time(), int(st["messages"]), int(st["frames"])))
                finally:
                    b.close()
        except Exception as exc:  # noqa: BLE001 - reported in the figures, the run goes on
            self.error = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"


def _mission(out: Path, mission: str, rtf: float, seed: int, record: bool, arch: str, perception: bool,
             monitor_port: Optional[int] = None):
    from sidewalk.launcher import RunConfig, run_mission

    cfg = RunConfig(world="campus", mission=mission, rtf=rtf, seed=seed, out=out, record=record, arch=arch,
                    perception=perception, monitor_port=monitor_port, max_wall_time_s=900.0)
    return asyncio.run(run_mission(cfg))


def _usage(msgs: list, *, wall: Optional[tuple[float, float]] = None,
           sim: Optional[tuple[float, float]] = None) -> Optional[tuple[float, float, float]]:
    """Return (Δcpu [s], Δsim [s], Δwall [s]) between the first and last heartbeat (within `wall` / `sim`, if given)."""
    beats = [m.value for m in msgs if isinstance(m.value.get("usage"), dict) and m.value.get("sim_time") is not None]
    if wall is not None:
        beats = [b for b in beats if wall[0] <= b["wall_time"] <= wall[1]]
    if sim is not None:
        beats = [b for b in beats if sim[0] <= b["sim_time"] <= sim[1]]
    if len(beats) < 2:
        return None
    a, b = beats[0], beats[-1]
    return b["usage"]["cpu_s"] - a["usage"]["cpu_s"], b["sim_time"] - a["sim_time"], b["wall_time"] - a["wall_time"]


def run(*, mission: str = DEFAULT_MISSION, rtf: float = 20.0, seed: int = 3, arch: str = "codger", perception: bool = True,
        without: bool = True, monitor: bool = False) -> dict:
    """Run the mission with (and without) the recorder; return the figures (see module docstring)."""
    from sidewalk.recording import open_recording
    from wire.ports import free_port

    with tempfile.TemporaryDirectory(prefix="sidewalk-bench-record-") as d:
        out = Path(d) / "with"
        port = free_port() if monitor else None
        watcher = PageWatcher(f"http://127.0.0.1:{port}/") if port else None
        if watcher:
            watcher.start()
        try:
            rep = _mission(out, mission, rtf, seed, True, arch, perception, port)
        finally:
            if watcher:
                watcher.stop()
        path = out / "run.mcap"
        rec = open_recording(path)
        t0, t1 = rec.time_range()
        channels = rec.channels()
        span_min = max(1e-9, (t1 - t0) / 60.0)
        messages = sum(c.count or 0 for c in channels.values())
        cpu = rep.modules["recorder"].cpu_s if "recorder" in rep.modules else 0.0
        beats: dict[str, list] = {"recorder": [], "monitor": []}
        sizes: list[tuple[float, int]] = []  # (log time [s], JSON size [bytes]) of every message
        status_t: list[float] = []
        for m in rec.messages():
            sizes.append((m.log_time, len(json.dumps(m.value, separators=(",", ":")))))
            if m.topic in ("/heartbeat/recorder", "/heartbeat/monitor"):
                beats[m.topic.rsplit("/", 1)[-1]].append(m)
            elif m.topic == "/mission/events":
                status_t.append(m.log_time)
        result = {
            "mission": Path(mission).stem,
            "arch": arch,
            "perception": perception,
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
            "others_cpu_s_with": round(sum(v.cpu_s for k, v in rep.modules.items() if k not in ("recorder", "monitor")), 3),
            "rtf_with": rep.rtf_achieved,
            "success_with": rep.success,
        }
        if len(status_t) >= 2 and status_t[-1] > status_t[0]:
            w0, w1 = status_t[0], status_t[-1]
            inside = [n for t, n in sizes if w0 <= t <= w1]
            wmin = (w1 - w0) / 60.0
            result.update({
                "mission_window_sim_s": round(w1 - w0, 2),
                "mission_messages_per_sim_min": round(len(inside) / wmin),
                "mission_mcap_bytes_per_sim_min": round(path.stat().st_size * sum(inside) / max(1, sum(n for _, n in sizes)) / wmin),
            })
            u = _usage(beats["recorder"], sim=(w0, w1))
            if u and u[1] > 0:
                result["mission_recorder_cpu_s_per_sim_min"] = round(u[0] / u[1] * 60.0, 4)
        steady = _usage(beats["recorder"])
        if steady and steady[1] > 0:
            result["recorder_steady_cpu_s_per_sim_min"] = round(steady[0] / steady[1] * 60.0, 4)
        if watcher:
            result["monitor_cpu_s"] = rep.modules["monitor"].cpu_s if "monitor" in rep.modules else None
            s = watcher.samples
            if watcher.error:
                result["page_error"] = watcher.error
            if len(s) >= 2 and s[-1][0] > s[0][0]:
                w = (s[0][0], s[-1][0])
                result["page_window_s"] = round(w[1] - w[0], 2)
                result["page_frames_per_s"] = round((s[-1][1] - s[0][1]) / (w[1] - w[0]), 2)
                result["page_draws_per_s"] = round((s[-1][2] - s[0][2]) / (w[1] - w[0]), 2)
                u = _usage(beats["monitor"], wall=w)
                if u and u[2] > 0:
                    result["monitor_cpu_cores"] = round(u[0] / u[2], 4)
                    if u[1] > 0:
                        result["monitor_cpu_s_per_sim_min"] = round(u[0] / u[1] * 60.0, 4)
        if without:
            rep0 = _mission(Path(d) / "without", mission, rtf, seed, False, arch, perception)
            result.update({
                "others_cpu_s_without": round(sum(v.cpu_s for v in rep0.modules.values()), 3),
                "rtf_without": rep0.rtf_achieved,
                "success_without": rep0.success,
            })
    return result
