"""`sidewalk security …`: issue the certificates, passwords and rules of a secure deployment."""

# No `from __future__ import annotations`: Typer reads the annotations.
from pathlib import Path
from typing import Annotated, Optional

import typer

__all__ = ["security_app"]

security_app = typer.Typer(help="Secure deployments: certificates, passwords and access rules (see docs/security.md).",
                           no_args_is_help=True)


def _names(text: Optional[str]) -> tuple[str, ...]:
    return tuple(n.strip() for n in (text or "").split(",") if n.strip())


@security_app.command("init")
def init(
    directory: Annotated[Path, typer.Argument(help="Directory to create (pass it to every command as --secure DIR)")],
    hosts: Annotated[Optional[str], typer.Option(help="Router hosts, comma-separated names or IPs (localhost and 127.0.0.1 always)")] = None,
    modules: Annotated[Optional[str], typer.Option(help="Extra roles to issue, comma-separated (the rules' roles always)")] = None,
    days: Annotated[int, typer.Option(min=1, help="Validity of the certificates [day]")] = 365,
    force: Annotated[bool, typer.Option("--force", help="Issue everything again in a non-empty directory")] = False,
) -> None:
    """Create a CA, a certificate per router host and per role, a password per role, and the rules file."""
    from sidewalk.security import SecurityError, init_secure_dir

    try:
        roles = init_secure_dir(directory, hosts=_names(hosts), extra_roles=_names(modules), force=force, days=days)
    except SecurityError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
    except OSError as exc:
        typer.echo(f"error: {directory}: {exc.strerror}", err=True)
        raise typer.Exit(2) from None
    typer.echo(f"secure directory {directory}: CA, hosts {', '.join(['localhost', '127.0.0.1', *_names(hosts)])}, "
               f"roles {', '.join(roles)}")
    typer.echo(f"edit {directory / 'rules.yaml'} to change who may do what; give each host only ca.pem, its own "
               "roles/<role>.* and credentials (the router needs all of credentials.txt); keep ca.key offline")


@security_app.command("acl")
def acl(directory: Annotated[Path, typer.Argument(help="Secure directory")]) -> None:
    """Print the Zenoh access control the router generates from DIR/rules.yaml (JSON)."""
    from sidewalk.security import SecurityError, access_control_json

    try:
        typer.echo(access_control_json(directory))
    except SecurityError as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(2) from None
