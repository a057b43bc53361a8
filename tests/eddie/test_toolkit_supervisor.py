"""The supervisor starts a configured 2-module system as real processes, hears heartbeats, reports a killed module."""

from __future__ import annotations

import os
import signal

import pytest

from eddie.errors import SupervisorError, SystemConfigError
from eddie.toolkit import Module, Supervisor, load_system_config, parse_system_config
from eddie.toolkit.echo import Echo
from tests.eddie._net import net_pair, retry

SYSTEM = """
modules:
  - {name: one, run: eddie.toolkit.echo, args: [one]}
  - {name: two, run: eddie.toolkit.echo, args: [two]}
links:
  - {from: one, to: two}
delivery:
  - {publisher: one, stream: echoes, subscriber: two, mode: request}
"""


async def test_supervisor_starts_watches_and_reports_a_killed_module(tmp_path):
    listen, connect, ep = net_pair(f"sup{os.getpid()}")
    cfg = parse_system_config(SYSTEM.replace("args: [one]}", "args: [one]}"))
    assert cfg.argv("one")[-2:] == ("--deliver", "echoes=request")
    cfg = parse_system_config(SYSTEM.replace("\ndelivery:\n  - {publisher: one, stream: echoes, subscriber: two, mode: request}", ""))
    async with Supervisor(cfg, listen, tmp_path, connect=(ep,), wedged_after=3.0) as sup:
        await sup.start_all(timeout=180.0)
        await sup.wait_for("one", "ready", 20.0)
        assert (await sup.wait_heartbeat("one", 20.0)).heartbeat_age_s is not None  # its ready line may come before its first beat
        await sup.wait_for("two", "ready", 20.0)
        async with Module("tester", connect) as me:
            await me.wait_connected(10.0)
            # a session just connected may not yet have the router's route to two's queryable: ask until it has
            reply = await retry(lambda: me.request("two", "echo", Echo(seq=5, data=b"x"), timeout=5.0, reply_type=Echo))
            assert reply == Echo(seq=5, data=b"x")
        os.kill(sup.pid("two"), signal.SIGKILL)
        st = await sup.wait_for("two", "dead", 20.0)
        assert st.returncode == -signal.SIGKILL
        await sup.wait_for("one", "ready", 20.0)
        os.kill(sup.pid("one"), signal.SIGSTOP)  # wedged: token alive, heartbeat silent
        try:
            await sup.wait_for("one", "wedged", 20.0)
        finally:
            os.kill(sup.pid("one"), signal.SIGCONT)
        await sup.restart("two", timeout=180.0)
        st = await sup.wait_for("two", "ready", 20.0)
        assert st.restarts == 1
        with pytest.raises(SupervisorError, match="nobody"):
            await sup.start("nobody")


def test_a_bad_system_file_names_the_file_and_the_field(tmp_path):
    p = tmp_path / "sys.yaml"
    p.write_text("modules:\n  - {name: one, run: eddie.toolkit.echo}\nlinks:\n  - {from: one, to: ghost}\n")
    with pytest.raises(SystemConfigError, match=r"sys.yaml: .*links.0.to: no module named 'ghost'"):
        load_system_config(p)
    p.write_text("modules:\n  - {name: one, run: 'bad module!'}\n")
    with pytest.raises(SystemConfigError, match=r"sys.yaml: modules.0.run"):
        load_system_config(p)
    p.write_text("modules: [\n")
    with pytest.raises(SystemConfigError, match=r"sys.yaml: line"):
        load_system_config(p)
    with pytest.raises(SystemConfigError, match="cannot read"):
        load_system_config(tmp_path / "missing.yaml")
