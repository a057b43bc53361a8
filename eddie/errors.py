"""EDDIE's errors: one root (`EddieError`), typed sub-errors each with a one-line message."""

from __future__ import annotations

__all__ = [
    "EddieError", "LinkError", "LinkTimeout", "NoSuchModule", "BadMessage", "UnknownMessageType",
    "ServiceError", "ControlRefused",
]


class EddieError(Exception):
    """Root of every error raised by `eddie`."""


class LinkError(EddieError):
    """A point-to-point link could not carry a message (the message names the module and key)."""


class LinkTimeout(LinkError, TimeoutError):
    """A request or receive got no answer in time (the message names the module and service)."""


class NoSuchModule(LinkError):
    """A request reached no module: nothing answers the service key (the message names it)."""


class BadMessage(EddieError, ValueError):
    """A payload that is not a valid EDDIE message; the message names the sender and the field."""

    def __init__(self, text: str, *, sender: str = "?", field: str = "") -> None:
        super().__init__(text)
        self.sender = sender
        self.field = field


class UnknownMessageType(BadMessage):
    """An envelope naming a message type this process does not know."""


class ServiceError(EddieError):
    """A service answered with an error (the message names the module, service and the reason)."""


class ControlRefused(EddieError):
    """A command refused by the controller (a higher-priority client holds control, or it is invalid)."""
