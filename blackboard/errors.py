"""Typed blackboard errors, carried on the wire as {"error": code, "message": text}."""

from __future__ import annotations

__all__ = [
    "BlackboardError",
    "BadRequestError",
    "UnknownTypeError",
    "InvalidTokenError",
    "TokenTooLargeError",
    "BadSpecError",
    "VersionConflictError",
    "NotFoundError",
    "UnknownFrameError",
    "ExtrapolationError",
    "PastExtrapolationError",
    "FutureExtrapolationError",
    "NodeUnavailableError",
    "StoreOpenError",
    "error_from_wire",
]


class BlackboardError(Exception):
    """Base of every error the blackboard raises or sends; `code` names it on the wire."""

    code = "blackboard_error"

    def __init__(self, message: str = "") -> None:
        super().__init__(message)
        self.message = message

    def to_wire(self) -> dict:
        """Return the wire form {"error": code, "message": text}."""
        return {"error": self.code, "message": self.message}


class StoreOpenError(BlackboardError):
    """The node's database cannot be opened: held by another node, unreadable, or not a database."""

    code = "store_open"


class BadRequestError(BlackboardError):
    """The payload could not be decoded (not msgpack/JSON, or not the expected shape)."""

    code = "bad_request"


class UnknownTypeError(BlackboardError):
    """The token type is not registered on the node (or in the client's registry)."""

    code = "unknown_type"


class InvalidTokenError(BlackboardError):
    """The token's attributes, geometry, frame or stamp do not validate."""

    code = "invalid_token"


class TokenTooLargeError(InvalidTokenError):
    """The token exceeds its type's limit of bytes or geometry points (`blackboard.limits`); the message names both."""

    code = "token_too_large"


class BadSpecError(BlackboardError):
    """The retrieval specification does not validate."""

    code = "bad_spec"


class VersionConflictError(BlackboardError):
    """Compare-and-set failed: the token's version is not the expected one."""

    code = "version_conflict"


class NotFoundError(BlackboardError):
    """No token with that id."""

    code = "not_found"


class UnknownFrameError(BlackboardError):
    """No frame of that name, or the two frames are not connected."""

    code = "unknown_frame"


class ExtrapolationError(BlackboardError):
    """The pose history does not cover the requested time."""

    code = "extrapolation"


class PastExtrapolationError(ExtrapolationError):
    """The requested time is older than the oldest pose kept [s]."""

    code = "past_extrapolation"


class FutureExtrapolationError(ExtrapolationError):
    """The requested time is newer than the newest pose received [s]."""

    code = "future_extrapolation"


class NodeUnavailableError(BlackboardError):
    """No blackboard node answered in time."""

    code = "node_unavailable"


_BY_CODE: dict[str, type[BlackboardError]] = {
    cls.code: cls
    for cls in (
        BlackboardError,
        BadRequestError,
        UnknownTypeError,
        InvalidTokenError,
        TokenTooLargeError,
        BadSpecError,
        VersionConflictError,
        NotFoundError,
        UnknownFrameError,
        ExtrapolationError,
        PastExtrapolationError,
        FutureExtrapolationError,
        NodeUnavailableError,
    )
}


def error_from_wire(obj: object) -> BlackboardError:
    """Return the typed exception for a wire error object (unknown codes give BlackboardError)."""
    if isinstance(obj, dict):
        cls = _BY_CODE.get(str(obj.get("error")), BlackboardError)
        return cls(str(obj.get("message", "")))
    return BlackboardError(f"malformed error reply: {obj!r}"[:500])
