"""Follow a running `sidewalk run` from outside with `sidewalk status --json`, as an operator would."""

from __future__ import annotations

import json
import re
import subprocess
import sys
import threading
import time

from wire.keys import MissionKeys, ModuleKeys
from wire.network import NetworkConfig
from wire.errors import ConnectError
from wire.session import Session, open_session

__all__ = ["RunWatch", "assert_progress_moves", "assert_cli_progress"]


class RunWatch:
    """A `sidewalk run` process: its stderr read on a thread; `progress()` asks `sidewalk status` about its mission."""

    def __init__(self, cmd: list[str]) -> None:
        self.proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        self.err: list[str] = []
        self._cv = threading.Condition()
        self._t = threading.Thread(target=self._pump, daemon=True)
        self._t.start()
        self.ns = self.endpoint = ""
        #: `sidewalk status --json`'s answer while the mission ran (`running_progress`)
        self.cli: dict = {}

    def _pump(self) -> None:
        assert self.proc.stderr is not None
        for line in self.proc.stderr:
            with self._cv:
                self.err.append(line)
                self._cv.notify_all()
        with self._cv:
            self.err.append("")
            self._cv.notify_all()

    def stderr(self) -> str:
        with self._cv:
            return "".join(self.err)

    def wait_system(self, timeout: float) -> None:
        """Wait for the launcher's line naming the namespace and the endpoint (the system is up and submitting)."""
        rx = re.compile(r"namespace (\S+), endpoint (\S+)")
        with self._cv:
            ok = self._cv.wait_for(lambda: any(rx.search(ln) for ln in self.err) or (self.err and self.err[-1] == ""), timeout)
            m = next((rx.search(ln) for ln in self.err if rx.search(ln)), None)
        assert ok and m, f"no namespace line within {timeout:.0f} s:\n{self.stderr()[-3000:]}"
        self.ns, self.endpoint = m.group(1), m.group(2)

    def status(self) -> dict:
        """Return one `sidewalk status --json` answer about the run's namespace."""
        p = subprocess.run([sys.executable, "-m", "sidewalk", "status", "--json", "--heartbeat-wait", "0", "--timeout", "5",
                            "--ns", self.ns, "--connect", self.endpoint], capture_output=True, text=True, timeout=60)
        return json.loads(p.stdout) if p.stdout.strip() else {}

    def running_progress(self, timeout: float) -> list[dict]:
        """Return the progress records of the running mission, each with a later sim time than the one before.

        The status query (`sidewalk status`'s) is asked over one Zenoh session once per heartbeat of any process
        (several a second), until the mission ended or `timeout` [s wall] passed. At the first record
        `sidewalk status --json` itself is run beside it (`self.cli`: its answer; the mission may have ended by then).
        """
        seen: list[dict] = []
        ended = False
        end = time.monotonic() + timeout
        beat = threading.Event()
        cli: threading.Thread | None = None
        s = self._session(end)
        try:
            s.subscribe_payload(ModuleKeys(self.ns).heartbeat_all, lambda _k, _p: beat.set())
            while not ended and time.monotonic() < end and self.proc.poll() is None:
                # a heartbeat, or a second to look whether the run ended (its processes stop beating before it exits)
                if not beat.wait(min(1.0, max(0.0, end - time.monotonic()))):
                    continue
                beat.clear()
                for r in s.get_blocking(MissionKeys(self.ns).status("*"), timeout=5.0):
                    m = json.loads(r.payload) if r.ok else {}
                    p = m.get("progress")
                    if m.get("state") == "running" and p is not None and (not seen or p["sim_time_s"] > seen[-1]["sim_time_s"]):
                        seen.append(p)
                    ended = ended or (bool(seen) and m.get("state") in ("succeeded", "failed", "cancelled"))
                if seen and cli is None:
                    cli = threading.Thread(target=lambda: setattr(self, "cli", self.status()), daemon=True)
                    cli.start()
        finally:
            s.close()
        if cli is not None:
            cli.join(60)
        return seen

    def _session(self, end: float) -> Session:
        """Return a session to the run's router, once it listens (the namespace line comes before it starts)."""
        while True:
            try:
                return open_session(NetworkConfig(namespace=self.ns, mode="client", connect=(self.endpoint,)))
            except ConnectError:
                assert time.monotonic() < end and self.proc.poll() is None, f"the router never came up:\n{self.stderr()[-3000:]}"
                with self._cv:  # back off until the launcher says more (or 0.2 s)
                    n = len(self.err)
                    self._cv.wait_for(lambda: len(self.err) > n, 0.2)

    def finish(self, timeout: float) -> int:
        """Wait for the run to end; return its exit code."""
        try:
            return self.proc.wait(timeout=timeout)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
            self._t.join(5)


def assert_progress_moves(seen: list[dict]) -> None:
    """Assert that a running mission's progress records carry every field and that they move along the route."""
    assert len(seen) >= 3, seen
    first, last = seen[0], seen[-1]  # from the step's start (or soon after) to its end (or soon before)
    for p in seen:
        assert p["step_index"] == 0 and p["pose"] is not None and p["route_done_m"] is not None, p
        assert p["since_progress_s"] is not None and p["since_progress_s"] >= 0.0, p
        assert p["waiting"] in ("", "obstacle hold", "planning", "dead reckoning"), p
        # done + left is the route's length: the same route throughout (a short hop is not replanned)
        assert abs(p["route_done_m"] + p["route_left_m"] - (first["route_done_m"] + first["route_left_m"])) < 1.0, (first, p)
    assert last["sim_time_s"] > first["sim_time_s"]
    assert last["route_done_m"] > first["route_done_m"] + 1.0 and last["route_left_m"] < first["route_left_m"] - 1.0, (first, last)
    moved = ((last["pose"]["x"] - first["pose"]["x"]) ** 2 + (last["pose"]["y"] - first["pose"]["y"]) ** 2) ** 0.5
    assert moved > 1.0, (first, last)
    # driving on: progress is recent in some answer (a record made while it stood still may say otherwise)
    assert min(p["since_progress_s"] for p in seen) < 5.0, seen


def assert_cli_progress(answer: dict) -> None:
    """Assert that `sidewalk status --json` gave a running mission with its progress (one that ended by then, without)."""
    missions = answer.get("missions")
    assert missions, answer
    for m in missions:
        assert (m["progress"] is not None) == (m["state"] == "running"), m
        if m["progress"] is not None:
            assert {"sim_time_s", "route_done_m", "route_left_m", "pose", "since_progress_s", "waiting"} <= set(m["progress"])
