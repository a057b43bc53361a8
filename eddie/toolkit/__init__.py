"""EDDIE's toolkit: point-to-point links between named modules.

One concept per file: `message` (typed messages, their registry and envelope), `module` (a module's
endpoint: inbox, `send` / `request` / `receive`, services, streams; a part of the one module runtime,
`runtime/`). Processes are started, watched and restarted by the one supervisor, `sidewalk.supervisor`.
"""

from eddie.toolkit.message import (
    Envelope, Message, decode_body, decode_envelope, encode_body, encode_envelope, message_model, message_name,
    message_type, registered_types,
)
from eddie.toolkit.module import Incoming, Module, ModuleBody, ServiceHandler, endpoint

__all__ = [
    "Envelope", "Message", "decode_body", "decode_envelope", "encode_body", "encode_envelope", "message_model",
    "message_name", "message_type", "registered_types",
    "Incoming", "Module", "ModuleBody", "ServiceHandler", "endpoint",
]
