"""The errors of the security tools (certificates, rules, access control)."""

from __future__ import annotations

from sidewalk.errors import SidewalkError

__all__ = ["SecurityError"]


class SecurityError(SidewalkError):
    """A secure directory, rules file or role that cannot be used (the message names the file and what)."""
