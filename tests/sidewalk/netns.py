"""Several hosts on one machine for tests: network namespaces on a bridge, made and removed by the test.

Needs root and iproute2 (`ip netns`); `available()` says why not when they are missing.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from dataclasses import dataclass, field

__all__ = ["Hosts", "available"]


def available() -> str | None:
    """Return None when namespaces can be made here, else the reason they cannot."""
    if os.geteuid() != 0:
        return "multi-host tests need root (ip netns)"
    if shutil.which("ip") is None:
        return "multi-host tests need iproute2 (`ip`)"
    probe = f"swprobe{os.getpid()}"
    r = subprocess.run(["ip", "netns", "add", probe], capture_output=True, text=True)
    if r.returncode != 0:
        return f"cannot create a network namespace: {r.stderr.strip()}"
    subprocess.run(["ip", "netns", "del", probe], capture_output=True)
    return None


def _ip(*args: str, ns: str | None = None) -> None:
    cmd = (["ip", "netns", "exec", ns, "ip"] if ns else ["ip"]) + list(args)
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: {r.stderr.strip()}")


@dataclass
class Hosts:
    """`n` hosts (network namespaces) on one bridge, at 10.<net>.0.1 … 10.<net>.0.n/24."""

    n: int
    tag: str = field(default_factory=lambda: f"{os.getpid() % 100000}")
    net: int = 77
    names: list[str] = field(default_factory=list)
    #: give the bridge 10.<net>.0.254 so that this (root) namespace reaches the hosts too (the test's own observer)
    bridge_ip: bool = False

    @property
    def bridge(self) -> str:
        return f"swbr{self.tag}"

    def addr(self, i: int) -> str:
        """Return the IPv4 address of host `i` (0-based)."""
        return f"10.{self.net}.0.{i + 1}"

    @property
    def bridge_addr(self) -> str:
        """Return the root namespace's address on the bridge (with `bridge_ip`)."""
        return f"10.{self.net}.0.254"

    def veth(self, i: int) -> str:
        return f"swv{self.tag}h{i}"

    def __enter__(self) -> "Hosts":
        try:
            _ip("link", "add", self.bridge, "type", "bridge")
            _ip("link", "set", self.bridge, "up")
            if self.bridge_ip:
                _ip("addr", "add", f"{self.bridge_addr}/24", "dev", self.bridge)
            for i in range(self.n):
                ns = f"swns{self.tag}h{i}"
                subprocess.run(["ip", "netns", "add", ns], check=True, capture_output=True)
                self.names.append(ns)
                _ip("link", "add", self.veth(i), "type", "veth", "peer", "name", "eth0", "netns", ns)
                _ip("link", "set", self.veth(i), "master", self.bridge)
                _ip("link", "set", self.veth(i), "up")
                _ip("addr", "add", f"{self.addr(i)}/24", "dev", "eth0", ns=ns)
                _ip("link", "set", "eth0", "up", ns=ns)
                _ip("link", "set", "lo", "up", ns=ns)
        except BaseException:
            self.__exit__()
            raise
        return self

    def exec(self, i: int, argv: list[str]) -> list[str]:
        """Return `argv` run on host `i`."""
        return ["ip", "netns", "exec", self.names[i], *argv]

    def link(self, i: int, up: bool) -> None:
        """Bring host `i`'s link to the bridge down or up (a cable pulled and plugged back)."""
        _ip("link", "set", self.veth(i), "up" if up else "down")

    def __exit__(self, *exc: object) -> None:
        for i, ns in enumerate(self.names):
            subprocess.run(["ip", "link", "del", self.veth(i)], capture_output=True)
            subprocess.run(["ip", "netns", "del", ns], capture_output=True)
        self.names.clear()
        subprocess.run(["ip", "link", "del", self.bridge], capture_output=True)
