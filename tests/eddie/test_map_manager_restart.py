"""The map manager killed and started again on its state file: triggers crossed while it was away fire once, none refires.

Before the state file, a restarted manager had every used flag cleared and no idea where the vehicle
had been, so a trigger crossed while it was down never came (in the compare grid: a dead-reckoned
intersection whose resume-vision trigger was lost, the AMV standing still until the step failed).
The test plays the controller (its state stream and its `recorded_path` service, with the
controller's own `PathRecord`), the navigator's stream, and the `vision` module the triggers reach;
the manager is a real process, SIGKILLed mid-drive.
"""

from __future__ import annotations

import asyncio
import json
import os
import subprocess
import sys

import pytest

from eddie.annotated_map import save_annotations
from eddie.controller.path_record import PathRecord
from eddie.map_manager.state_file import ManagerState, StateFileError, load_state, save_state
from eddie.messages.controller import ControllerState, RecordedPath, RecordedPathQuery
from eddie.messages.map_manager import AnnotationList, AnnotationQuery, TriggerFired, TriggerMessage
from eddie.toolkit import Module
from eddie.toolkit.message import encode_body
from eddie.toolkit.module import Incoming
from tests.eddie._net import retry
from tests.eddie.test_map_manager import ANNS, W
from tests.modules._procs import spawn, stop
from wire.network import NetworkConfig
from wire.ports import free_port


def test_the_state_file_names_what_is_wrong_and_refuses_another_maps_state(tmp_path) -> None:
    f = tmp_path / "mm.state.json"
    assert load_state(f, annotated_map="gates.geojson", known={"a"}) is None  # no file: start afresh
    save_state(f, ManagerState(annotated_map="gates.geojson", used=("b",), odometer=2.5, x=2.5, y=0.1, stamp=1.0))
    assert load_state(f, annotated_map="gates.geojson", known={"a", "b"}).used == ("b",)
    with pytest.raises(StateFileError, match="the state of annotated map 'gates.geojson', not 'other.geojson'"):
        load_state(f, annotated_map="other.geojson", known={"a", "b"})
    with pytest.raises(StateFileError, match="used annotations not in 'gates.geojson': b"):
        load_state(f, annotated_map="gates.geojson", known={"a"})
    f.write_text('{"annotated_map": "gates.geojson", "used": [], "odometer": -1, "x": 0, "y": 0, "stamp": 0}')
    with pytest.raises(StateFileError, match="mm.state.json: odometer: Input should be greater than or equal to 0"):
        load_state(f, annotated_map="gates.geojson", known=set())
    f.write_text('{"annotated_map": ')
    with pytest.raises(StateFileError, match="mm.state.json: not JSON"):
        load_state(f, annotated_map="gates.geojson", known=set())
    # the process refuses it with one clear line, before it joins the network
    save_annotations(tmp_path / "gates.geojson", ANNS)
    r = subprocess.run([sys.executable, "-m", "eddie.map_manager", "--annotated-map", str(tmp_path / "gates.geojson"),
                        "--state", str(f), "--connect", f"tcp/127.0.0.1:{free_port()}"], capture_output=True, text=True, timeout=60)
    err = " ".join(r.stderr.split())
    assert r.returncode == 2 and "--state:" in err and "not JSON" in err and "Traceback" not in r.stderr


