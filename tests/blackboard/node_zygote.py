"""A fork server of blackboard nodes: import once, fork a real node per start, SIGKILL and reap on request.

Starting `python -m blackboard` costs seconds of imports; the durability test restarts the node a
hundred times. This process imports the node (and zenoh, without opening a session) once, then
answers one JSON line per request on stdin:
  {"cmd": "start", "ns", "connect", "db", "hold"} → {"pid", "ready"} once the forked node printed
      its ready line (`hold`: the node's --test-hold-after-journal path, or null);
  {"cmd": "kill", "pid"} → {"pid", "status"} once the node is SIGKILLed and reaped.
EOF on stdin kills every node still running and exits.
"""

from __future__ import annotations

import gc
import json
import os
import signal
import sys

from blackboard.node import serve
from wire.network import NetworkConfig

__all__ = ["main"]

TYPES = ("tests.blackboard.sample_types",)


def _start(req: dict) -> dict:
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # the node
        try:
            os.close(r)
            null = os.open(os.devnull, os.O_RDWR)
            os.dup2(null, 0)
            os.dup2(null, 1)
            net = NetworkConfig(namespace=req["ns"], connect=(req["connect"],))
            serve(net, db=req["db"], types=TYPES, ready_stream=os.fdopen(w, "w"), test_hold_after_journal=req.get("hold"))
        finally:
            os._exit(0)
    os.close(w)
    with os.fdopen(r) as ready:
        line = ready.readline().strip()
    if not line.startswith("blackboard ready"):
        _, status = os.waitpid(pid, 0)
        return {"error": f"node {pid} exited ({status}) before ready"}
    return {"pid": pid, "ready": line}


def _kill(pid: int) -> dict:
    try:
        os.kill(pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    _, status = os.waitpid(pid, 0)
    return {"pid": pid, "status": status}


def main() -> int:
    """Serve start/kill requests until stdin closes."""
    import tests.blackboard.sample_types  # noqa: F401 - registered before the first fork

    gc.freeze()  # what every node inherits is long-lived: its collector need not scan it

    children: set[int] = set()
    try:
        for line in sys.stdin:
            req = json.loads(line)
            if req["cmd"] == "start":
                rep = _start(req)
                if "pid" in rep:
                    children.add(rep["pid"])
            else:
                rep = _kill(int(req["pid"]))
                children.discard(rep["pid"])
            sys.stdout.write(json.dumps(rep) + "\n")
            sys.stdout.flush()
    finally:
        for pid in children:
            _kill(pid)
    return 0


if __name__ == "__main__":
    sys.exit(main())
