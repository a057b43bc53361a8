"""Every key an EDDIE module's code uses is granted to its role by the default rules (no network).

`test_security_rules.py` checks the router against the rules file; this checks the rules file against
the code: each EDDIE module's source (and the helpers it imports from the modules' packages) is read for what it
sends (`send` → write the destination's inbox), asks (`request` → ask a service), subscribes to
(`subscribe` → read a stream), publishes and serves, and which simulator keys it puts, subscribes to
or queries; every one of those keys must be granted to the module's role for that operation. A new
call in a module without its grant fails here, before a secure run silently stops driving.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

from sidewalk.security import load_rules
from sidewalk.security.rules import Rules
from tests.sidewalk.test_security_rules import _allowed
from wire.keys import EddieKeys, ModuleKeys, SimKeys, root

EDDIE = Path(__file__).resolve().parents[2] / "eddie"
RULES = Path(__file__).resolve().parents[2] / "sidewalk" / "security" / "default_rules.yaml"
NS = "ns"
BASE = root(NS) + "/"

#: role → the file its process runs
MODULES = {
    "controller": "controller/controller_module.py",
    "navigator": "navigator/navigator_module.py",
    "map_manager": "map_manager/map_manager_module.py",
    "mission_service": "mission_service/mission_service.py",
    "road_following": "road_following/road_following_module.py",
    "landmark_matching": "landmark_matching/landmark_matching_module.py",
    "obstacle_stop": "obstacle_stop/obstacle_stop_module.py",
}

_ARG = r"""(?:"(\w+)"|([\w.]+))"""  # a literal module name, or an expression naming it (self.controller)


def _sources(rel: str) -> str:
    """Return the module file's text and the source of each helper (function, class) it imports from the EDDIE modules' packages."""
    text = (EDDIE / rel).read_text()
    parts = [text]
    for pkg, helper, names in re.findall(
            r"^from eddie\.(modules|road_following|landmark_matching|obstacle_stop|mission_service)\.(\w+) import ([\w, ]+)$", text, re.M):
        wanted = {n.strip() for n in names.split(",")}
        src = (EDDIE / pkg / f"{helper}.py").read_text()
        parts += [ast.get_source_segment(src, node) or "" for node in ast.parse(src).body
                  if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and node.name in wanted]
    return "\n".join(parts)


def _name(literal: str, expr: str) -> str | None:
    """Return the module a call names: the literal, else the module an expression ends with (None: any module)."""
    if literal:
        return literal
    last = expr.rsplit(".", 1)[-1]
    return last if last in MODULES else None


def _sim_key(attr: str) -> str:
    return getattr(SimKeys(NS), attr).removeprefix(BASE)


def uses(role: str) -> set[tuple[str, str]]:
    """Return the (operation, key relative to the namespace root) pairs `role`'s code uses."""
    src = _sources(MODULES[role])
    ek = EddieKeys(NS)
    rel = lambda key: key.removeprefix(BASE)  # noqa: E731
    out: set[tuple[str, str]] = {("read", rel(ek.inbox(role))), ("read", rel(ModuleKeys(NS).sim_clock)),
                                 ("write", rel(ModuleKeys(NS).heartbeat(role))), ("write", rel(ModuleKeys(NS).alive(role)))}
    for lit, expr in re.findall(rf"\.send\({_ARG}", src):
        dests = [_name(lit, expr)] if _name(lit, expr) else list(MODULES)  # a destination read from data: any inbox
        out |= {("write", rel(ek.inbox(d))) for d in dests}
    for lit, expr, svc in re.findall(rf"\.request\({_ARG},\s*\"(\w+)\"", src):
        out.add(("ask", rel(ek.service(_name(lit, expr) or "x", svc))))
    for lit, expr, stream in re.findall(rf"\.subscribe\({_ARG},\s*\"(\w+)\"", src):
        out.add(("read", rel(ek.topic(_name(lit, expr) or "x", stream))))
    out |= {("write", rel(ek.topic(role, s))) for s in re.findall(r"\.publish\(\"(\w+)\"", src)}
    out |= {("serve", rel(ek.service(role, s))) for s in re.findall(r"\.serve\(\"(\w+)\"", src)}
    out |= {("write", _sim_key(a)) for a in re.findall(r"link\.put\((?:self\.)?sim\.(\w+)", src)}
    out |= {("read", _sim_key(a)) for a in re.findall(r"link\.subscribe\((?:self\.)?sim\.(\w+)", src)}
    out |= {("ask", _sim_key(a)) for a in re.findall(r"SimKeys\([^)]*\)\.(\w+)", src)}
    return out


@pytest.fixture(scope="module")
def rules() -> Rules:
    return load_rules(RULES)


@pytest.mark.parametrize("role", sorted(MODULES))
def test_every_key_an_eddie_module_uses_is_granted_to_its_role(rules, role):
    used = uses(role)
    denied = sorted((op, key) for op, key in used if not _allowed(rules, role, op, key))
    assert not denied, f"{role} uses keys its role is not granted in {RULES.name}: {denied}"


def test_the_scan_finds_what_the_perception_modules_do(rules):
    """The scan is not vacuous: the perception modules' known traffic is found (and a stranger's is refused)."""
    rf, ob, lm = uses("road_following"), uses("obstacle_stop"), uses("landmark_matching")
    assert {("write", "eddie/inbox/controller"), ("write", "eddie/inbox/navigator"), ("ask", "eddie/svc/mission_service/route"),
            ("ask", "sim/capture"), ("read", "eddie/pub/controller/state"), ("read", "eddie/pub/navigator/world_from_local")} <= rf
    assert {("read", "eddie/pub/controller/path"), ("write", "eddie/pub/obstacle_stop/seen"), ("write", "eddie/inbox/controller")} <= ob
    assert ("write", "eddie/inbox/navigator") in lm and ("write", "eddie/inbox/controller") not in lm
    assert ("write", "sim/cmd") in uses("controller") and ("read", "sim/odom") in uses("controller")
    assert not _allowed(rules, "landmark_matching", "write", "eddie/inbox/controller")
    assert not _allowed(rules, "road_following", "write", "sim/cmd")