async def test_a_restarted_manager_fires_the_triggers_crossed_while_it_was_down_once(tmp_path) -> None:
    ns = f"mmr{os.getpid()}"
    ep = f"tcp/127.0.0.1:{free_port()}"
    amap, state = tmp_path / "gates.geojson", tmp_path / "map_manager.state.json"
    save_annotations(amap, ANNS)
    cmd = [sys.executable, "-m", "eddie.map_manager", "--annotated-map", str(amap), "--state", str(state), "--ns", ns, "--connect", ep]
    record = PathRecord(spacing=0.25)
    asked: list[RecordedPathQuery] = []

    async def recorded(inc: Incoming) -> RecordedPath:
        q = inc.message
        asked.append(q)
        return RecordedPath(points=tuple(record.stretch(q.odometer_from, q.odometer_to)), odometer_from=q.odometer_from,
                            odometer_to=q.odometer_to)

    procs: list[subprocess.Popen] = []
    try:
        async with Module("vision", NetworkConfig(namespace=ns, listen=(ep,))) as me, \
                Module("controller", NetworkConfig(namespace=ns, connect=(ep,))) as ctl:
            ctl.serve("recorded_path", recorded)
            ctl.ready()

            def drive(k: int) -> None:
                """The vehicle at local x = 0.25·k [m] (world x = 3 + 0.25·k), odometer = x."""
                x = 0.25 * k
                record.add(x, x, 0.1)
                me.link.put(me.keys.topic("controller", "state"),
                            encode_body(ControllerState(stamp=0.1 * k, x=x, y=0.1, yaw=0.0, v=2.5, curvature=0.0, odometer=x)))

            async def start_manager() -> None:
                procs.append(spawn(cmd, "SIDEWALK-READY map_manager"))
                await retry(lambda: me.request("map_manager", "query", AnnotationQuery(type="set_speed"), reply_type=AnnotationList))
                me.link.put(me.keys.topic("navigator", "world_from_local"), encode_body(W))

            fired: list[TriggerFired] = []
            one_fired, two_fired = asyncio.Event(), asyncio.Event()

            def on_fired(f: TriggerFired) -> None:
                fired.append(f)
                (two_fired if len(fired) >= 2 else one_fired).set()

            me.subscribe("map_manager", "triggers", TriggerFired, on_fired)
            await start_manager()
            drive(0)
            await me.request("map_manager", "query", AnnotationQuery(type="set_speed"), reply_type=AnnotationList)
            for k in range(1, 11):  # local 0 → 2.5 m: world 3 → 5.5 m, across b (world 5)
                drive(k)
            got = await me.receive(timeout=15.0)
            assert isinstance(got.message, TriggerMessage) and got.message.annotation_id == "b"
            # the cycle that reports b writes the state file before the manager's loop takes anything else:
            # b's report, then a query answered after it, and the file holds b
            await asyncio.wait_for(one_fired.wait(), 10)
            await me.request("map_manager", "query", AnnotationQuery(type="set_speed"), reply_type=AnnotationList)
            assert "b" in json.loads(state.read_text())["used"]
            procs[-1].kill()
            procs[-1].wait(10)
            for k in range(11, 27):  # while it is down: local 2.75 → 6.5 m, world 5.75 → 9.5, across c (world 8)
                drive(k)
            await start_manager()
            ans = await me.request("map_manager", "query", AnnotationQuery(type="set_speed"), reply_type=AnnotationList)
            assert [(r.id, r.used) for r in ans.annotations] == [("a", False), ("b", True), ("c", False)]  # b's flag taken back
            drive(27)  # the first state after the restart: it walks the recorded path and fires c
            got = await me.receive(timeout=15.0)
            assert isinstance(got.message, TriggerMessage) and got.message.annotation_id == "c"
            assert abs(got.message.x - 8.0) < 1e-6 and abs(got.message.y - 0.1) < 1e-6
            assert asked and asked[0].odometer_to == pytest.approx(0.25 * 27) and asked[0].odometer_from <= 2.5
            ans = await me.request("map_manager", "query", AnnotationQuery(type="set_speed"), reply_type=AnnotationList)
            assert [(r.id, r.used) for r in ans.annotations] == [("a", False), ("b", True), ("c", True)]
            await asyncio.wait_for(two_fired.wait(), 10)
            assert [(f.annotation_id, f.event) for f in fired] == [("b", "fired"), ("c", "fired")]  # b not again
            assert me.pending() == 0
    finally:
        for p in procs:
            stop(p)
