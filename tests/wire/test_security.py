"""`--secure`: mutual TLS, passwords and the router's access control, on real Zenoh with real processes.

A secure router (`sidewalk up router --secure DIR`) runs as a process, with the simulator where the
vehicle matters; the test's sessions connect to it under different roles through `wire.session`
(and, for the peers without credentials, through plain zenoh: no project code).
"""

from __future__ import annotations

import json
import shutil
import sys
import threading
from pathlib import Path

import pytest
import zenoh

from sidewalk.security import init_secure_dir
from tests.modules._procs import spawn, stop
from wire.drive import DriveCommand, Odometry, decode, encode
from wire.errors import ConnectError
from wire.flags import FlagError, network_config
from wire.keys import Keys
from wire.network import NetworkConfig, SecureConfig
from wire.ports import free_port
from wire.session import open_session

NS = "sectest"
K = Keys(NS)


@pytest.fixture(scope="module")
def secure_dir(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("secure") / "sec"
    init_secure_dir(d)
    return d


@pytest.fixture(scope="module")
def router(secure_dir):
    ep = f"tcp/127.0.0.1:{free_port()}"
    p = spawn([sys.executable, "-m", "sidewalk", "up", "router", "--ns", NS, "--listen", ep, "--secure", str(secure_dir)],
              "router ready")
    try:
        yield ep
    finally:
        stop(p)


def _session(ep: str, d: Path, role: str):
    s = open_session(NetworkConfig(namespace=NS, connect=(ep,), secure=SecureConfig(dir=d, role=role)))
    s.wait_connected(timeout=10, name=role)
    return s


def _plain(ep: str, tls: dict | None = None) -> "zenoh.Session":
    cfg: dict = {"mode": "client", "scouting": {"multicast": {"enabled": False}}, "connect": {"endpoints": [ep]}}
    if tls is not None:
        cfg["transport"] = {"link": {"tls": tls}}
    return zenoh.open(zenoh.Config.from_json5(json.dumps(cfg)))


def test_flags_rewrite_tcp_refuse_udp_and_name_the_role(secure_dir) -> None:
    net = network_config(ns=NS, connect=["tcp/127.0.0.1:7447"], listen=None, mode=None, role="peer",
                         secure=str(secure_dir), who="helm")
    assert net.connect == ("tls/127.0.0.1:7447",) and net.mode == "client" and net.secure.role == "helm"
    tool = network_config(ns=NS, connect=None, listen=None, mode=None, role="tool", secure=str(secure_dir))
    assert tool.connect == ("tls/127.0.0.1:7447",) and tool.secure.role == "operator"
    with pytest.raises(FlagError, match="tls/HOST:PORT"):
        network_config(ns=NS, connect=["udp/127.0.0.1:7447"], listen=None, mode=None, role="peer", secure=str(secure_dir), who="helm")
    with pytest.raises(FlagError, match="roles/nobody.pem is missing"):
        network_config(ns=NS, connect=None, listen=None, mode=None, role="tool", secure=str(secure_dir), who="nobody")
    with pytest.raises(FlagError, match="not a directory"):
        network_config(ns=NS, connect=None, listen=None, mode=None, role="tool", secure=str(secure_dir / "missing"))
    plain = network_config(ns=NS, connect=None, listen=None, mode=None, role="peer", who="helm")
    assert plain.secure is None and plain.connect == ("tcp/127.0.0.1:7447",)


def test_no_certificate_wrong_ca_or_wrong_password_cannot_connect(router, secure_dir, tmp_path) -> None:
    # no TLS at all: a plain tcp client on the TLS port
    with pytest.raises(zenoh.ZError):
        _plain(router.replace("tls/", "tcp/"))
    # TLS trusting the CA, but no client certificate (mutual TLS required)
    with pytest.raises(zenoh.ZError):
        _plain(router.replace("tcp/", "tls/"), {"root_ca_certificate": str(secure_dir / "ca.pem")})
    # a full set of credentials from another CA
    other = tmp_path / "other"
    init_secure_dir(other)
    with pytest.raises(ConnectError, match="check the certificate/password for role 'pilot'"):
        _session(router, other, "pilot")
    # the right certificate, the wrong password
    wrong = tmp_path / "wrong"
    shutil.copytree(secure_dir, wrong)
    (wrong / "credentials.txt").write_text("pilot:not-the-password\n")
    with pytest.raises(ConnectError, match="check the certificate/password for role 'pilot'"):
        _session(router, wrong, "pilot")
    # the right certificate and password
    s = _session(router, secure_dir, "pilot")
    assert s.connected()
    s.close()


def _collect(s, key: str, out: list, ev: threading.Event | None = None, n: int = 1) -> None:
    def cb(sample) -> None:
        out.append(sample.payload)
        if ev is not None and len(out) >= n:
            ev.set()

    s.subscribe(key, cb)


def test_only_the_helm_drives_the_simulator(router, secure_dir) -> None:
    """The real simulator, secure: the PILOT's drive commands never move it; the HELM's do."""
    sim = spawn([sys.executable, "-m", "sidewalk", "up", "sim", "--world", "campus", "--vehicle", "terregator", "--rtf", "4",
                 "--ns", NS, "--connect", router, "--secure", str(secure_dir)], "ready sim")
    pilot = helm = watcher = None
    try:
        pilot, helm = _session(router, secure_dir, "pilot"), _session(router, secure_dir, "helm")
        watcher = _session(router, secure_dir, "monitor")
        odo: list[Odometry] = []
        moved, quiet = threading.Event(), threading.Event()
        driver = {"s": pilot, "seq": 0, "since": None}

        def on_odom(sample) -> None:  # one drive command per odometry sample, from the current driver
            o = decode(Odometry, sample.payload)
            odo.append(o)
            driver["seq"] += 1
            if driver["since"] is None:
                driver["since"] = o.stamp
            driver["s"].put(K.sim.cmd, encode(DriveCommand(speed=1.0, curvature=0.0, seq=driver["seq"])))
            if driver["s"] is pilot and o.stamp - driver["since"] >= 3.0:
                quiet.set()
            if driver["s"] is helm and o.distance > 0.2:
                moved.set()

        watcher.subscribe(K.sim.odom, on_odom)
        assert quiet.wait(60), "no odometry from the simulator"
        assert max(o.distance for o in odo) == 0.0 and max(abs(o.v) for o in odo) == 0.0  # 3 s sim of PILOT commands: still
        driver["s"] = helm
        assert moved.wait(60), "the HELM's drive commands did not move the vehicle"
    finally:
        for s in (pilot, helm, watcher):
            if s is not None:
                s.close()
        stop(sim)


def test_only_evaluation_monitor_and_recorder_read_truth(router, secure_dir) -> None:
    sim = _session(router, secure_dir, "sim")
    pilot, recorder = _session(router, secure_dir, "pilot"), _session(router, secure_dir, "recorder")
    try:
        stolen: list[bytes] = []
        pilot_clock: list[bytes] = []
        seen: list[bytes] = []
        pilot_ready, recorder_ready = threading.Event(), threading.Event()
        _collect(pilot, K.sim.truth, stolen)
        _collect(pilot, "sidewalk/**", stolen)  # a wildcard subscription must not get truth either
        _collect(pilot, K.sim.clock, pilot_clock, pilot_ready, 5)  # declared after: once it hears, so would the others
        _collect(recorder, K.sim.truth, seen, recorder_ready, 5)
        i = 0
        while not (pilot_ready.is_set() and recorder_ready.is_set()) and i < 20000:
            i += 1
            sim.put(K.sim.truth, b"truth %d" % i)
            sim.put(K.sim.clock, b"clock %d" % i)
            pilot_ready.wait(0.005)
        assert pilot_ready.is_set() and recorder_ready.is_set()
        assert not [p for p in stolen if p.startswith(b"truth")], "the PILOT read truth"
        # the truth-bearing capture and the world file: served to the recorder, never to the PILOT
        def serve(q) -> None:
            q.reply(b"truth capture")
            q.finish()

        sim.queryable(K.sim.truth_capture, serve)
        sim.queryable(K.sim.world, serve)
        for key in (K.sim.truth_capture, K.sim.world):
            replies = []
            for _ in range(50):  # the queryable's declaration reaches the router asynchronously
                replies = recorder.get_blocking(key, timeout=2.0)
                if replies:
                    break
            assert [r.payload for r in replies] == [b"truth capture"]
            assert pilot.get_blocking(key, timeout=1.0) == []
            assert pilot.get_blocking(f"{K.sim.base}/*", timeout=1.0) == []  # nor by a wildcard query
    finally:
        for s in (sim, pilot, recorder):
            s.close()


def test_a_stolen_password_under_another_certificate_cannot_drive(router, secure_dir) -> None:
    """The PILOT's certificate with the HELM's user and password connects, but matches no role: it may do nothing.

    The HELM's own command, put after the mixed session's, arrives; none of the mixed session's does.
    """
    helm_pw = next(line.split(":", 1)[1] for line in (secure_dir / "credentials.txt").read_text().splitlines()
                   if line.startswith("helm:"))
    cfg = {"mode": "client", "scouting": {"multicast": {"enabled": False}}, "connect": {"endpoints": [router.replace("tcp/", "tls/")]},
           "transport": {"link": {"tls": {"root_ca_certificate": str(secure_dir / "ca.pem"), "enable_mtls": True,
                                          "connect_certificate": str(secure_dir / "roles" / "pilot.pem"),
                                          "connect_private_key": str(secure_dir / "roles" / "pilot.key")}},
                         "auth": {"usrpwd": {"user": "helm", "password": helm_pw}}}}
    mixed = zenoh.open(zenoh.Config.from_json5(json.dumps(cfg)))
    sim, helm = _session(router, secure_dir, "sim"), _session(router, secure_dir, "helm")
    try:
        cmds: list[DriveCommand] = []
        heard = threading.Event()

        def on_cmd(sample) -> None:
            cmds.append(decode(DriveCommand, sample.payload))
            if cmds[-1].seq == 10_000:
                heard.set()

        sim.subscribe(K.sim.cmd, on_cmd)
        for i in range(500):
            mixed.put(K.sim.cmd, encode(DriveCommand(speed=1.0, curvature=0.0, seq=i + 1)))
            if i % 50 == 49:  # the HELM's command after the mixed ones: once it arrives, theirs would have
                helm.put(K.sim.cmd, encode(DriveCommand(speed=0.0, curvature=0.0, seq=10_000)))
                if heard.wait(0.2):
                    break
        assert heard.is_set(), "the HELM's own command never reached the simulator"
        assert {c.seq for c in cmds} == {10_000}, "a drive command of the mixed credentials reached the simulator"
    finally:
        sim.close()
        helm.close()
        mixed.close()
