"""Several clients, one vehicle: the client holding control and the priority it holds it with."""

from __future__ import annotations

__all__ = ["ClientArbiter"]


class ClientArbiter:
    """Grant control to a client unless a higher-priority one holds it; the holder may release it."""

    def __init__(self) -> None:
        self.holder: str | None = None
        self.priority: int | None = None

    def request(self, client: str, priority: int) -> tuple[bool, str]:
        """Return (granted, reason) for `client` asking with `priority`; granted takes control."""
        if self.holder is None or self.holder == client or priority >= (self.priority or 0):
            self.holder, self.priority = client, priority
            return True, ""
        return False, f"{self.holder!r} holds control at priority {self.priority} > {priority}"

    def release(self, client: str) -> bool:
        """Release control if `client` holds it; return whether it did."""
        if self.holder != client:
            return False
        self.holder = self.priority = None
        return True
