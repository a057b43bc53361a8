"""End to end: a short mission run with `--monitor`, watched in Debian's headless chromium (Playwright), its
`run.mcap` read back and checked against what was published, then replayed into the page — under the
CODGER blackboard and under EDDIE (`--arch eddie --no-perception`).

One run per architecture serves its tests (module-scoped fixtures): the page is loaded while the mission drives.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import signal
import sqlite3
import subprocess
import sys
import tempfile
import threading
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path

import msgpack
import pytest

from sidewalk.recording import open_recording
from wire.network import NetworkConfig
from wire.ports import free_port
from wire.session import open_session

DATA = Path(__file__).parent / "data"
CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update", "--disable-sync"]
PROCESSES = {"router", "blackboard", "recorder", "monitor", "sim", "helm", "perception", "pilot", "map_navigator", "captain"}
EDDIE_PROCESSES = {"router", "recorder", "monitor", "sim", "controller", "navigator", "map_manager", "mission_service"}
RUN_TIMEOUT_S = 300.0


class Lines:
    """Read a process's output lines on a thread; wait for one matching a pattern (an event, not a sleep)."""

    def __init__(self, stream) -> None:
        self.lines: list[str] = []
        self._cv = threading.Condition()
        self._t = threading.Thread(target=self._pump, args=(stream,), daemon=True)
        self._t.start()

    def _pump(self, stream) -> None:
        for line in stream:
            with self._cv:
                self.lines.append(line)
                self._cv.notify_all()
        with self._cv:
            self.lines.append("")  # end of stream
            self._cv.notify_all()

    def wait_for(self, pattern: str, timeout: float) -> re.Match:
        rx = re.compile(pattern)
        with self._cv:
            seen = 0
            ok = self._cv.wait_for(lambda: any(rx.search(ln) for ln in self.lines) or (self.lines and self.lines[-1] == ""), timeout)
            for ln in self.lines:
                m = rx.search(ln)
                if m:
                    return m
                seen += 1
        raise AssertionError(f"no line matching {pattern!r} within {timeout:.0f} s (ended: {bool(ok)}); output:\n" + "".join(self.lines)[-3000:])

    def text(self) -> str:
        with self._cv:
            return "".join(self.lines)


@dataclass
class Tap:
    """An independent subscriber to the run's keys: counts per key and the truth stamps it heard."""

    counts: dict = field(default_factory=lambda: defaultdict(int))
    truth_stamps: list = field(default_factory=list)
    event_kinds: dict = field(default_factory=lambda: defaultdict(int))
    stamps: dict = field(default_factory=lambda: defaultdict(list))  # the EDDIE controller's streams: stamps heard, in order
    lock: threading.Lock = field(default_factory=threading.Lock)

    def on_sample(self, key: str, payload: bytes) -> None:
        with self.lock:
            self.counts[key] += 1
            if key.endswith(("/eddie/pub/controller/state", "/eddie/pub/controller/path")):
                self.stamps[key].append(msgpack.unpackb(payload)["stamp"])
            if key.endswith("/sim/truth"):
                self.truth_stamps.append(msgpack.unpackb(payload)["stamp"])
            elif key.endswith("/sim/events"):
                self.event_kinds[msgpack.unpackb(payload)["kind"]] += 1


@dataclass
class MonitoredRun:
    proc: subprocess.Popen
    out: Path
    err: Lines
    tap: Tap
    ns: str = ""
    url: str = ""
    session: object = None
    returncode: int | None = None

    def finish(self) -> int:
        if self.returncode is None:
            try:
                self.returncode = self.proc.wait(timeout=RUN_TIMEOUT_S)
            finally:
                if self.session is not None:
                    self.session.close()
                    self.session = None
        return self.returncode


