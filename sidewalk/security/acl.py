"""Zenoh access control generated from the rules: what the router enforces.

Default deny: a connection may do only what its role is granted. Its role is matched by its
certificate's common name AND its user name together (one subject per role), so a certificate
with another role's password — or a router's certificate — matches no role and may do nothing.
Each (operation, family) becomes allow rules on the Zenoh messages of the operation, both the
ones coming in from the connection and the ones the router sends out to it.
"""

from __future__ import annotations

import json
from pathlib import Path

from sidewalk.security.rules import OPERATIONS, ROLE_PLACEHOLDER, Rules, load_rules

__all__ = ["access_control", "access_control_json", "MESSAGES"]

#: The Zenoh messages (and their flow at the router) an operation is made of.
MESSAGES: dict[str, tuple[tuple[str, tuple[str, ...]], ...]] = {
    # the writer's put/delete and liveliness tokens coming in; the subscribers' and liveliness
    # subscribers' declarations going out to it (a client publishes only where someone listens)
    "write": (("ingress", ("put", "delete", "liveliness_token")),
              ("egress", ("declare_subscriber", "declare_liveliness_subscriber"))),
    # the reader's subscriptions coming in; samples and tokens going out to it (queries are `ask`)
    "read": (("ingress", ("declare_subscriber", "declare_liveliness_subscriber", "liveliness_query")),
             ("egress", ("put", "delete", "liveliness_token"))),
    # a query (a service call, or a served value) coming in, its reply (and the servers' declarations) going out
    "ask": (("ingress", ("query",)), ("egress", ("reply", "declare_queryable"))),
    # the server's queryable and replies coming in, and queries going out to it
    "serve": (("ingress", ("declare_queryable", "reply")), ("egress", ("query",))),
}


def _key_exprs(keys: tuple[str, ...]) -> list[str]:
    return [f"sidewalk/*/{k}" for k in keys]


def access_control(rules: Rules) -> dict:
    """Return the Zenoh `access_control` section for `rules` (zenoh 1.x schema)."""
    subjects = [{"id": r, "cert_common_names": [r], "usernames": [r]} for r in rules.all_roles]
    zrules: dict[str, dict] = {}
    policies: list[dict] = []
    for role in rules.all_roles:
        ids: list[str] = []
        for op in OPERATIONS:
            for fam_name in rules.granted(role, op):
                fam = rules.families[fam_name]
                personal = any(ROLE_PLACEHOLDER in k for k in fam.keys)
                keys = fam.keys_for(role)
                for flow, messages in MESSAGES[op]:
                    rid = f"{op}:{fam_name}{'@' + role if personal else ''}:{flow}"
                    zrules.setdefault(rid, {"id": rid, "permission": "allow", "flows": [flow], "messages": list(messages),
                                            "key_exprs": _key_exprs(keys)})
                    ids.append(rid)
        if ids:
            policies.append({"id": role, "rules": ids, "subjects": [role]})
    return {"enabled": True, "default_permission": "deny", "rules": list(zrules.values()), "subjects": subjects,
            "policies": policies}


def access_control_json(directory: Path) -> str:
    """Return the access control of secure directory `directory` (from its rules.yaml) as JSON text."""
    return json.dumps(access_control(load_rules(Path(directory) / "rules.yaml")))
