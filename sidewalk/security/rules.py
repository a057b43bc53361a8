"""The access rules of a secure deployment: key families, and per role the families each operation may use.

The file (`DIR/rules.yaml`, a copy of `default_rules.yaml`; documented in docs/security.md) names
families of keys and grants each role operations on families; everything not granted is denied.
`sidewalk.security.acl` turns it into the router's Zenoh access control.
"""

from __future__ import annotations

from pathlib import Path

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError, field_validator, model_validator

from sidewalk.security.errors import SecurityError

__all__ = ["Family", "Grant", "Rules", "load_rules", "DEFAULT_RULES_FILE", "OPERATIONS", "ROLE_PLACEHOLDER"]

#: The file `sidewalk security init` copies into a secure directory.
DEFAULT_RULES_FILE = Path(__file__).with_name("default_rules.yaml")

#: The operations a role is granted on a family.
OPERATIONS = ("write", "read", "ask", "serve")

#: Written in a family's key, it stands for the role the family is granted to (`eddie/inbox/{role}`).
ROLE_PLACEHOLDER = "{role}"

_ROLE_CHARS = set("abcdefghijklmnopqrstuvwxyz0123456789_-")


def _check_role(r: str) -> str:
    if not r or not set(r) <= _ROLE_CHARS:
        raise ValueError(f"role {r!r} must use only lower-case letters, digits, '_' and '-'")
    return r


class Family(BaseModel):
    """A named set of keys (relative to `sidewalk/<ns>/`, Zenoh key expressions; `{role}` = the grantee)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    doc: str = ""
    keys: tuple[str, ...]

    @field_validator("keys")
    @classmethod
    def _check_keys(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        if not v:
            raise ValueError("a family needs at least one key")
        for k in v:
            if not k or k.startswith("/") or k.endswith("/") or "//" in k:
                raise ValueError(f"key {k!r} is not a key expression relative to sidewalk/<ns>/ (e.g. sim/cmd)")
        return v

    def keys_for(self, role: str) -> tuple[str, ...]:
        """Return the keys with `{role}` replaced by `role`."""
        return tuple(k.replace(ROLE_PLACEHOLDER, role) for k in self.keys)


class Grant(BaseModel):
    """What one role may do: per operation, the families it may use."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    doc: str = ""
    write: tuple[str, ...] = ()
    read: tuple[str, ...] = ()
    ask: tuple[str, ...] = ()
    serve: tuple[str, ...] = ()

    def families(self, op: str) -> tuple[str, ...]:
        """Return the families granted for operation `op`."""
        return getattr(self, op)


class Rules(BaseModel):
    """The families, what every role may do (`everyone`), and each role's own grant; the rest is denied."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    families: dict[str, Family]
    everyone: Grant = Grant()
    roles: dict[str, Grant]
    extra_roles: tuple[str, ...] = ()

    @field_validator("roles")
    @classmethod
    def _check_roles(cls, v: dict[str, Grant]) -> dict[str, Grant]:
        for r in v:
            _check_role(r)
        return v

    @field_validator("extra_roles")
    @classmethod
    def _check_extra(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        return tuple(_check_role(r) for r in v)

    @model_validator(mode="after")
    def _known_families(self) -> "Rules":
        for who, g in [("everyone", self.everyone), *((f"roles.{r}", g) for r, g in self.roles.items())]:
            for op in OPERATIONS:
                unknown = sorted(set(g.families(op)) - set(self.families))
                if unknown:
                    raise ValueError(f"{who}.{op}: unknown famil{'y' if len(unknown) == 1 else 'ies'} "
                                     f"{', '.join(unknown)} (define it under families)")
        return self

    @property
    def all_roles(self) -> tuple[str, ...]:
        """Return every role, listed and extra, once each."""
        return tuple(dict.fromkeys([*self.roles, *self.extra_roles]))

    def granted(self, role: str, op: str) -> tuple[str, ...]:
        """Return the families `role` may use for `op` (its own grant and everyone's)."""
        own = self.roles.get(role, Grant()).families(op)
        return tuple(dict.fromkeys([*self.everyone.families(op), *own]))

    def allows(self, role: str, op: str, family: str) -> bool:
        """Return whether `role` may `op` the keys of `family`."""
        return family in self.granted(role, op)


def load_rules(path: Path) -> Rules:
    """Read a rules file; raise SecurityError naming the file and what is wrong."""
    try:
        data = yaml.safe_load(Path(path).read_text())
    except OSError as exc:
        raise SecurityError(f"{path}: cannot read the rules: {exc.strerror}") from None
    except yaml.YAMLError as exc:
        raise SecurityError(f"{path}: not valid YAML: {str(exc).splitlines()[0]}") from None
    if not isinstance(data, dict):
        raise SecurityError(f"{path}: the rules must be a mapping with families:, everyone: and roles:")
    try:
        return Rules.model_validate(data)
    except ValidationError as exc:
        e = exc.errors()[0]
        where = ".".join(str(x) for x in e["loc"])
        msg = e["msg"].removeprefix("Value error, ")
        return_msg = f"{path}: {where + ': ' if where else ''}{msg}"
        raise SecurityError(return_msg) from None