def _monitored(out: Path, *extra: str, rtf: str = "6"):
    """Start a short mission with --monitor; yield it once its page is served and a tap listens to every key."""
    port = free_port()
    cmd = [sys.executable, "-m", "sidewalk", "run", "--world", "campus", "--mission", str(DATA / "short-hop.yaml"),
           "--rtf", rtf, "--seed", "3", "--out", str(out), "--max-wall-time", "240", "--monitor", "--monitor-port", str(port),
           *extra]
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env={**os.environ, "COLUMNS": "200"})
    run = MonitoredRun(proc=proc, out=out, err=Lines(proc.stderr), tap=Tap())
    try:
        m = run.err.wait_for(r"namespace (\S+), endpoint (\S+)", 60)
        run.ns = m.group(1)
        run.url = run.err.wait_for(r"monitor: (http://\S+)", 120).group(1)  # the router is up by now
        z = open_session(NetworkConfig(namespace=run.ns, mode="client", connect=(m.group(2),)))
        z.subscribe_payload(f"sidewalk/{run.ns}/**", run.tap.on_sample)
        run.session = z
        yield run
    finally:
        if proc.poll() is None and run.returncode is None:
            proc.send_signal(signal.SIGINT)  # the launcher stops every process it started
            try:
                proc.wait(timeout=60)
            except subprocess.TimeoutExpired:
                proc.kill()
        if run.session is not None:
            run.session.close()


@pytest.fixture(scope="module")
def monitored_run(tmp_path_factory):
    yield from _monitored(tmp_path_factory.mktemp("monitored"))


@pytest.fixture(scope="module")
def eddie_run(tmp_path_factory):
    yield from _monitored(tmp_path_factory.mktemp("monitored-eddie"), "--arch", "eddie", "--no-perception", rtf="10")


@pytest.fixture(scope="module")
def browser():
    if not os.access(CHROMIUM, os.X_OK):
        pytest.fail(f"Debian's chromium is not installed at {CHROMIUM}: the browser test cannot run. "
                    "`make test` installs it when run as root (apt-get install -y chromium).")
    from playwright.sync_api import sync_playwright

    with sync_playwright() as p:
        ctx = p.chromium.launch_persistent_context(tempfile.mkdtemp(prefix="sidewalk-chromium-"), executable_path=CHROMIUM,
                                                   headless=True, args=CHROMIUM_ARGS, viewport={"width": 1400, "height": 860})
        try:
            yield ctx
        finally:
            ctx.close()


@pytest.mark.e2e
@pytest.mark.timeout(420)
def test_monitor_page_draws_the_live_mission(monitored_run, browser):
    page = browser.new_page()
    page.goto(monitored_run.url)
    page.wait_for_function("window.monitorState.connected && window.monitorState.map.features > 10", timeout=60_000)
    # the route, a driving unit and the vehicle are drawn once the mission is under way
    page.wait_for_function("""(() => { const s = window.monitorState;
        return s.route.points >= 2 && s.units.count >= 1 && s.vehicle !== null && s.truth !== null; })()""", timeout=120_000)
    first = page.evaluate("window.monitorState.vehicle")
    # the vehicle marker moves: its drawn position changes between two reads
    page.wait_for_function("""(p) => { const v = window.monitorState.vehicle;
        return v && Math.hypot(v.x - p.x, v.y - p.y) > 1.0 && Math.hypot(v.sx - p.sx, v.sy - p.sy) > 2; }""",
                           arg=first, timeout=120_000)
    # every process is listed with its heartbeat age
    page.wait_for_function("""(names) => { const m = window.monitorState.modules;
        return names.every(n => m.some(r => r.name === n && r.alive && r.age !== null)); }""", arg=sorted(PROCESSES), timeout=60_000)
    rows = page.locator("#modules tbody tr")
    listed = {rows.nth(i).get_attribute("data-module"): rows.nth(i).locator("td").nth(2).inner_text() for i in range(rows.count())}
    assert PROCESSES <= set(listed), listed
    assert all(re.fullmatch(r"\d+\.\d", listed[n]) for n in PROCESSES), listed
    page.wait_for_function("window.monitorState.images.camera && window.monitorState.images.colored_range", timeout=60_000)
    st = page.evaluate("window.monitorState")
    assert st["segment"]["drawn"] and st["plan"]["points"] >= 2 and not st["replay"]
    page.screenshot(path=str(monitored_run.out / "monitor.png"))
    page.close()
    assert (monitored_run.out / "monitor.png").stat().st_size > 20_000


