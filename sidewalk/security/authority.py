"""The certificate authority of one secure deployment: a CA, router (host) and role certificates, passwords.

`init_secure_dir(DIR, hosts, roles)` writes the layout `wire.network.SecureConfig` reads:

    DIR/ca.pem                 the CA certificate (every process trusts it)
    DIR/ca.key                 the CA private key (0600; keep it off the robot once the files are issued)
    DIR/hosts/<host>.pem|.key  one certificate per router host (its name or IP as subjectAltName)
    DIR/roles/<role>.pem|.key  one client certificate per role (common name = the role)
    DIR/credentials.txt        `role:password` lines, the Zenoh user/password dictionary (0600)
    DIR/rules.yaml             the roles' access rules (copied from the default; edit it)

Keys are ECDSA P-256; certificates are valid for `days` [day].
"""

from __future__ import annotations

import datetime
import ipaddress
import os
import secrets
import shutil
from pathlib import Path

from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import ExtendedKeyUsageOID, NameOID

from sidewalk.security.errors import SecurityError
from sidewalk.security.rules import DEFAULT_RULES_FILE, load_rules

__all__ = ["init_secure_dir", "DEFAULT_HOSTS", "issue_certificate"]

#: The router hosts a secure directory always covers (loopback).
DEFAULT_HOSTS = ("localhost", "127.0.0.1")


def _write(path: Path, data: bytes, *, secret: bool) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600 if secret else 0o644)
    with os.fdopen(fd, "wb") as f:
        f.write(data)
    os.chmod(path, 0o600 if secret else 0o644)


def _key_pem(key: ec.EllipticCurvePrivateKey) -> bytes:
    return key.private_bytes(serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption())


def _name(cn: str) -> x509.Name:
    return x509.Name([x509.NameAttribute(NameOID.ORGANIZATION_NAME, "Sidewalk"), x509.NameAttribute(NameOID.COMMON_NAME, cn)])


def _san(names: list[str]) -> x509.SubjectAlternativeName:
    out: list[x509.GeneralName] = []
    for n in names:
        try:
            out.append(x509.IPAddress(ipaddress.ip_address(n)))
        except ValueError:
            out.append(x509.DNSName(n))
    return x509.SubjectAlternativeName(out)


def issue_certificate(ca_key: ec.EllipticCurvePrivateKey, ca_cert: x509.Certificate, cn: str, names: list[str],
                      days: int) -> tuple[bytes, bytes]:
    """Return (certificate PEM, private key PEM) for `cn`, signed by the CA, good as TLS server and client."""
    key = ec.generate_private_key(ec.SECP256R1())
    now = datetime.datetime.now(datetime.timezone.utc)
    cert = (
        x509.CertificateBuilder()
        .subject_name(_name(cn)).issuer_name(ca_cert.subject).public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5)).not_valid_after(now + datetime.timedelta(days=days))
        .add_extension(_san(names), critical=False)
        .add_extension(x509.BasicConstraints(ca=False, path_length=None), critical=True)
        .add_extension(x509.KeyUsage(digital_signature=True, key_encipherment=False, content_commitment=False,
                                     data_encipherment=False, key_agreement=True, key_cert_sign=False, crl_sign=False,
                                     encipher_only=False, decipher_only=False), critical=True)
        .add_extension(x509.ExtendedKeyUsage([ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH]), critical=False)
        .sign(ca_key, hashes.SHA256())
    )
    return cert.public_bytes(serialization.Encoding.PEM), _key_pem(key)


def _make_ca(days: int) -> tuple[ec.EllipticCurvePrivateKey, x509.Certificate]:
    key = ec.generate_private_key(ec.SECP256R1())
    now = datetime.datetime.now(datetime.timezone.utc)
    name = _name("Sidewalk CA")
    cert = (
        x509.CertificateBuilder()
        .subject_name(name).issuer_name(name).public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(now - datetime.timedelta(minutes=5)).not_valid_after(now + datetime.timedelta(days=days))
        .add_extension(x509.BasicConstraints(ca=True, path_length=0), critical=True)
        .add_extension(x509.KeyUsage(digital_signature=True, key_encipherment=False, content_commitment=False,
                                     data_encipherment=False, key_agreement=False, key_cert_sign=True, crl_sign=True,
                                     encipher_only=False, decipher_only=False), critical=True)
        .sign(key, hashes.SHA256())
    )
    return key, cert


def init_secure_dir(directory: Path, *, hosts: tuple[str, ...] = (), extra_roles: tuple[str, ...] = (),
                    force: bool = False, days: int = 365) -> list[str]:
    """Create the CA, host and role certificates, passwords and rules in `directory`; return the roles issued.

    Raise SecurityError if `directory` exists and is not empty (unless `force`: everything is re-issued).
    """
    directory = Path(directory)
    if directory.exists() and not directory.is_dir():
        raise SecurityError(f"{directory}: exists and is not a directory")
    if directory.exists() and any(directory.iterdir()) and not force:
        raise SecurityError(f"{directory}: exists and is not empty (use --force to issue everything again)")
    rules_text = DEFAULT_RULES_FILE.read_text()
    rules = load_rules(DEFAULT_RULES_FILE)
    roles = list(dict.fromkeys([*rules.roles, *extra_roles]))
    for r in extra_roles:
        if not r or not set(r) <= set("abcdefghijklmnopqrstuvwxyz0123456789_-"):
            raise SecurityError(f"--modules: role name {r!r} must use only lower-case letters, digits, '_' and '-'")
    if directory.exists() and force:
        for sub in ("hosts", "roles"):
            shutil.rmtree(directory / sub, ignore_errors=True)
    directory.mkdir(parents=True, exist_ok=True)
    os.chmod(directory, 0o700)
    ca_key, ca_cert = _make_ca(days)
    _write(directory / "ca.pem", ca_cert.public_bytes(serialization.Encoding.PEM), secret=False)
    _write(directory / "ca.key", _key_pem(ca_key), secret=True)
    for host in dict.fromkeys([*DEFAULT_HOSTS, *hosts]):
        names = [host, *DEFAULT_HOSTS] if host in DEFAULT_HOSTS else [host]
        cert, key = issue_certificate(ca_key, ca_cert, host, names, days)
        _write(directory / "hosts" / f"{host}.pem", cert, secret=False)
        _write(directory / "hosts" / f"{host}.key", key, secret=True)
    lines = []
    for role in roles:
        cert, key = issue_certificate(ca_key, ca_cert, role, [role], days)
        _write(directory / "roles" / f"{role}.pem", cert, secret=False)
        _write(directory / "roles" / f"{role}.key", key, secret=True)
        lines.append(f"{role}:{secrets.token_urlsafe(24)}")
    _write(directory / "credentials.txt", ("\n".join(lines) + "\n").encode(), secret=True)
    rules_path = directory / "rules.yaml"
    if not rules_path.exists() or force:
        text = rules_text
        if extra_roles:
            text += "\n# added by `sidewalk security init --modules`: no guarded permission until you list them above\n"
            text += "extra_roles: [" + ", ".join(extra_roles) + "]\n"
        _write(rules_path, text.encode(), secret=False)
    return roles
