"""Network settings shared by every Sidewalk process: namespace, Zenoh mode and endpoints.

The deployment (see README "Several hosts"): one Zenoh **router** per system (`sidewalk up router`,
started first by `sidewalk run`) listens on the system's endpoint; every module, the blackboard node,
the simulator, the observers and the command-line tools (`status`, `submit`, `cancel`, `bb …`) are
**clients** of it, and every message travels through it (`wire.flags`: direct peer links did not
survive a process stopped past its lease, eclipse-zenoh/zenoh#498). A process that listens itself
is a **peer** (others connect to it; tests and benchmarks do so without a router), and `--mode peer`
still gives peers that link to one another directly (each listens on an ephemeral port). Multicast
scouting is off: endpoints are explicit.
"""

from __future__ import annotations

import ipaddress
import json
from pathlib import Path
from typing import Any, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

__all__ = ["NetworkConfig", "SecureConfig", "DEFAULT_ENDPOINT", "Mode", "check_chunk"]

#: Where the system's router listens, and everything else connects, when no endpoint is given.
DEFAULT_ENDPOINT = "tcp/127.0.0.1:7447"

Mode = Literal["peer", "client", "router"]

_CHUNK_ALLOWED = set("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_-.")


def check_chunk(name: str, what: str = "name") -> str:
    """Return `name` if it is one key chunk (letters, digits, '_', '-', '.'); raise ValueError naming `what`."""
    if not name or not set(name) <= _CHUNK_ALLOWED:
        raise ValueError(f"{what} {name!r} must be non-empty and use only letters, digits, '_', '-', '.'")
    return name


def _host_of(endpoint: str) -> str:
    """Return the host part of `proto/host:port` (brackets of IPv6 removed)."""
    addr = endpoint.partition("/")[2].split("#", 1)[0]
    host = addr.rsplit(":", 1)[0] if ":" in addr else addr
    return host.strip("[]")


def _is_loopback(endpoint: str) -> bool:
    host = _host_of(endpoint)
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class SecureConfig(BaseModel):
    """`--secure DIR`: TLS with mutual certificates, user/password, and (on the router) access control.

    DIR is what `sidewalk security init` wrote: `ca.pem`, `roles/<role>.pem|.key` (the client
    certificate, common name = the role), `hosts/<host>.pem|.key` (a router's certificate, picked by
    the host of its listen endpoint), `credentials.txt` (`role:password` lines). The router's
    `access_control` (Zenoh JSON, generated from DIR/rules.yaml by `sidewalk up router`) rides along.
    """

    model_config = ConfigDict(frozen=True, extra="forbid")

    dir: Path
    role: str
    access_control: str = ""

    @field_validator("role")
    @classmethod
    def _check_role(cls, v: str) -> str:
        return check_chunk(v, "role")

    @property
    def ca(self) -> Path:
        """Return the CA certificate every process trusts."""
        return self.dir / "ca.pem"

    def role_files(self) -> tuple[Path, Path]:
        """Return this role's (certificate, private key) paths."""
        return self.dir / "roles" / f"{self.role}.pem", self.dir / "roles" / f"{self.role}.key"

    def host_files(self, host: str) -> tuple[Path, Path]:
        """Return the router certificate and key for listen host `host` (the loopback one for 0.0.0.0 / unknown hosts)."""
        hosts = self.dir / "hosts"
        for name in (host, "localhost"):
            if (hosts / f"{name}.pem").is_file():
                return hosts / f"{name}.pem", hosts / f"{name}.key"
        return hosts / f"{host}.pem", hosts / f"{host}.key"

    @property
    def credentials(self) -> Path:
        """Return the `role:password` dictionary."""
        return self.dir / "credentials.txt"

    def password(self) -> str:
        """Return this role's password from the credentials file; raise ValueError naming the file if it has none."""
        try:
            lines = self.credentials.read_text().splitlines()
        except OSError as exc:
            raise ValueError(f"--secure: cannot read {self.credentials}: {exc.strerror}") from None
        for line in lines:
            user, sep, pw = line.partition(":")
            if sep and user.strip() == self.role:
                return pw.strip()
        raise ValueError(f"--secure: {self.credentials} has no password for role {self.role!r} "
                         "(issue one with `sidewalk security init --modules ROLE`, or pick another --role)")

    def problems(self, listen_hosts: tuple[str, ...] = ()) -> list[str]:
        """Return what is missing in DIR for this role (empty: usable)."""
        if not self.dir.is_dir():
            return [f"--secure: {self.dir} is not a directory (create one with `sidewalk security init {self.dir}`)"]
        need = [self.ca, *self.role_files()] + [p for h in listen_hosts for p in self.host_files(h)]
        out = [f"--secure: {p} is missing (role {self.role!r}; issue it with `sidewalk security init`)"
               for p in need if not p.is_file()]
        if not out:
            try:
                self.password()
            except ValueError as exc:
                out.append(str(exc))
        return out

    def zenoh_json(self, mode: str, listen: tuple[str, ...]) -> dict[str, Any]:
        """Return the `transport` section (TLS, mutual TLS, user/password) and, for a router, `access_control`."""
        cert, key = self.role_files()
        tls: dict[str, Any] = {
            "root_ca_certificate": str(self.ca), "enable_mtls": True, "verify_name_on_connect": True,
            "connect_certificate": str(cert), "connect_private_key": str(key),
        }
        if listen:
            lcert, lkey = self.host_files(_host_of(listen[0]))
            tls["listen_certificate"], tls["listen_private_key"] = str(lcert), str(lkey)
        usrpwd: dict[str, Any] = {"user": self.role, "password": self.password()}
        if mode == "router" or listen:
            usrpwd["dictionary_file"] = str(self.credentials)
        out: dict[str, Any] = {"transport": {"link": {"tls": tls}, "auth": {"usrpwd": usrpwd}}}
        if self.access_control:
            out["access_control"] = json.loads(self.access_control)
        return out