@pytest.mark.missions
@pytest.mark.e2e
@pytest.mark.timeout(420)
def test_run_mcap_holds_every_channel_and_every_message(monitored_run):
    code = monitored_run.finish()
    out = monitored_run.out
    report = json.loads((out / "report.json").read_text())
    assert code == 0 and report["success"], monitored_run.err.text()[-3000:]
    assert report["exit_codes"]["recorder"] == 0 and report["exit_codes"]["monitor"] == 0
    rec = open_recording(out / "run.mcap")
    channels = rec.channels()
    ns_root = f"sidewalk/{monitored_run.ns}/"
    # every key the independent subscriber heard has its channel (but the recorder's own monitor events,
    # which are its /tokens/* channels)
    heard = {k[len(ns_root):] for k in monitored_run.tap.counts if not k.startswith(ns_root + "bb/to/recorder-")}
    missing = {"/" + k for k in heard} - set(channels)
    assert not missing, missing
    expected = {"/sim/clock", "/sim/odom", "/sim/truth", "/sim/cmd", "/sim/preview", "/mission/events", "/alive", "/sim/map",
                "/sim/world", "/tf", "/tf/truth", "/scene/map", "/scene/world_truth", "/scene/route", "/scene/segment",
                "/scene/driving_units", "/scene/local_path", "/camera/image", "/colored_range/image"}
    expected |= {f"/heartbeat/{p}" for p in PROCESSES}
    expected |= {f"/tokens/{t}" for t in ("mission", "mission_status", "route_plan", "route_segment", "driving_unit",
                                           "perception_result", "local_path_plan", "position_estimate")}
    assert expected <= set(channels), expected - set(channels)
    assert any(t.startswith("/bb/write/") for t in channels) and any(t.startswith("/bb/to/") for t in channels)
    for t in ("/tf", "/tf/truth"):
        assert channels[t].schema == "foxglove.FrameTransform"
    assert channels["/scene/map"].schema == "foxglove.SceneUpdate" and channels["/camera/image"].schema == "foxglove.CompressedImage"

    per_topic: dict[str, list] = defaultdict(list)
    for m in rec.messages():
        per_topic[m.topic].append(m)
    assert {t: len(v) for t, v in per_topic.items()} == {t: c.count for t, c in channels.items()}
    # stamps in order on every channel; the simulator's streams strictly by their own stamps
    for t, msgs in per_topic.items():
        logs = [m.log_time for m in msgs]
        assert logs == sorted(logs), t
    for t in ("/sim/clock", "/sim/truth", "/sim/odom"):
        own = [m.value["stamp"] for m in per_topic[t]]
        assert all(b > a for a, b in zip(own, own[1:])), t
        assert [m.publish_time for m in per_topic[t]] == pytest.approx(own)

    # counts against the publishers' own counters, on every reliable stream: nothing missing, from the first one
    # (every process is a client of the router, which has the recorder's subscription before any module starts)
    for t, msgs in per_topic.items():
        if t.startswith("/bb/write/"):  # each client numbers its write batches 1, 2, 3 …
            rids = [m.value["payload"][0] for m in msgs]
            assert rids == list(range(1, 1 + len(rids))), (t, rids[:5])
    for p in PROCESSES - {"sim"}:  # every process but the simulator beats reliably, numbered from 0
        seqs = [m.value["seq"] for m in per_topic[f"/heartbeat/{p}"]]
        # the router and the node start before the recorder (it monitors the node's tokens); the others after it
        first = seqs[0] if p in ("router", "blackboard", "recorder") else 0
        assert seqs == list(range(first, first + len(seqs))), (p, seqs[:5])
    statuses = [m.value["token"]["attrs"]["state"] for m in per_topic["/tokens/mission_status"]]
    assert [m.value["state"] for m in per_topic["/mission/events"]] == statuses == ["queued", "running", "succeeded"]
    # … against an independent subscriber, up before the simulator started: the same simulator events
    kinds = defaultdict(int)
    for m in per_topic.get("/sim/events", []):
        kinds[m.value["kind"]] += 1
    with monitored_run.tap.lock:
        assert dict(kinds) == dict(monitored_run.tap.event_kinds)
    # the simulator's clock, odometry, truth and previews are droppable by design (they never hold up the
    # physics): on a starved machine Zenoh drops some before any subscriber sees them (a few % at a load of
    # 8 on 2 cores, a third of the big previews at 17), so for them the recording must hold, in order, most
    # of what the simulator numbered and most of what the test's own subscriber heard
    steps = [m.value["step"] for m in per_topic["/sim/clock"]]
    every = steps[1] - steps[0]
    published = (steps[-1] - steps[0]) // every + 1
    assert every > 0 and len(steps) >= 0.5 * published, (len(steps), published)
    pseq = [m.value["seq"] for m in per_topic["/sim/preview"]]
    assert pseq and pseq == sorted(set(pseq)) and len(per_topic["/camera/image"]) == len(pseq)
    with monitored_run.tap.lock:
        tapped = list(monitored_run.tap.truth_stamps)
    recorded = {m.value["stamp"] for m in per_topic["/sim/truth"]}
    assert len(tapped) > 100 and len(recorded & set(tapped)) >= 0.5 * len(tapped)
    # … and against the blackboard's own store: every token, every version
    db = sqlite3.connect(out / "blackboard.db")
    stored = {t: (n, v) for t, n, v in db.execute("SELECT type, COUNT(*), SUM(version) FROM tokens GROUP BY type")}
    db.close()
    versions: dict[tuple[str, str], set[int]] = defaultdict(set)
    gone = set()
    for t, msgs in per_topic.items():
        if t.startswith("/tokens/"):
            for m in msgs:
                tok = m.value["token"]
                versions[(tok["type"], tok["id"])].add(tok["version"])
                if m.value["event"] == "deleted":
                    gone.add(tok["id"])
    got = defaultdict(lambda: [0, 0])
    for (ttype, tid), vs in versions.items():
        if tid in gone:
            continue
        assert vs == set(range(1, max(vs) + 1)), (ttype, tid, vs)
        got[ttype][0] += 1
        got[ttype][1] += max(vs)
    assert {t: tuple(v) for t, v in got.items()} == stored


