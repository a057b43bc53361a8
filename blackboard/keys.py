"""Key expressions of the blackboard under `sidewalk/<ns>/…` (documented in docs/keys.md)."""

from __future__ import annotations

__all__ = ["BlackboardKeys"]


class BlackboardKeys:
    """The blackboard's key expressions for one namespace."""

    def __init__(self, ns: str) -> None:
        self.ns = ns
        base = f"sidewalk/{ns}/bb"
        self.base = base
        #: queryable: one post (msgpack or JSON) → the stored token.
        self.post = f"{base}/post"
        #: queryable: a list of ops (post/update/delete/pose/static) → a list of results, one commit.
        self.batch = f"{base}/batch"
        #: subscription (client → node): msgpack [request_id, ops] on `write/<client>`; acked on `to/<client>`.
        self.write_prefix = f"{base}/write"
        #: publication (node → client) on `to/<client>`, one per commit: msgpack [acks, events],
        #: acks [[request_id, results], …] (after the commit), events [[mid, [event, …]], …].
        self.to_prefix = f"{base}/to"
        #: queryable: one update (compare-and-set on version) → the new token.
        self.update = f"{base}/update"
        #: queryable: one delete → {"id": id}.
        self.delete = f"{base}/delete"
        #: queryable: payload is a Spec; selector parameters frame=F;stamp=S → list of tokens.
        self.retrieve = f"{base}/retrieve"
        #: queryable: {"target","target_stamp","source","source_stamp"} → [x, y, yaw].
        self.lookup = f"{base}/lookup"
        #: queryable: the frame tree (edges, newest stamps).
        self.frames = f"{base}/frames"
        #: queryable: register/cancel a monitor {"client","mid","spec"} / {"client","mid","cancel":true}.
        self.monitor = f"{base}/monitor"
        #: queryable: node counters.
        self.stats = f"{base}/stats"
        #: liveliness token of the node.
        self.alive = f"sidewalk/{ns}/alive/blackboard"
        #: liveliness tokens of clients (monitors are dropped when a client's token goes).
        self.client_alive_prefix = f"sidewalk/{ns}/alive/bbclient"
        #: heartbeat published by the node every second (msgpack {"t": wall time [s], "tokens": n}).
        self.heartbeat = f"sidewalk/{ns}/heartbeat/blackboard"

    def write(self, client: str) -> str:
        """Return the key a client publishes its write batches on."""
        return f"{self.write_prefix}/{client}"

    def to_client(self, client: str) -> str:
        """Return the key the node publishes a client's acknowledgements and monitor events on."""
        return f"{self.to_prefix}/{client}"

    def client_alive(self, client: str) -> str:
        """Return a client's liveliness key."""
        return f"{self.client_alive_prefix}/{client}"