class NetworkConfig(BaseModel):
    """Zenoh session settings and the key-expression namespace (`sidewalk/<namespace>/…`)."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    namespace: str = "default"
    mode: Mode = "peer"
    connect: tuple[str, ...] = ()
    listen: tuple[str, ...] = ()
    multicast_scouting: bool = False
    secure: SecureConfig | None = None
    #: the lease [s] this session announces: the others drop it after so long without a word (None: Zenoh's 10 s)
    lease_s: float | None = Field(default=None, ge=1.0, le=3600.0)

    @model_validator(mode="before")
    @classmethod
    def _secure_endpoints(cls, data: Any) -> Any:
        """With `secure`: `tcp/` endpoints become `tls/`, other transports are refused, and peers become clients.

        Access control is enforced by the router, so in a secure system every process talks through it.
        """
        if not isinstance(data, dict) or not data.get("secure"):
            return data
        data = dict(data)
        for field in ("connect", "listen"):
            eps = []
            for ep in data.get(field) or ():
                proto, sep, rest = str(ep).partition("/")
                if proto == "tcp":
                    ep = f"tls/{rest}"
                elif proto != "tls":
                    raise ValueError(f"endpoint {ep!r}: --secure needs tls/HOST:PORT (or tcp/HOST:PORT, rewritten to tls/)")
                eps.append(ep)
            data[field] = tuple(eps)
        if data.get("mode", "peer") == "peer":
            data["mode"] = "client"
        return data

    @field_validator("namespace")
    @classmethod
    def _check_namespace(cls, v: str) -> str:
        return check_chunk(v, "namespace")

    @field_validator("connect", "listen")
    @classmethod
    def _check_endpoints(cls, v: tuple[str, ...]) -> tuple[str, ...]:
        for ep in v:
            proto, sep, rest = ep.partition("/")
            if not sep or not proto or not rest:
                raise ValueError(f"endpoint {ep!r} is not of the form PROTO/ADDRESS (e.g. tcp/127.0.0.1:7447)")
        return v

    def with_defaults(self) -> "NetworkConfig":
        """Return a copy with the default endpoint filled in: a router listens on it, the others connect to it."""
        if self.connect or self.listen:
            return self
        default = (f"tls/{DEFAULT_ENDPOINT.partition('/')[2]}",) if self.secure else (DEFAULT_ENDPOINT,)
        if self.mode == "router":
            return self.model_copy(update={"listen": default})
        return self.model_copy(update={"connect": default})

    def as_tool(self) -> "NetworkConfig":
        """Return the settings a command-line tool uses: a client of the router (unless a mode was forced)."""
        return self.model_copy(update={"mode": "client"}) if self.mode == "peer" else self

    @property
    def endpoints(self) -> tuple[str, ...]:
        """Return every endpoint named (connect, then listen), for messages."""
        return self.connect + self.listen

    def peer_listen(self) -> tuple[str, ...]:
        """Return what a peer listens on so other peers can reach it directly (ephemeral port)."""
        if self.listen or self.mode != "peer":
            return self.listen
        if not self.connect or all(_is_loopback(ep) for ep in self.connect):
            return ("tcp/127.0.0.1:0",)
        return ("tcp/0.0.0.0:0",)

    def zenoh_json(self) -> dict:
        """Return the Zenoh configuration as a JSON-able dict (zenoh 1.x schema)."""
        cfg: dict = {
            "mode": self.mode,
            "scouting": {"multicast": {"enabled": self.multicast_scouting}, "gossip": {"enabled": True}},
        }
        if self.connect:
            cfg["connect"] = {"endpoints": list(self.connect)}
        listen = self.peer_listen()
        if listen:
            cfg["listen"] = {"endpoints": list(listen)}
        if self.secure is not None:
            cfg.update(self.secure.zenoh_json(self.mode, listen))
        if self.lease_s is not None:
            cfg.setdefault("transport", {}).setdefault("link", {})["tx"] = {"lease": round(self.lease_s * 1000)}
        return cfg

    def with_role(self, role: str) -> "NetworkConfig":
        """Return a copy whose secure identity is `role` (unchanged when not secure)."""
        if self.secure is None:
            return self
        return self.model_copy(update={"secure": self.secure.model_copy(update={"role": role, "access_control": ""})})
