"""The system's Zenoh router: discovery and routing for every peer of one system (or one host).

`sidewalk up router` (and `sidewalk run`, first of all) runs one. Peers (modules, the blackboard
node, the simulator) connect to it, learn about each other through its gossip and open direct links;
tools connect to it as clients. It holds no Sidewalk state: restarting it costs a reconnection.
"""

from __future__ import annotations

import os
import socket
import sys
import threading
import time
from typing import TextIO

from wire.health import Heartbeat, encode_heartbeat, process_usage
from wire.keys import ModuleKeys
from wire.network import NetworkConfig
from wire.session import open_session, barrier_traffic, traffic

__all__ = ["serve_router", "ROUTER_READY"]

#: What the router prints on stdout once it listens.
ROUTER_READY = "router ready"


def serve_router(net: NetworkConfig, stop: threading.Event, *, out: TextIO | None = None,
                 heartbeat_period: float = 1.0, close_timeout: float = 5.0) -> bool:
    """Run a Zenoh router for `net` until `stop` is set; print the ready line once listening.

    Like every process it declares a liveliness token and publishes a heartbeat every
    `heartbeat_period` [s] wall, so `sidewalk status` tells a wedged router from a live one.
    Return whether its session closed within `close_timeout` [s] wall: a router holds no state, so
    its process may exit without waiting longer (every peer of a run going away at once with it).
    """
    if net.mode != "router":
        net = net.model_copy(update={"mode": "router"})
    s = open_session(net)
    try:
        s.wait_connected(name="router", cancelled=stop.is_set)  # returns at once unless it also connects somewhere
        keys = ModuleKeys(net.namespace)
        s.liveliness_token(keys.alive("router"))
        print(f"{ROUTER_READY} ns={net.namespace} listen={','.join(net.listen) or '-'} connect={','.join(net.connect) or '-'} zid={s.zid}",
              file=out or sys.stdout, flush=True)
        seq, host, pid = 0, socket.gethostname(), os.getpid()
        while not stop.is_set():
            seq += 1
            s.put(keys.heartbeat("router"), encode_heartbeat(Heartbeat(
                module="router", seq=seq, wall_time=time.time(), period_s=heartbeat_period, pid=pid, host=host, zenoh_sessions=1,
                usage=process_usage(traffic(), barrier_traffic()))))
            stop.wait(heartbeat_period)
    finally:
        closed = s.close_within(close_timeout, "router")
    return closed
