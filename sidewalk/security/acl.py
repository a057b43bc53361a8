"""Zenoh access control generated from the rules: what the router enforces.

Each guard and operation that names allowed roles becomes deny rules for every other role, matched
by its certificate's common name OR its user name: a connection is allowed a guarded operation only
when both its certificate and its password belong to allowed roles. The default is allow (keys no
guard names are open to every authenticated role).
"""

from __future__ import annotations

import json
from pathlib import Path

from sidewalk.security.rules import OPERATIONS, Rules, load_rules

__all__ = ["access_control", "access_control_json", "MESSAGES"]

#: The Zenoh messages (and their flow at the router) an operation is made of.
MESSAGES: dict[str, tuple[tuple[str, tuple[str, ...]], ...]] = {
    # the writer's put/delete coming in
    "write": (("ingress", ("put", "delete")),),
    # the reader's subscription and query coming in, and samples and replies going out to it
    "read": (("ingress", ("declare_subscriber", "query")), ("egress", ("put", "delete", "reply"))),
    # a service call coming in
    "ask": (("ingress", ("query",)),),
    # the server's queryable and replies coming in, and queries going out to it
    "serve": (("ingress", ("declare_queryable", "reply")), ("egress", ("query",))),
}


def access_control(rules: Rules, host_names: tuple[str, ...] = ()) -> dict:
    """Return the Zenoh `access_control` section for `rules` (zenoh 1.x schema).

    `host_names`: the common names of the router certificates, so that one used as a client
    certificate is still judged by its user name.
    """
    roles = rules.all_roles
    names = list(dict.fromkeys([*roles, *host_names]))
    # each subject names both attributes: zenoh matched none of two one-attribute subjects on one connection
    subjects = ([{"id": f"cert:{r}", "cert_common_names": [r], "usernames": list(roles)} for r in roles]
                + [{"id": f"user:{r}", "cert_common_names": names, "usernames": [r]} for r in roles])
    zrules: list[dict] = []
    policies: list[dict] = []
    for g in rules.guards:
        key_exprs = [f"sidewalk/*/{k}" for k in g.keys]
        for op in OPERATIONS:
            allowed = g.allowed(op)
            if allowed is None:
                continue
            denied = [r for r in roles if r not in allowed]
            if not denied:
                continue
            ids = []
            for flow, messages in MESSAGES[op]:
                rid = f"{g.name}:{op}:{flow}"
                zrules.append({"id": rid, "permission": "deny", "flows": [flow], "messages": list(messages), "key_exprs": key_exprs})
                ids.append(rid)
            policies.append({"id": f"{g.name}:{op}", "rules": ids,
                             "subjects": [f"cert:{r}" for r in denied] + [f"user:{r}" for r in denied]})
    return {"enabled": True, "default_permission": "allow", "rules": zrules, "subjects": subjects, "policies": policies}


def access_control_json(directory: Path) -> str:
    """Return the access control of secure directory `directory` (from its rules.yaml) as JSON text."""
    hosts = tuple(sorted(p.stem for p in (Path(directory) / "hosts").glob("*.pem")))
    return json.dumps(access_control(load_rules(Path(directory) / "rules.yaml"), hosts))
