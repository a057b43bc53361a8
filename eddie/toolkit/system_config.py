"""An EDDIE system as a YAML file: which modules (command, arguments, host), the links between them, and
how each subscriber gets each stream (pushed on every update, or answered on request).

```yaml
modules:
  - name: controller
    run: eddie.controller            # python -m <run>
    args: [--vehicle, navlab]
  - name: navigator
    run: eddie.navigator
    args: [--start-pose, "0,0,0"]
links:                               # who talks to whom (documentation and checks)
  - {from: navigator, to: controller}
delivery:                            # per subscriber, chosen at start-up
  - {publisher: navigator, stream: world_from_local, subscriber: map_manager, mode: push}
```
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from wire.network import check_chunk

from eddie.errors import SystemConfigError

__all__ = ["ModuleSpec", "LinkSpec", "DeliverySpec", "SystemConfig", "load_system_config", "parse_system_config"]

_FROZEN = ConfigDict(frozen=True, extra="forbid", populate_by_name=True)

#: Hosts the supervisor starts modules on itself (others are started there with `sidewalk up`).
LOCAL_HOSTS = ("", "localhost", "127.0.0.1", "local")


class ModuleSpec(BaseModel):
    """One module of the system: its name, the Python module run with `-m`, its arguments, its host."""

    model_config = _FROZEN

    name: str = Field(min_length=1)
    run: str = Field(min_length=1, pattern=r"^[A-Za-z_][A-Za-z0-9_.]*$")
    args: tuple[str, ...] = ()
    host: str = "localhost"
    env: dict[str, str] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _name_is_a_key_chunk(self) -> "ModuleSpec":
        check_chunk(self.name, "module name")
        return self

    @property
    def local(self) -> bool:
        """Return whether the supervisor starts this module on this host."""
        return self.host in LOCAL_HOSTS


class LinkSpec(BaseModel):
    """A point-to-point link: module `from` sends to or asks module `to`."""

    model_config = _FROZEN

    from_: str = Field(alias="from", min_length=1)
    to: str = Field(min_length=1)


class DeliverySpec(BaseModel):
    """How `subscriber` gets `publisher`'s `stream`: `push` (published on every update) or `request` (asks)."""

    model_config = _FROZEN

    publisher: str = Field(min_length=1)
    stream: str = Field(min_length=1)
    subscriber: str = Field(min_length=1)
    mode: Literal["push", "request"]


class SystemConfig(BaseModel):
    """A whole EDDIE system: modules, links, delivery choices."""

    model_config = _FROZEN

    modules: tuple[ModuleSpec, ...] = Field(min_length=1)
    links: tuple[LinkSpec, ...] = ()
    delivery: tuple[DeliverySpec, ...] = ()

    @model_validator(mode="after")
    def _references_exist(self) -> "SystemConfig":
        names = [m.name for m in self.modules]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"modules: name {dup[0]!r} given twice")
        known = set(names)
        for i, link in enumerate(self.links):
            for end, name in (("from", link.from_), ("to", link.to)):
                if name not in known:
                    raise ValueError(f"links.{i}.{end}: no module named {name!r}")
        for i, d in enumerate(self.delivery):
            if d.publisher not in known:
                raise ValueError(f"delivery.{i}.publisher: no module named {d.publisher!r}")
        return self

    def module(self, name: str) -> ModuleSpec:
        """Return the module named `name`; raise SystemConfigError."""
        for m in self.modules:
            if m.name == name:
                return m
        raise SystemConfigError(f"no module named {name!r} in the system configuration")

    def delivery_modes(self, publisher: str) -> dict[str, set[str]]:
        """Return, per stream of `publisher`, the delivery modes its subscribers chose."""
        out: dict[str, set[str]] = {}
        for d in self.delivery:
            if d.publisher == publisher:
                out.setdefault(d.stream, set()).add(d.mode)
        return out

    def argv(self, name: str) -> tuple[str, ...]:
        """Return the arguments after `python` that start module `name` (`-m run args --deliver stream=mode …`)."""
        m = self.module(name)
        extra: list[str] = []
        for stream, modes in sorted(self.delivery_modes(name).items()):
            for mode in sorted(modes):
                extra += ["--deliver", f"{stream}={mode}"]
        return ("-m", m.run, *m.args, *extra)


def parse_system_config(text: str, *, source: str = "<text>") -> SystemConfig:
    """Return the system configuration in YAML `text`; raise SystemConfigError naming `source` and the field."""
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}" if mark is not None else ""
        raise SystemConfigError(f"{source}:{where}: not valid YAML: {getattr(exc, 'problem', exc)}") from None
    if not isinstance(data, dict):
        raise SystemConfigError(f"{source}: a system configuration must be a mapping with `modules`")
    try:
        return SystemConfig.model_validate(data)
    except ValidationError as exc:
        e = exc.errors()[0]
        field = ".".join(str(x) for x in e["loc"]) or "<root>"
        msg = str(e["msg"]).removeprefix("Value error, ")
        raise SystemConfigError(f"{source}: {field}: {msg}") from None
    except ValueError as exc:  # a bad module name (wire's check)
        raise SystemConfigError(f"{source}: {exc}") from None


def load_system_config(path: str | Path) -> SystemConfig:
    """Return the system configuration in file `path`; raise SystemConfigError naming the file and the field."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise SystemConfigError(f"{p}: cannot read: {exc.strerror}") from None
    return parse_system_config(text, source=str(p))
