"""The access rules of a secure deployment: roles, and the guarded keys each operation is allowed on.

The file (`DIR/rules.yaml`, a copy of `default_rules.yaml`; documented in docs/security.md) lists the
roles and the guards; `sidewalk.security.acl` turns it into the router's Zenoh access control.
"""

from __future__ import annotations

from pathlib import Path

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError, field_validator, model_validator

from sidewalk.security.errors import SecurityError

__all__ = ["Guard", "Rules", "load_rules", "DEFAULT_RULES_FILE", "OPERATIONS"]

#: The file `sidewalk security init` copies into a secure directory.
DEFAULT_RULES_FILE = Path(__file__).with_name("default_rules.yaml")

#: The operations a guard can restrict.
OPERATIONS = ("write", "read", "ask", "serve")

_ROLE_CHARS = set("abcdefghijklmnopqrstuvwxyz0123456789_-")


class Guard(BaseModel):
    """Keys (relative to `sidewalk/<ns>/`) and, per operation, the roles allowed (None: not restricted)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    name: str
    doc: str = ""
    keys: tuple[str, ...]
    write: tuple[str, ...] | None = None
    read: tuple[str, ...] | None = None
    ask: tuple[str, ...] | None = None
    serve: tuple[str, ...] | None = None

    @field_validator("keys")
    @classmethod
    def _check_keys(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        if not v:
            raise ValueError("a guard needs at least one key")
        for k in v:
            if not k or k.startswith("/") or k.endswith("/") or "//" in k:
                raise ValueError(f"key {k!r} is not a key expression relative to sidewalk/<ns>/ (e.g. sim/cmd)")
        return v

    def allowed(self, op: str) -> tuple[str, ...] | None:
        """Return the roles allowed operation `op` on these keys (None: every role)."""
        return getattr(self, op)


class Rules(BaseModel):
    """Every role of the deployment and the guards on its keys."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    roles: tuple[str, ...]
    guards: tuple[Guard, ...] = ()
    extra_roles: tuple[str, ...] = ()

    @field_validator("roles", "extra_roles")
    @classmethod
    def _check_roles(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        for r in v:
            if not r or not set(r) <= _ROLE_CHARS:
                raise ValueError(f"role {r!r} must use only lower-case letters, digits, '_' and '-'")
        return v

    @model_validator(mode="after")
    def _known_roles(self) -> "Rules":
        known = set(self.all_roles)
        for g in self.guards:
            for op in OPERATIONS:
                unknown = sorted(set(g.allowed(op) or ()) - known)
                if unknown:
                    raise ValueError(f"guard {g.name!r} {op}: unknown role(s) {', '.join(unknown)} (add them to roles)")
        return self

    @property
    def all_roles(self) -> tuple[str, ...]:
        """Return every role, listed and extra, once each."""
        return tuple(dict.fromkeys([*self.roles, *self.extra_roles]))


def load_rules(path: Path) -> Rules:
    """Read a rules file; raise SecurityError naming the file and what is wrong."""
    try:
        data = yaml.safe_load(Path(path).read_text())
    except OSError as exc:
        raise SecurityError(f"{path}: cannot read the rules: {exc.strerror}") from None
    except yaml.YAMLError as exc:
        raise SecurityError(f"{path}: not valid YAML: {str(exc).splitlines()[0]}") from None
    if not isinstance(data, dict):
        raise SecurityError(f"{path}: the rules must be a mapping with roles: and guards:")
    try:
        return Rules.model_validate(data)
    except ValidationError as exc:
        e = exc.errors()[0]
        where = ".".join(str(x) for x in e["loc"])
        raise SecurityError(f"{path}: {where}: {e['msg']}") from None
