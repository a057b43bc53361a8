"""The blackboard client as a part of the module runtime: what makes a runtime a CODGER module.

Plugged into `runtime.run_module(…, parts=(BlackboardPart(),))`: once the session reaches the
network it connects a `BlackboardClient` (waiting up to `connect_timeout` [s wall] for the node) as
`rt.bb`, tells the lock-step barrier to wait for its unacknowledged writes, adds its link to the node
(up, away, resyncing), its monitors and its resyncs to every heartbeat, and closes it on the way out.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from blackboard import BlackboardClient

if TYPE_CHECKING:
    from runtime import ModuleRuntime

__all__ = ["BlackboardPart"]


class BlackboardPart:
    """Connect (or take) a blackboard client for a module runtime; report and close it."""

    def __init__(self, *, connect_timeout: float = 30.0, client: BlackboardClient | None = None) -> None:
        """Connect a client at start (waiting `connect_timeout` [s wall] for the node), or take `client` as it is."""
        self.connect_timeout = connect_timeout
        self.client = client

    async def start(self, rt: "ModuleRuntime") -> None:
        """Connect the client as `rt.bb`; raise RuntimeError naming the module when the node cannot be reached."""
        if self.client is None:
            try:
                self.client = await BlackboardClient.connect(rt.net, source=rt.name, connect_timeout=self.connect_timeout)
            except Exception as exc:  # noqa: BLE001 - any failure to reach the node ends the module, naming it
                raise RuntimeError(f"{rt.name}: cannot reach the blackboard node: {exc}") from exc
        rt.bb = self.client
        client = self.client
        rt.add_probe(lambda: client.awaiting_acks)

    def health(self) -> dict[str, Any]:
        """Return the client's link to the node, its monitors and its resyncs (the heartbeat's blackboard fields)."""
        c = self.client
        if c is None:
            return {}
        return {"blackboard": c.link_state, "monitors": c.monitor_count, "resyncs": c.resyncs}

    async def close(self) -> None:
        """Close the client."""
        if self.client is not None:
            await self.client.close()
