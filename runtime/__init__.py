"""The module runtime: lifecycle, Zenoh session, sim clock, liveliness and heartbeat, shutdown.

A module is an async function `main(rt: ModuleRuntime)`; `run_module(name, main, net)` runs it.
"""

from wire.aio import GetReply, Link, QueryAnswer, QueryRequest
from wire.flags import add_network_args, network_from_args
from wire.keys import ModuleKeys
from wire.network import check_chunk as check_name
from runtime.flags import (
    VEHICLES, add_heartbeat, add_seed, add_start_pose, add_vehicle, config_flag_errors, module_parser, parse_module_args, parse_pose,
    setup_logging,
)
from runtime.clock import ClockNotRunningError, SimClock
from runtime.heartbeat import (
    ClockPayloadError, HeartbeatError, HeartbeatTracker, decode_clock, decode_heartbeat, encode_heartbeat,
)
from runtime.watch import HeartbeatWatch, ModuleWatch
from runtime.lifecycle import READY_PREFIX, ModuleMain, ModuleRuntime, RuntimePart, run_module, run_module_async

__all__ = [
    "GetReply", "QueryAnswer", "QueryRequest", "Link",
    "add_network_args", "network_from_args", "setup_logging",
    "VEHICLES", "add_heartbeat", "add_seed", "add_start_pose", "add_vehicle", "module_parser", "config_flag_errors", "parse_module_args", "parse_pose",
    "ClockNotRunningError", "SimClock",
    "ClockPayloadError", "HeartbeatError", "HeartbeatTracker", "decode_clock", "decode_heartbeat", "encode_heartbeat",
    "ModuleKeys", "check_name",
    "ModuleWatch", "HeartbeatWatch",
    "READY_PREFIX", "ModuleMain", "ModuleRuntime", "RuntimePart", "run_module", "run_module_async",
]
