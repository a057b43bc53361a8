"""Three hosts in network namespaces: the router, node and simulator on A, the modules on B, tools on C.

From C, `sidewalk status` sees every module every time (50 runs) and 20 `sidewalk submit`s all
succeed — the deployment every peer sees every other through the router.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from sidewalk.launcher import RunConfig, build_plans, prepare_run
from tests.modules._procs import spawn, stop
from tests.sidewalk.netns import Hosts, available

pytestmark = [pytest.mark.e2e, pytest.mark.skipif(available() is not None, reason=available() or "")]

MISSION = Path(__file__).parent / "data" / "short-hop.yaml"
ON_A = ("router", "blackboard", "sim")
READY = {"router": "router ready", "blackboard": "blackboard ready", "sim": "ready sim"}


def _sidewalk(hosts: Hosts, i: int, *args: str, timeout: float = 60.0) -> subprocess.CompletedProcess:
    return subprocess.run(hosts.exec(i, [sys.executable, "-m", "sidewalk", *args]), capture_output=True, text=True,
                          timeout=timeout, cwd=Path(__file__).resolve().parents[2])


def test_every_host_sees_every_module(tmp_path) -> None:
    with Hosts(3) as hosts:
        endpoint = f"tcp/{hosts.addr(0)}:7447"
        ns = "multihost"
        cfg = RunConfig(world="campus", mission=str(MISSION), out=tmp_path, namespace=ns, record=False)
        plans = build_plans(cfg, prepare_run(cfg), ns, endpoint)
        procs = []
        try:
            for plan in plans:
                host = 0 if plan.name in ON_A else 1
                ready = READY.get(plan.name, f"SIDEWALK-READY {plan.name}")
                procs.append(spawn(hosts.exec(host, [sys.executable, *plan.args]), ready, timeout=90))
            expected = {"router", "blackboard", "sim", "helm", "perception", "pilot", "map_navigator", "captain"}
            seen = []
            for _ in range(50):
                r = _sidewalk(hosts, 2, "status", "--json", "--heartbeat-wait", "0", "--ns", ns, "--connect", endpoint)
                assert r.returncode == 0, r.stderr
                seen.append({m["name"] for m in json.loads(r.stdout)["modules"]})
            assert all(s == expected for s in seen), [sorted(expected - s) for s in seen if s != expected]
            r = _sidewalk(hosts, 2, "status", "--json", "--ns", ns, "--connect", endpoint)
            health = {m["name"]: m for m in json.loads(r.stdout)["modules"]}
            assert r.returncode == 0 and all(h["state"] == "ready" for h in health.values()), health
            ids = []
            for _ in range(20):
                r = _sidewalk(hosts, 2, "submit", str(MISSION), "--no-follow", "--ns", ns, "--connect", endpoint)
                assert r.returncode == 0, r.stdout + r.stderr
                ids.append(r.stdout.split("mission accepted:")[1].split()[0])
            assert len(set(ids)) == 20
        finally:
            for p in reversed(procs):
                stop(p)
