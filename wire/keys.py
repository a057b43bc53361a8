"""Every Zenoh key expression of Sidewalk, under `sidewalk/<ns>/…` (documented in docs/keys.md).

`Keys(ns)` gathers them: `Keys(ns).bb` (the CODGER blackboard), `.sim` (the simulator), `.mission`
(the CAPTAIN's services), `.eddie` (EDDIE's point-to-point inboxes and services), and the module
liveliness and heartbeat keys. Nothing else in the code base writes a key by hand.
"""

from __future__ import annotations

from wire.network import check_chunk

__all__ = ["Keys", "BlackboardKeys", "SimKeys", "MissionKeys", "EddieKeys", "ModuleKeys", "LockstepKeys", "root"]


def root(ns: str) -> str:
    """Return the root of namespace `ns`: `sidewalk/<ns>`."""
    return f"sidewalk/{check_chunk(ns, 'namespace')}"


class BlackboardKeys:
    """The blackboard's key expressions for one namespace."""

    def __init__(self, ns: str) -> None:
        self.ns = ns
        r = root(ns)
        base = f"{r}/bb"
        self.base = base
        #: queryable: one post (msgpack or JSON) → the stored token.
        self.post = f"{base}/post"
        #: queryable: a list of ops (post/update/delete/pose/static) → a list of results, one commit.
        self.batch = f"{base}/batch"
        #: subscription (client → node): msgpack [request_id, ops] on `write/<client>`; acked on `to/<client>`.
        self.write_prefix = f"{base}/write"
        #: publication (node → client) on `to/<client>`, one per commit: msgpack [acks, events].
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
        #: publication (node → frame caches): msgpack [epoch, seq, changes], one per commit that changed frames.
        self.frame_updates = f"{base}/frames/updates"
        #: queryable: the whole frame tree with its bounds, and the [epoch, seq] it is current to.
        self.frame_history = f"{base}/frames/history"
        #: queryable: register/cancel a monitor.
        self.monitor = f"{base}/monitor"
        #: queryable: node counters.
        self.stats = f"{base}/stats"
        #: liveliness token of the node.
        self.alive = f"{r}/alive/blackboard"
        #: liveliness tokens of clients (monitors are dropped when a client's token goes).
        self.client_alive_prefix = f"{r}/alive/bbclient"
        #: heartbeat published by the node every second.
        self.heartbeat = f"{r}/heartbeat/blackboard"

    def write(self, client: str) -> str:
        """Return the key a client publishes its write batches on."""
        return f"{self.write_prefix}/{client}"

    def to_client(self, client: str) -> str:
        """Return the key the node publishes a client's acknowledgements and monitor events on."""
        return f"{self.to_prefix}/{client}"

    def client_alive(self, client: str) -> str:
        """Return a client's liveliness key."""
        return f"{self.client_alive_prefix}/{client}"


class SimKeys:
    """The simulator's key expressions for one namespace."""

    def __init__(self, ns: str) -> None:
        self.ns = ns
        r = root(ns)
        base = f"{r}/sim"
        self.base = base
        #: published at publish_hz sim time: `SimClock` (msgpack)
        self.clock = f"{base}/clock"
        #: subscribed: `DriveCommand` (msgpack, or JSON)
        self.cmd = f"{base}/cmd"
        #: subscribed: `OdometrySlip` — the launcher's position-jump fault (evaluation only)
        self.slip = f"{base}/slip"
        #: published at publish_hz sim time: `Odometry` (local frame, drifts)
        self.odom = f"{base}/odom"
        #: published at publish_hz sim time: `TruthPose` (world frame) — evaluation and monitor only
        self.truth = f"{base}/truth"
        #: published when they happen: `SimEvent`
        self.events = f"{base}/events"
        #: queryable: `CaptureRequest` (msgpack/JSON/empty) → capture bytes at the current pose
        self.capture = f"{base}/capture"
        #: queryable: `CaptureRequest` → the capture WITH its truth fields — evaluation, monitor, recorder only
        #: (its own key so that access control can deny it; `capture` never carries truth)
        self.truth_capture = f"{base}/truth_capture"
        #: queryable: → `SimInfo` (msgpack; JSON if the query is JSON)
        self.info = f"{base}/info"
        #: queryable: → the map GeoJSON (JSON) the robot is told
        self.map = f"{base}/map"
        #: queryable: → the world GeoJSON (JSON) — evaluation and monitor only
        self.world = f"{base}/world"
        #: published (droppable) on every capture served: `SimPreview` (small JPEGs, no pose, no truth)
        self.preview = f"{base}/preview"
        #: queryable (lock-step only): let a simulator held at its start step on → `LockstepRelease` (msgpack/JSON)
        self.lockstep_release = f"{base}/lockstep/release"
        #: liveliness token while the node runs
        self.alive = f"{r}/alive/sim"
        #: heartbeat every wall second
        self.heartbeat = f"{r}/heartbeat/sim"


