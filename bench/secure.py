"""The cost of `--secure`: blackboard post → monitor notification latency with and without TLS.

Three deployments, each a router and a blackboard node as real processes and a client here:
`plain_peer` (the default: peers talk directly), `plain_client` (every process a client of the
router, as under --secure, without TLS), `secure` (mutual TLS, passwords, the router's access
control). Figures in [µs]: `<config>_notify_p50_us`/`_p99_us` (post → the monitor's notification)
and `<config>_post_ack_p50_us`/`_p99_us` (post → acknowledgement), and the ratios to `plain_peer`.

Run: `sidewalk bench secure --json` (or `python -m bench.secure`).
"""

from __future__ import annotations

import asyncio
import os
import sys
import tempfile
import time
from pathlib import Path

from blackboard import BlackboardClient, Spec
from bench.blackboard import BenchNote
from sidewalk.supervisor import ProcessPlan, Supervisor
from wire.network import NetworkConfig, SecureConfig
from wire.ports import free_port
from wire.summary import percentiles

__all__ = ["run", "CONFIGS"]

#: The deployments measured, in order.
CONFIGS = ("plain_peer", "plain_client", "secure")


async def _measure(net: NetworkConfig, samples: int) -> dict[str, float]:
    pc = time.perf_counter
    ack, notify = [], []
    async with BlackboardClient(net, source="bench", timeout=60) as bb:
        async with bb.monitor(Spec(type="bench_note")) as mon:
            for i in range(50):  # warm up
                await bb.post(BenchNote(seq=i), stamp=0.0)
                await mon.next(10)
            for i in range(samples):
                t0 = pc()
                fut = asyncio.ensure_future(bb.post(BenchNote(seq=i), stamp=float(i)))
                await anext(mon)
                t1 = pc()
                await fut
                t2 = pc()
                notify.append(t1 - t0)
                ack.append(t2 - t0)
    out: dict[str, float] = {}
    out["notify_p50_us"], out["notify_p99_us"] = percentiles(notify, (50, 99), method="rank", scale=1e6)
    out["post_ack_p50_us"], out["post_ack_p99_us"] = percentiles(ack, (50, 99), method="rank", scale=1e6)
    return out


async def _one(config: str, samples: int, secure_dir: Path | None, log_dir: Path) -> dict[str, float]:
    ns = f"benchsec{os.getpid()}{config.replace('_', '')}"
    ep = f"tcp/127.0.0.1:{free_port()}"
    sec = ("--secure", str(secure_dir)) if secure_dir is not None else ()
    mode = ("--mode", "client") if config == "plain_client" else ()
    sup = Supervisor(log_dir / config)
    try:
        await sup.start(ProcessPlan("router", ("-m", "sidewalk", "up", "router", "--ns", ns, "--listen", ep, *sec)))
        await sup.start(ProcessPlan("blackboard", ("-m", "sidewalk", "up", "blackboard", "--ns", ns, "--connect", ep, *mode, *sec,
                                                   "--types", "bench.blackboard")))
        net = NetworkConfig(namespace=ns, connect=(ep,), mode="client" if config != "plain_peer" else "peer",
                            secure=None if secure_dir is None else SecureConfig(dir=secure_dir, role="pilot"))
        return await _measure(net, samples)
    finally:
        await sup.stop_all()


def run(samples: int = 1000) -> dict:
    """Measure each deployment in turn; return the figures (see the module docstring)."""
    if samples < 10:
        raise ValueError("samples must be ≥ 10")
    from sidewalk.security import init_secure_dir

    out: dict = {"samples": samples, "cpus": os.cpu_count()}
    with tempfile.TemporaryDirectory(prefix="bench-secure-") as tmp:
        d = Path(tmp) / "sec"
        init_secure_dir(d)
        for config in CONFIGS:
            figures = asyncio.run(_one(config, samples, d if config == "secure" else None, Path(tmp) / "logs"))
            out.update({f"{config}_{k}": v for k, v in figures.items()})
    for config in CONFIGS[1:]:
        out[f"{config}_notify_vs_plain_peer"] = out[f"{config}_notify_p50_us"] / out["plain_peer_notify_p50_us"]
    out["secure_notify_vs_plain_client"] = out["secure_notify_p50_us"] / out["plain_client_notify_p50_us"]
    out["loadavg_1m"] = os.getloadavg()[0]
    return out


if __name__ == "__main__":
    from sidewalk.json_out import dumps

    print(dumps(run(int(sys.argv[1]) if len(sys.argv) > 1 else 1000), sort_keys=True))
