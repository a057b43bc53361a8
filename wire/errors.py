"""The wire layer's errors: one root, typed subclasses, each with a wire code."""

from __future__ import annotations

__all__ = ["WireError", "ConnectError", "PayloadError", "SessionClosedError"]


class WireError(Exception):
    """Root of every error raised by `wire`."""

    code = "wire_error"


class ConnectError(WireError):
    """The Zenoh session could not be opened or reach its endpoints (the message names them)."""

    code = "connect"


class PayloadError(WireError):
    """A payload that cannot be decoded (the message says which key and what is wrong)."""

    code = "bad_request"


class SessionClosedError(WireError):
    """An operation on a session that has been closed."""

    code = "closed"
