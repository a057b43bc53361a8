"""Talk to a system's mission service over Zenoh (the mission contract, `wire.mission`): submit, status, cancel.

The same client serves both architectures: the CAPTAIN under CODGER and EDDIE's mission service
answer the same keys with the same forms.
"""

from __future__ import annotations

from modules.vocabulary import MissionStatus
from sidewalk.errors import SidewalkError
from wire.aio import Link
from wire.keys import ModuleKeys
from wire.mission import Rejection, SubmitAccepted

__all__ = ["MissionClient", "MissionRejected", "MissionServiceUnavailable"]


class MissionRejected(SidewalkError):
    """The mission service refused the request; `rejection` says why (and, for a bad mission, where)."""

    def __init__(self, rejection: Rejection) -> None:
        super().__init__(rejection.message)
        self.rejection = rejection


class MissionServiceUnavailable(SidewalkError):
    """No mission service (the CAPTAIN or EDDIE's) answered in time."""


class MissionClient:
    """Mission submission, status and cancel over an open Zenoh link, in namespace `keys.ns`."""

    def __init__(self, link: Link, keys: ModuleKeys, *, timeout: float = 10.0) -> None:
        self.link = link
        self.keys = keys
        self.timeout = timeout

    async def _one(self, selector: str, payload: bytes | None) -> bytes:
        replies = await self.link.get(selector, payload=payload, timeout=self.timeout)
        if not replies:
            raise MissionServiceUnavailable(f"no CAPTAIN (or mission service) answered on {selector} within {self.timeout:.0f} s")
        r = replies[0]
        if not r.ok:
            try:
                rej = Rejection.model_validate_json(r.payload)
            except ValueError:
                rej = Rejection(error="error", message=r.payload.decode("utf-8", errors="replace"))
            raise MissionRejected(rej)
        return r.payload

    async def submit(self, text: str | bytes) -> SubmitAccepted:
        """Submit a mission (YAML or JSON); return the acceptance or raise MissionRejected."""
        data = text.encode() if isinstance(text, str) else text
        return SubmitAccepted.model_validate_json(await self._one(self.keys.mission_submit, data))

    async def status(self, mission_id: str) -> MissionStatus:
        """Return a mission's status; raise MissionRejected for an unknown id."""
        return MissionStatus.model_validate_json(await self._one(self.keys.mission_status(mission_id), None))

    async def statuses(self) -> list[MissionStatus]:
        """Return the status of every mission the CAPTAIN knows."""
        replies = await self.link.get(self.keys.mission_status("*"), timeout=self.timeout)
        return [MissionStatus.model_validate_json(r.payload) for r in replies if r.ok]

    async def cancel(self, mission_id: str, reason: str = "cancelled by request") -> MissionStatus:
        """Cancel a mission; return its status, or raise MissionRejected (unknown or already finished)."""
        import json

        payload = json.dumps({"mission_id": mission_id, "reason": reason}).encode()
        return MissionStatus.model_validate_json(await self._one(self.keys.mission_cancel, payload))
