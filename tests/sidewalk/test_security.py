"""`sidewalk security init`, the rules file and its access control, and mission submit under `--secure`.

The submit test runs the router, the blackboard node and the CAPTAIN as secure processes and
`sidewalk submit` as the user would, once as a module's role and once as the operator.
"""

from __future__ import annotations

import json
import stat
import subprocess
import sys
from pathlib import Path

import pytest
from cryptography import x509

from sidewalk.security import SecurityError, access_control, init_secure_dir, load_rules
from tests.modules._procs import ROOT, spawn, stop
from wire.ports import free_port

MISSION = Path(__file__).parent / "data" / "short-hop.yaml"


def _sidewalk(*args: str, timeout: float = 90.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "sidewalk", *args], capture_output=True, text=True, timeout=timeout, cwd=ROOT)


def test_init_issues_a_ca_certificates_and_secret_files(tmp_path) -> None:
    d = tmp_path / "sec"
    r = _sidewalk("security", "init", str(d), "--hosts", "10.1.2.3,robot-a", "--modules", "lidar")
    assert r.returncode == 0, r.stderr
    ca = x509.load_pem_x509_certificate((d / "ca.pem").read_bytes())
    helm = x509.load_pem_x509_certificate((d / "roles" / "helm.pem").read_bytes())
    assert helm.issuer == ca.subject and helm.subject.get_attributes_for_oid(x509.NameOID.COMMON_NAME)[0].value == "helm"
    helm.verify_directly_issued_by(ca)
    host = x509.load_pem_x509_certificate((d / "hosts" / "10.1.2.3.pem").read_bytes())
    san = host.extensions.get_extension_for_class(x509.SubjectAlternativeName).value
    assert [str(ip) for ip in san.get_values_for_type(x509.IPAddress)] == ["10.1.2.3"]
    assert (d / "roles" / "lidar.pem").is_file() and (d / "hosts" / "robot-a.pem").is_file()
    for secret in ("ca.key", "credentials.txt", "roles/helm.key", "hosts/robot-a.key"):
        assert stat.S_IMODE((d / secret).stat().st_mode) == 0o600, secret
    users = [line.split(":")[0] for line in (d / "credentials.txt").read_text().splitlines()]
    assert {"helm", "pilot", "operator", "evaluation", "lidar"} <= set(users) and len(set(users)) == len(users)
    assert "lidar" in load_rules(d / "rules.yaml").all_roles
    # a non-empty directory is refused with one line, unless --force
    again = _sidewalk("security", "init", str(d))
    assert again.returncode == 2 and "not empty" in again.stderr and "Traceback" not in again.stderr
    forced = _sidewalk("security", "init", str(d), "--force")
    assert forced.returncode == 0 and (d / "ca.pem").read_bytes() != ca.public_bytes(__import__("cryptography").hazmat.primitives.serialization.Encoding.PEM)


def test_rules_become_allow_policies_for_each_role_and_deny_the_rest(tmp_path) -> None:
    d = tmp_path / "sec"
    init_secure_dir(d)
    rules = load_rules(d / "rules.yaml")
    acl = access_control(rules)
    assert acl["enabled"] and acl["default_permission"] == "deny"
    # one subject per role: its certificate AND its password (a mixed pair matches no role)
    assert {"id": "pilot", "cert_common_names": ["pilot"], "usernames": ["pilot"]} in acl["subjects"]
    rules_by_id = {r["id"]: r for r in acl["rules"]}
    policy = {p["id"]: set(p["rules"]) for p in acl["policies"]}
    drivers = {role for role, ids in policy.items() if "write:drive:ingress" in ids}
    assert drivers == {"helm", "controller"}
    assert rules_by_id["write:drive:ingress"]["key_exprs"] == ["sidewalk/*/sim/cmd"]
    assert {"put", "delete"} <= set(rules_by_id["write:drive:ingress"]["messages"])
    assert {role for role, ids in policy.items() if "ask:truth:ingress" in ids} == {"monitor", "recorder", "evaluation"}
    assert {role for role, ids in policy.items() if "ask:missions:ingress" in ids} == {"operator"}
    # `{role}` keys are the grantee's own: the navigator reads its inbox, not the controller's
    assert rules_by_id["read:own-inbox@navigator:ingress"]["key_exprs"] == ["sidewalk/*/eddie/inbox/navigator"]
    assert "read:own-inbox@navigator:ingress" not in policy["controller"]
    # a bad rules file is named, with what is wrong
    (d / "rules.yaml").write_text("families: {drive: {keys: [sim/cmd]}}\nroles:\n  helm: {write: [drive, ghost]}\n")
    with pytest.raises(SecurityError, match=r"rules.yaml: .*roles.helm.write: unknown family ghost"):
        load_rules(d / "rules.yaml")
    r = _sidewalk("security", "acl", str(d))
    assert r.returncode == 2 and "ghost" in r.stderr and "Traceback" not in r.stderr


def test_only_the_operator_submits_a_mission(tmp_path) -> None:
    d = tmp_path / "sec"
    init_secure_dir(d)
    ep = f"tcp/127.0.0.1:{free_port()}"
    net = ["--ns", "secsubmit", "--connect", ep, "--secure", str(d)]
    procs = [spawn([sys.executable, "-m", "sidewalk", "up", "router", "--ns", "secsubmit", "--listen", ep, "--secure", str(d)],
                   "router ready")]
    try:
        procs.append(spawn([sys.executable, "-m", "sidewalk", "up", "blackboard", *net, "--types", "modules.vocabulary"],
                           "blackboard ready"))
        procs.append(spawn([sys.executable, "-m", "sidewalk", "up", "captain", *net], "SIDEWALK-READY captain"))
        denied = _sidewalk("submit", str(MISSION), "--no-follow", "--timeout", "3", *net, "--role", "pilot")
        assert denied.returncode == 3 and "mission accepted" not in denied.stdout, denied.stdout + denied.stderr
        ok = _sidewalk("submit", str(MISSION), "--no-follow", "--timeout", "20", *net)  # tools act as the operator
        assert ok.returncode == 0 and "mission accepted" in ok.stdout, ok.stdout + ok.stderr
        st = _sidewalk("status", "--json", "--heartbeat-wait", "0", *net)
        assert st.returncode == 0, st.stderr
        assert len(json.loads(st.stdout)["missions"]) == 1  # only the operator's mission reached the CAPTAIN
        nocert = _sidewalk("status", "--ns", "secsubmit", "--connect", ep, "--timeout", "1")  # no --secure at all
        assert nocert.returncode != 0
    finally:
        for p in reversed(procs):
            stop(p)
