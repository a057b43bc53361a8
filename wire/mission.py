"""The mission contract every mission service answers (the CAPTAIN under CODGER, EDDIE's mission service).

Keys (`wire.keys.MissionKeys`): `mission/submit` takes a mission (YAML or JSON text) and answers a
`SubmitAccepted` or a `Rejection`; `mission/status/<id>` (or `*`) answers the mission's status as JSON;
`mission/cancel` takes a `CancelRequest` (or a bare mission id) and answers the status or a
`Rejection`; `mission/events` carries every status as it changes. Statuses are the vocabulary's
`MissionStatus` (a blackboard token type under CODGER, the same JSON under EDDIE). Everything here is
JSON, so a person or a standard Zenoh tool can speak it.
"""

from __future__ import annotations

import json
import re
import secrets

from pydantic import BaseModel, ConfigDict, ValidationError

from wire.errors import PayloadError

__all__ = ["new_mission_id", "SubmitAccepted", "Rejection", "ProblemWire", "CancelRequest", "parse_cancel",
           "MissionRequestError", "MAX_CANCEL_BYTES"]


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class MissionRequestError(PayloadError, ValueError):
    """A mission request payload (a cancel) that cannot be understood."""


class SubmitAccepted(_Frozen):
    """The answer to an accepted mission: its id, name, step count and how many missions are ahead of it."""

    mission_id: str
    name: str
    steps: int
    queued_behind: int = 0


class ProblemWire(_Frozen):
    """One problem of a rejected mission: line, column, field, message."""

    line: int | None = None
    column: int | None = None
    field: str = ""
    message: str


class Rejection(_Frozen):
    """A refused request: error code, message, and the mission file problems if any."""

    error: str
    message: str
    problems: tuple[ProblemWire, ...] = ()

    def to_bytes(self) -> bytes:
        """Return the JSON wire form."""
        return self.model_dump_json().encode()


class CancelRequest(_Frozen):
    """A cancel request: the mission id and an optional reason."""

    mission_id: str
    reason: str = "cancelled by request"


#: The largest cancel request accepted [bytes] (a mission id is a slug of at most 47 characters).
MAX_CANCEL_BYTES = 4096


def parse_cancel(payload: bytes) -> CancelRequest:
    """Return the cancel request in a payload: a bare mission id, or JSON {"mission_id": ..., "reason": ...}."""
    if len(payload) > MAX_CANCEL_BYTES:
        raise MissionRequestError(f"a cancel request of {len(payload)} bytes is too large (the limit is {MAX_CANCEL_BYTES} bytes)")
    text = payload.decode("utf-8", errors="replace").strip()
    if not text:
        raise MissionRequestError("cancel needs a mission id (text) or JSON {\"mission_id\": ...}")
    if text.startswith("{"):
        try:
            return CancelRequest.model_validate(json.loads(text))
        except (ValueError, ValidationError) as exc:
            raise MissionRequestError(f"bad cancel request: {str(exc)[:300]}") from None
    return CancelRequest(mission_id=text)


def new_mission_id(name: str) -> str:
    """Return a fresh mission id: the name's slug and 6 hex digits (a single key chunk)."""
    slug = re.sub(r"[^A-Za-z0-9_-]+", "-", name).strip("-")[:40] or "mission"
    return f"{slug}-{secrets.token_hex(3)}"
