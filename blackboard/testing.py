"""Start blackboard nodes as subprocesses for tests and launchers, synchronised on readiness."""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field

from wire.network import NetworkConfig
from wire.ports import free_port

__all__ = ["NodeProcess", "start_node"]


@dataclass
class NodeProcess:
    """A blackboard node running in its own OS process."""

    proc: subprocess.Popen
    endpoint: str
    namespace: str
    ready_line: str
    args: list[str] = field(default_factory=list)
    #: the node is a client of the router at `endpoint` (as in a deployed system), not a peer listening there
    via_router: bool = False

    def client_net(self) -> NetworkConfig:
        """Return the NetworkConfig a client uses to reach this node (a client of the router when there is one)."""
        return NetworkConfig(namespace=self.namespace, mode="client" if self.via_router else "peer", connect=(self.endpoint,))

    def kill(self) -> None:
        """SIGKILL the node and reap it."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGKILL)
        self.proc.wait(10)

    def stop(self, timeout: float = 10.0) -> int:
        """SIGTERM the node, wait for a clean exit; SIGKILL after `timeout` [s]. Return the exit code."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        if self.proc.stdout:
            self.proc.stdout.close()
        return self.proc.returncode

    def __enter__(self) -> "NodeProcess":
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()


def start_node(
    *,
    namespace: str = "test",
    port: int | None = None,
    db: str = ":memory:",
    sync: str = "normal",
    types: tuple[str, ...] = (),
    timeout: float = 60.0,
    extra_env: dict[str, str] | None = None,
    dispatch: str = "inline",
    router: str | None = None,
) -> NodeProcess:
    """Start `python -m blackboard` listening on tcp/127.0.0.1:<port>, or a client of `router` (an endpoint); return once it prints "ready"."""
    if router is None:
        endpoint = f"tcp/127.0.0.1:{port or free_port()}"
        where = ["--listen", endpoint]
    else:
        endpoint = router
        where = ["--connect", router]
    args = [sys.executable, "-m", "blackboard", "--ns", namespace, *where, "--db", db, "--sync", sync, "--dispatch", dispatch]
    for t in types:
        args += ["--types", t]
    env = {**os.environ, **(extra_env or {})}
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=None, text=True, env=env)
    deadline = time.monotonic() + timeout
    assert proc.stdout is not None
    buf = ""
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            proc.kill()
            proc.wait(5)
            raise TimeoutError(f"blackboard node did not become ready within {timeout} s: {buf!r}")
        r, _, _ = select.select([proc.stdout], [], [], left)
        if not r:
            continue
        line = proc.stdout.readline()
        if not line:
            rc = proc.wait(5)
            raise RuntimeError(f"blackboard node exited with code {rc} before ready: {buf!r}")
        buf += line
        if line.startswith("blackboard ready"):
            return NodeProcess(proc, endpoint, namespace, line.strip(), args, via_router=router is not None)
