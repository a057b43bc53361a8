"""Security of a Sidewalk deployment: certificates and passwords (`sidewalk security init`), rules, access control."""

from sidewalk.security.acl import access_control, access_control_json
from sidewalk.security.authority import DEFAULT_HOSTS, init_secure_dir
from sidewalk.security.errors import SecurityError
from sidewalk.security.rules import DEFAULT_RULES_FILE, Family, Grant, Rules, load_rules

__all__ = [
    "access_control", "access_control_json", "init_secure_dir", "DEFAULT_HOSTS", "SecurityError",
    "DEFAULT_RULES_FILE", "Family", "Grant", "Rules", "load_rules",
]
