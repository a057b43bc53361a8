"""EDDIE's toolkit: point-to-point links between named modules, and start-up / monitoring of a configured system.

One concept per file: `message` (typed messages, their registry and envelope), `module` (a module's
endpoint: inbox, `send` / `request` / `receive`, services, streams; a part of the one module runtime,
`runtime/`), `system_config` (a system as a YAML file), `supervisor` (start, watch, restart).
"""

from eddie.toolkit.message import (
    Envelope, Message, decode_body, decode_envelope, encode_body, encode_envelope, message_model, message_name,
    message_type, registered_types,
)
from eddie.toolkit.module import Incoming, Module, ModuleBody, ServiceHandler, endpoint
from eddie.toolkit.supervisor import ModuleHealth, ModuleStatus, Supervisor
from eddie.toolkit.system_config import (
    DeliverySpec, LinkSpec, ModuleSpec, SystemConfig, load_system_config, parse_system_config,
)

__all__ = [
    "Envelope", "Message", "decode_body", "decode_envelope", "encode_body", "encode_envelope", "message_model",
    "message_name", "message_type", "registered_types",
    "Incoming", "Module", "ModuleBody", "ServiceHandler", "endpoint",
    "ModuleHealth", "ModuleStatus", "Supervisor",
    "DeliverySpec", "LinkSpec", "ModuleSpec", "SystemConfig", "load_system_config", "parse_system_config",
]