@contextlib.contextmanager
def _replay_page(browser, recording: Path, speed: str):
    """Play `recording` into the monitor page (`sidewalk replay`); yield the page; the replay must exit 0 on SIGINT."""
    proc = subprocess.Popen([sys.executable, "-m", "sidewalk", "replay", str(recording), "--speed", speed, "--port", str(free_port())],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    lines = Lines(proc.stdout)
    try:
        url = lines.wait_for(r"replay: (http://\S+)", 60).group(1)
        page = browser.new_page()
        page.goto(url)
        yield page
        page.close()
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            code = proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            proc.kill()
            code = None
    assert code == 0, lines.text()[-2000:]


@pytest.mark.e2e
@pytest.mark.timeout(300)
def test_replay_draws_the_recording(monitored_run, browser):
    monitored_run.finish()
    with _replay_page(browser, monitored_run.out / "run.mcap", "40") as page:
        page.wait_for_function("""(() => { const s = window.monitorState;
            return s.connected && s.replay && s.map.features > 10 && s.route.points >= 2 && s.units.count >= 1
                   && s.vehicle !== null && s.modules.length >= 8; })()""", timeout=120_000)
        first = page.evaluate("window.monitorState.vehicle")
        page.wait_for_function("""(p) => { const s = window.monitorState, v = s.vehicle;
            return (s.progress && s.progress.done) || Math.hypot(v.x - p.x, v.y - p.y) > 0.5; }""", arg=first, timeout=120_000)
        assert page.locator("#badge").inner_text() == "REPLAY"
        page.screenshot(path=str(monitored_run.out / "replay.png"))
    keep = os.environ.get("SIDEWALK_KEEP_SCREENSHOTS")
    if keep:  # a developer's copy of the screenshots (e.g. for docs/monitor.png)
        for name in ("monitor.png", "replay.png"):
            if (monitored_run.out / name).exists():
                shutil.copy(monitored_run.out / name, Path(keep) / name)


@pytest.mark.missions  # EDDIE's whole mission behind its page (~100 s quiet with the fixture): CI runs it after `make test`
@pytest.mark.e2e
@pytest.mark.timeout(300)
def test_monitor_page_draws_a_live_eddie_mission(browser, eddie_run):  # the browser first: the mission must not run before the page can open
    page = browser.new_page()
    page.goto(eddie_run.url)
    page.wait_for_function("window.monitorState.connected && window.monitorState.map.features > 10", timeout=60_000)
    # EDDIE's processes listed alive with their heartbeat age, while the run goes on
    page.wait_for_function("""(names) => { const m = window.monitorState.modules;
        return names.every(n => m.some(r => r.name === n && r.alive && r.state === "ready" && r.age !== null)); }""",
                           arg=sorted(EDDIE_PROCESSES), timeout=120_000)
    page.wait_for_function("window.monitorState.vehicle !== null && window.monitorState.truth !== null", timeout=60_000)
    first = page.evaluate("window.monitorState.vehicle")
    # the vehicle marker (world←local ∘ the controller's pose) moves
    page.wait_for_function("""(p) => { const v = window.monitorState.vehicle;
        return v && Math.hypot(v.x - p.x, v.y - p.y) > 3.0 && Math.hypot(v.sx - p.sx, v.sy - p.sy) > 2; }""",
                           arg=first, timeout=120_000)
    # the annotations, the route they lay out, the current segment, and a trigger as it fired
    page.wait_for_function("""(() => { const s = window.monitorState;
        return s.annotations.count >= 5 && s.route.points >= 2 && s.segment.drawn && s.triggers.fired >= 1
               && s.series.speed >= 2 && s.series.pos_error >= 2 && s.mission !== null; })()""", timeout=120_000)
    st = page.evaluate("window.monitorState")
    assert st["arch"] == "eddie" and not st["replay"] and st["segment"]["id"].startswith("route.")
    assert st["units"]["count"] == 0 and st["plan"]["points"] == 0  # no blackboard: no driving units, no PILOT plan
    # the list beside the map names the trigger the map drew last; the list follows each message and the map the
    # next frame, and triggers go on firing, so both are read together, at a moment when the page is drawn
    page.wait_for_function("""(() => { const li = document.querySelector('#triggers li'), last = window.monitorState.triggers.last;
        return li && last && li.innerText.includes(last.type) && li.innerText.includes('→'); })()""", timeout=30_000)
    page.screenshot(path=str(eddie_run.out / "monitor.png"))
    page.close()
    assert (eddie_run.out / "monitor.png").stat().st_size > 20_000


@pytest.mark.missions  # EDDIE's whole mission behind its page (~100 s quiet with the fixture): CI runs it after `make test`
@pytest.mark.e2e
@pytest.mark.timeout(300)
def test_eddie_run_mcap_holds_every_message_on_eddies_keys(eddie_run):
    code = eddie_run.finish()
    out = eddie_run.out
    report = json.loads((out / "report.json").read_text())
    assert code == 0 and report["architecture"] == "eddie", eddie_run.err.text()[-3000:]
    assert report["exit_codes"]["recorder"] == 0 and report["exit_codes"]["monitor"] == 0
    rec = open_recording(out / "run.mcap")
    channels = rec.channels()
    ns_root = f"sidewalk/{eddie_run.ns}/"
    with eddie_run.tap.lock:
        heard = {"/" + k[len(ns_root):]: n for k, n in eddie_run.tap.counts.items()}
    assert set(heard) <= set(channels), set(heard) - set(channels)
    assert not any(t.startswith(("/bb/", "/tokens/")) for t in channels)  # no blackboard anywhere
    expected = {"/eddie/pub/controller/state", "/eddie/pub/controller/path", "/eddie/pub/navigator/world_from_local",
                "/eddie/pub/map_manager/triggers", "/eddie/inbox/controller", "/eddie/annotations", "/mission/events", "/alive",
                "/tf", "/tf/truth", "/scene/map", "/scene/annotations", "/scene/route", "/scene/segment", "/scene/triggers",
                "/geojson/map", "/geojson/annotations", "/geojson/world_truth", "/sim/map", "/sim/world"}
    expected |= {f"/heartbeat/{p}" for p in EDDIE_PROCESSES}
    assert expected <= set(channels), expected - set(channels)
    assert channels["/tf"].schema == "foxglove.FrameTransform" and channels["/geojson/map"].schema == "foxglove.GeoJSON"

    per_topic: dict[str, list] = defaultdict(list)
    for m in rec.messages():
        per_topic[m.topic].append(m)
    assert {t: len(v) for t, v in per_topic.items()} == {t: c.count for t, c in channels.items()}
    for t, msgs in per_topic.items():
        logs = [m.log_time for m in msgs]
        assert logs == sorted(logs), t
    # EDDIE's links and streams are reliable and the recorder was up before EDDIE's first module: every
    # message an independent subscriber heard on EDDIE's keys is in the file, once
    eddie_topics = {t for t in heard if t.startswith("/eddie/")}
    assert {"/eddie/pub/controller/state", "/eddie/pub/map_manager/triggers"} <= eddie_topics
    # the controller's states and paths: every one the test's subscriber heard is in the file, in order, and the
    # file holds those sent before it subscribed too (it subscribes once the monitor is up; the recorder before it)
    with eddie_run.tap.lock:
        tapped = {"/" + k[len(ns_root):]: list(v) for k, v in eddie_run.tap.stamps.items()}
    for t, heard_stamps in tapped.items():
        got = [m.value["stamp"] for m in per_topic[t]]
        assert got and len(got) >= len(heard_stamps) and got[len(got) - len(heard_stamps):] == heard_stamps, \
            (t, len(got), len(heard_stamps), got[:3], heard_stamps[:3])
    rest = eddie_topics - set(tapped)
    assert {t: len(per_topic[t]) for t in rest} == {t: heard[t] for t in rest}
    own = [m.value["stamp"] for m in per_topic["/eddie/pub/controller/state"]]
    # in order by the controller's own stamps (a tick that outruns the sim clock repeats a stamp)
    assert len(own) > 100 and all(b >= a for a, b in zip(own, own[1:])) and own[-1] > own[0]
    assert [m.publish_time for m in per_topic["/eddie/pub/controller/state"]] == pytest.approx(own)
    # the triggers that fired are the report's, in order; each drawn for Foxglove
    fired = [m.value for m in per_topic["/eddie/pub/map_manager/triggers"] if m.value.get("event", "fired") == "fired"]
    assert [f["annotation_id"] for f in fired] == [t["annotation"] for t in report["triggers"]] and fired
    assert len(per_topic["/scene/triggers"]) == len(per_topic["/eddie/pub/map_manager/triggers"])
    # the poses as FrameTransforms: world→local from the navigator, local→vehicle from the controller
    pairs = defaultdict(int)
    for m in per_topic["/tf"]:
        pairs[(m.value["parent_frame_id"], m.value["child_frame_id"])] += 1
    assert pairs[("local", "vehicle")] == len(own) and pairs[("world", "local")] == len(per_topic["/eddie/pub/navigator/world_from_local"])
    # the annotations: the map manager's answer, as GeoJSON in WGS84, and the route they lay out
    anns = per_topic["/eddie/annotations"][0].value["payload"]
    geo = json.loads(per_topic["/geojson/annotations"][0].value["geojson"])
    assert len(geo["features"]) == len(anns) >= 5
    assert all(-80.0 < c[0] < -79.9 and 40.4 < c[1] < 40.5 for f in geo["features"] for c in _coords(f["geometry"]))
    segs = [e["metadata"] for m in per_topic["/scene/segment"] for e in m.value["entities"]]
    ids = [next(kv["value"] for kv in md if kv["key"] == "segment_id") for md in segs]
    route_ids = [a["id"] for a in anns if a["type"] == "route"]
    assert ids and ids == sorted(ids, key=route_ids.index)  # forward along the route only
    for p in EDDIE_PROCESSES - {"sim"}:  # numbered from 0 but for the router and the recorder (up before the recording)
        seqs = [m.value["seq"] for m in per_topic[f"/heartbeat/{p}"]]
        first = seqs[0] if p in ("router", "recorder") else 0
        assert seqs == list(range(first, first + len(seqs))), (p, seqs[:5])
    states = [m.value["state"] for m in per_topic["/mission/events"]]
    assert report["claimed_success"] and states[0] in ("queued", "running") and states[-1] == "succeeded", states


def _coords(g: dict) -> list:
    c = g["coordinates"]
    return [c] if g["type"] == "Point" else (c[0] if g["type"] == "Polygon" else c)


@pytest.mark.missions  # EDDIE's whole mission behind its page (~100 s quiet with the fixture): CI runs it after `make test`
@pytest.mark.e2e
@pytest.mark.timeout(200)
def test_replay_draws_an_eddie_recording(eddie_run, browser):
    eddie_run.finish()
    with _replay_page(browser, eddie_run.out / "run.mcap", "20") as page:
        page.wait_for_function("""(() => { const s = window.monitorState;
            return s.connected && s.replay && s.annotations.count >= 5 && s.route.points >= 2 && s.segment.drawn
                   && s.triggers.fired >= 1 && s.vehicle !== null && s.modules.some(r => r.name === "map_manager"); })()""",
                               timeout=120_000)
