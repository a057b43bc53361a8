"""The `sidewalk blackboard serve` and `sidewalk bb …` commands as real processes."""

from __future__ import annotations

import json
import os
import select
import signal
import subprocess
import sys

import pytest

from wire.ports import free_port

pytestmark = pytest.mark.timeout(90)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ENV = {**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", "")}


def sidewalk(*args: str, check: bool = True) -> subprocess.CompletedProcess:
    p = subprocess.run([sys.executable, "-m", "sidewalk", *args], capture_output=True, text=True, env=ENV, timeout=60)
    if check:
        assert p.returncode == 0, p.stderr
    return p


def test_serve_post_retrieve_and_clean_shutdown(tmp_path):
    ep = f"tcp/127.0.0.1:{free_port()}"
    db = str(tmp_path / "cli.sqlite")
    srv = subprocess.Popen(
        [sys.executable, "-m", "sidewalk", "blackboard", "serve", "--ns", "cli", "--listen", ep, "--db", db,
         "--types", "tests.blackboard.sample_types"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=ENV,
    )
    try:
        r, _, _ = select.select([srv.stdout], [], [], 30)
        line = srv.stdout.readline() if r else ""
        assert line.startswith("blackboard ready") and "ns=cli" in line and "bbt_segment" in line, line
        net = ["--ns", "cli", "--connect", ep]
        out = sidewalk("bb", "post", "bbt_segment", '{"index": 7}', "--stamp", "2.5", "--geometry", '{"kind":"point","x":1,"y":2}', *net)
        tok = json.loads(out.stdout)
        assert tok["attrs"] == {"index": 7, "mode": "follow-road"} and tok["stamp"] == 2.5
        out = sidewalk("bb", "retrieve", '{"type": "bbt_segment"}', "--frame", "world", *net)
        lines = [json.loads(x) for x in out.stdout.splitlines()]
        assert [t["id"] for t in lines] == [tok["id"]]
        bad = sidewalk("bb", "post", "bbt_segment", '{"index": "seven"}', *net, check=False)
        assert bad.returncode == 1 and "invalid_token" in bad.stderr
        bad = sidewalk("bb", "retrieve", '{"limit": 0}', *net, check=False)
        assert bad.returncode == 1 and "bad_spec" in bad.stderr
        stats = json.loads(sidewalk("bb", "stats", *net).stdout)
        assert stats["posts"] == 1 and stats["tokens"] == 1
    finally:
        srv.send_signal(signal.SIGTERM)
        rc = srv.wait(20)
    assert rc == 0
