"""Wire forms of the CAPTAIN's Zenoh services (JSON, so a person or a standard Zenoh tool can speak them)."""

from __future__ import annotations

import secrets

import re

import json

from pydantic import BaseModel, ConfigDict, ValidationError

from modules.captain.missionfile import MissionFileError
from modules.captain.errors import CaptainError

__all__ = ["new_mission_id", "SubmitAccepted", "Rejection", "ProblemWire", "CancelRequest", "rejection_from", "parse_cancel", "WireError", "MAX_CANCEL_BYTES"]


class _Frozen(BaseModel):
    model_config = ConfigDict(frozen=True, extra="forbid")


class WireError(CaptainError, ValueError):
    """A request payload that cannot be understood."""


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


def rejection_from(exc: MissionFileError) -> Rejection:
    """Return the rejection for an invalid mission."""
    return Rejection(
        error="invalid_mission", message=str(exc),
        problems=tuple(ProblemWire(line=p.line, column=p.column, field=p.field, message=p.message) for p in exc.problems),
    )


class CancelRequest(_Frozen):
    """A cancel request: the mission id and an optional reason."""

    mission_id: str
    reason: str = "cancelled by request"


#: The largest cancel request accepted [bytes] (a mission id is a slug of at most 47 characters).
MAX_CANCEL_BYTES = 4096


def parse_cancel(payload: bytes) -> CancelRequest:
    """Return the cancel request in a payload: a bare mission id, or JSON {"mission_id": ..., "reason": ...}."""
    if len(payload) > MAX_CANCEL_BYTES:
        raise WireError(f"a cancel request of {len(payload)} bytes is too large (the limit is {MAX_CANCEL_BYTES} bytes)")
    text = payload.decode("utf-8", errors="replace").strip()
    if not text:
        raise WireError("cancel needs a mission id (text) or JSON {\"mission_id\": ...}")
    if text.startswith("{"):
        try:
            return CancelRequest.model_validate(json.loads(text))
        except (ValueError, ValidationError) as exc:
            raise WireError(f"bad cancel request: {str(exc)[:300]}") from None
    return CancelRequest(mission_id=text)


def new_mission_id(name: str) -> str:
    """Return a fresh mission id: the name's slug and 6 hex digits (a single key chunk)."""
    slug = re.sub(r"[^A-Za-z0-9_-]+", "-", name).strip("-")[:40] or "mission"
    return f"{slug}-{secrets.token_hex(3)}"