class MissionKeys:
    """The CAPTAIN's mission services for one namespace."""

    def __init__(self, ns: str) -> None:
        r = root(ns)
        #: queryable (JSON or YAML text) → `SubmitAccepted` / rejection
        self.submit = f"{r}/mission/submit"
        #: queryable (mission id or JSON) → the mission's status
        self.cancel = f"{r}/mission/cancel"
        #: publication, JSON: every mission status as it changes (a stream a tool can subscribe to)
        self.events = f"{r}/mission/events"
        self._status = f"{r}/mission/status"

    def status(self, mission_id: str = "*") -> str:
        """Return the mission status queryable key (one mission, or `*` for all)."""
        if mission_id != "*":
            check_chunk(mission_id, "mission id")
        return f"{self._status}/{mission_id}"


class EddieKeys:
    """EDDIE's keys for one namespace: each module's inbox, and the toolkit's services."""

    def __init__(self, ns: str) -> None:
        r = root(ns)
        self.base = f"{r}/eddie"

    def inbox(self, module: str) -> str:
        """Return the inbox key of EDDIE module `module` (messages sent to it)."""
        return f"{self.base}/inbox/{check_chunk(module, 'module name')}"

    def service(self, module: str, name: str) -> str:
        """Return the request/reply key of `module`'s service `name` (a queryable)."""
        return f"{self.base}/svc/{check_chunk(module, 'module name')}/{check_chunk(name, 'service name')}"

    def topic(self, module: str, name: str) -> str:
        """Return the key `module` publishes its stream `name` on (pushed to every subscriber)."""
        return f"{self.base}/pub/{check_chunk(module, 'module name')}/{check_chunk(name, 'stream name')}"


class LockstepKeys:
    """The lock-step barrier's keys for one namespace (see `wire.lockstep`)."""

    def __init__(self, ns: str) -> None:
        # a verbatim chunk (`@`): no wildcard matches it, so the recorder's and the monitor's `**` never hear the barrier
        self.base = f"{root(ns)}/@lockstep"
        #: liveliness tokens of the participants, one per process: `@lockstep/alive/<participant>`
        self.alive_all = f"{self.base}/alive/*"
        #: the barrier's ask, one put per wave that every participant receives
        self.ask = f"{self.base}/ask"
        #: every participant's answer (the barrier subscribes to them all)
        self.report_all = f"{self.base}/report/*"

    def alive(self, participant: str) -> str:
        """Return the liveliness key of `participant` (a process taking part in the barrier)."""
        return f"{self.base}/alive/{check_chunk(participant, 'participant name')}"

    def report(self, participant: str) -> str:
        """Return the key on which `participant` answers the barrier's asks."""
        return f"{self.base}/report/{check_chunk(participant, 'participant name')}"


class ModuleKeys:
    """Liveliness and heartbeat keys of the modules of one namespace, and the sim clock they follow."""

    def __init__(self, ns: str) -> None:
        self.ns = check_chunk(ns, "namespace")
        self.root = root(ns)
        self._mission = MissionKeys(ns)

    def alive(self, module: str) -> str:
        """Return the liveliness token key of `module` (declared once the module is ready)."""
        return f"{self.root}/alive/{check_chunk(module, 'module name')}"

    @property
    def alive_all(self) -> str:
        """Return the key expression matching every module's liveliness token."""
        return f"{self.root}/alive/*"

    @property
    def alive_everything(self) -> str:
        """Return the key expression matching every liveliness token (blackboard clients included)."""
        return f"{self.root}/alive/**"

    def heartbeat(self, module: str) -> str:
        """Return the heartbeat key of `module`."""
        return f"{self.root}/heartbeat/{check_chunk(module, 'module name')}"

    @property
    def heartbeat_all(self) -> str:
        """Return the key expression matching every module's heartbeat."""
        return f"{self.root}/heartbeat/*"

    @property
    def sim_clock(self) -> str:
        """Return the simulator's clock key (sim time [s])."""
        return f"{self.root}/sim/clock"

    @property
    def mission_submit(self) -> str:
        """Return the CAPTAIN's mission submission queryable key (YAML or JSON payload)."""
        return self._mission.submit

    def mission_status(self, mission_id: str = "*") -> str:
        """Return the CAPTAIN's mission status queryable key (one mission, or `*` for all)."""
        return self._mission.status(mission_id)

    @property
    def mission_cancel(self) -> str:
        """Return the CAPTAIN's mission cancel queryable key (payload: the mission id)."""
        return self._mission.cancel

    @property
    def mission_events(self) -> str:
        """Return the key the CAPTAIN publishes every mission status on (JSON stream)."""
        return self._mission.events


class Keys(ModuleKeys):
    """Every key of one namespace: module liveliness/heartbeats plus `.bb`, `.sim`, `.mission`, `.eddie`."""

    def __init__(self, ns: str) -> None:
        super().__init__(ns)
        self.bb = BlackboardKeys(ns)
        self.sim = SimKeys(ns)
        self.mission = self._mission
        self.eddie = EddieKeys(ns)
        self.lockstep = LockstepKeys(ns)

    def bench(self, name: str) -> str:
        """Return a key of the benchmarks' own traffic (the raw-Zenoh floors)."""
        return f"{self.root}/bench/{check_chunk(name, 'bench key')}"
