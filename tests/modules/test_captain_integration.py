"""CAPTAIN and MAP NAVIGATOR on a real blackboard node over real Zenoh: submit, run, status, cancel,
bad input, replanning, and a module killed mid-mission."""

from __future__ import annotations

import asyncio
import json
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from blackboard import AttrPredicate, Spec
from sidewalk.mission_client import MissionRejected
from tests.modules._harness import system

ROOT = Path(__file__).resolve().parents[2]
TOUR = """
mission: mini-tour
steps:
  - name: to the quad
    destination: quad
    constraints: [keep_right]
    trigger: wait 5
  - name: to the slope
    destination: slope_bottom
    trigger: stop
"""


def _eq(path: str, value) -> AttrPredicate:
    return AttrPredicate(path=path, op="==", value=value)


async def test_mission_submitted_over_zenoh_runs_to_success() -> None:
    async with system("cap-ok") as s:
        acc = await s.missions.submit(TOUR)
        assert acc.name == "mini-tour" and acc.steps == 2
        # step 1 runs through its segments, then the wait trigger holds in sim time
        waiting = await s.wait_status(acc.mission_id, lambda st: st.steps[0].state == "waiting")
        assert waiting.state == "running"
        st = await s.missions.status(acc.mission_id)
        assert st.steps[0].state == "waiting"
        s.tick(4.0)
        s.tick(6.0)  # 5 s after the step ended at sim time 0
        done = await s.wait_status(acc.mission_id, lambda st: st.terminal)
        assert done.state == "succeeded", done
        assert [o.state for o in done.steps] == ["succeeded", "succeeded"]

        # the blackboard holds the trail: one plan per step, segments with one mode each, step results
        plans = await s.bb.retrieve(Spec(type="route_plan", where=(_eq("mission_id", acc.mission_id),)))
        assert sorted(p.attrs.step_index for p in plans) == [0, 1]
        assert plans[0].geometry is not None and plans[0].geometry.kind == "polyline"
        first = next(p.attrs for p in plans if p.attrs.step_index == 0)
        assert first.node_ids[0] == "dorm" and first.node_ids[-1] == "quad"
        results = await s.bb.retrieve(Spec(type="step_result", where=(_eq("mission_id", acc.mission_id),)))
        assert sorted((r.attrs.step_index, r.attrs.success) for r in results) == [(0, True), (1, True)]
        modes = [seg.mode for seg in s.pilot.seen]
        assert "turn-at-intersection" in modes and "follow-road" in modes
        assert all(seg.constraints.keep == "right" for seg in s.pilot.seen if seg.plan_id == first.plan_id)
        # segments were handed out one at a time: each posted only after the previous one's result
        assert len({seg.segment_id for seg in s.pilot.seen}) == len(s.pilot.seen)
        all_st = await s.missions.statuses()
        assert [x.mission_id for x in all_st] == [acc.mission_id]
        # the MAP NAVIGATOR stored the map on the blackboard: a spatial query finds the stairs beside the slope
        from blackboard import Near, Point

        near = await s.bb.retrieve(Spec(type="map_object", geometry=Near(Point(x=62.0, y=66.0), 3.0, frame="world")))
        assert {"stairs_main", "slope_ramp"} <= {t.attrs.object_id for t in near}
        from modules.map_navigator import load_map

        stored = await s.bb.retrieve(Spec(type="map_object"))
        assert len(stored) == len(load_map("campus").world.objects)


async def test_bad_missions_are_rejected_and_the_captain_stays_up() -> None:
    async with system("cap-bad") as s:
        with pytest.raises(MissionRejected) as ei:
            await s.missions.submit("mission: x\nsteps:\n  - destination: {x: 1, y: nope}\n")
        rej = ei.value.rejection
        assert rej.error == "invalid_mission"
        assert [(p.line, p.field) for p in rej.problems] == [(3, "steps[0].destination.y")]
        # an unknown place is refused at submit, naming the step; an unreachable destination fails its step with the reason …
        with pytest.raises(MissionRejected) as ei:
            await s.missions.submit("mission: lost\nsteps:\n  - destination: hall\n  - destination: atlantis\n")
        (problem,) = ei.value.rejection.problems
        assert problem.field == "steps[1].destination" and "unknown place 'atlantis'" in problem.message
        acc = await s.missions.submit("mission: nowhere\nsteps:\n  - destination: library\n    constraints: [avoid_stairs, avoid_slope]\n")
        st = await s.wait_status(acc.mission_id, lambda st: st.terminal)
        assert st.state == "failed" and "no route" in st.reason
        # … and the next mission still runs
        acc = await s.missions.submit(json.dumps({"mission": "after", "steps": [{"destination": "hall", "trigger": "stop"}]}))
        st = await s.wait_status(acc.mission_id, lambda st: st.terminal)
        assert st.state == "succeeded"
        with pytest.raises(MissionRejected, match="no mission 'nope-123'"):
            await s.missions.status("nope-123")
        with pytest.raises(MissionRejected, match="already succeeded"):
            await s.missions.cancel(acc.mission_id)


async def test_cancel_withdraws_the_step_and_the_segment() -> None:
    async with system("cap-cancel", answer=lambda seg: None) as s:  # the PILOT never finishes a segment
        acc = await s.missions.submit("mission: c\nsteps:\n  - destination: gym\n")
        await s.pilot.wait_segments(1)
        st = await s.missions.cancel(acc.mission_id, "operator abort")
        st = await s.wait_status(acc.mission_id, lambda st: st.terminal)
        assert st.state == "cancelled" and st.reason == "operator abort"
        steps = await s.bb.retrieve(Spec(type="mission_step", where=(_eq("mission_id", acc.mission_id),)))
        assert [t.attrs.state for t in steps] == ["cancelled"]
        seg_id = s.pilot.seen[0].segment_id

        async def withdrawn() -> None:
            while seg_id not in s.pilot.cancelled:
                s.pilot.new_segment.clear()
                await s.pilot.new_segment.wait()
        await asyncio.wait_for(withdrawn(), 20.0)
        res = await s.bb.wait(Spec(type="step_result", where=(_eq("mission_id", acc.mission_id),)), timeout=20.0)
        assert not res.attrs.success and "cancelled" in res.attrs.reason


async def test_a_failed_segment_is_replanned_around() -> None:
    failed: set[str] = set()

    def answer(seg):
        if "sw_s2" in seg.path_object_ids and not failed:
            failed.add(seg.segment_id)
            return False, "a bench blocks the walk", seg.centreline[0]
        return True, "", seg.exit.point

    async with system("cap-replan", answer=answer) as s:
        acc = await s.missions.submit("mission: r\nsteps:\n  - destination: quad\n")
        st = await s.wait_status(acc.mission_id, lambda st: st.terminal)
        assert st.state == "succeeded", st
        plans = await s.bb.retrieve(Spec(type="route_plan", where=(_eq("mission_id", acc.mission_id),)))
        revs = {p.attrs.revision: p.attrs for p in plans}
        assert sorted(revs) == [0, 1]
        assert "e_s2" in revs[0].edge_ids and "e_s2" not in revs[1].edge_ids[1:]  # only to back off it
        assert revs[1].node_ids[-1] == "quad" and "e_quad_n" in revs[1].edge_ids
        res = await s.bb.retrieve(Spec(type="step_result", where=(_eq("mission_id", acc.mission_id),)))
        assert res[0].attrs.replans == 1


async def test_navigator_gone_fails_the_mission_with_the_reason() -> None:
    from codger.captain import CaptainOptions

    async with system("cap-lost", answer=lambda seg: None, captain=CaptainOptions(navigator_grace_s=1.0)) as s:
        acc = await s.missions.submit("mission: l\nsteps:\n  - destination: gym\n")
        await s.pilot.wait_segments(1)
        await s.stop_module("map_navigator")
        st = await s.wait_status(acc.mission_id, lambda st: st.terminal)
        assert st.state == "failed" and "map_navigator stopped" in st.reason


async def test_navigator_killed_and_restarted_resumes_the_mission() -> None:
    """SIGKILL the MAP NAVIGATOR process mid-segment; a new one takes the step up where it was."""
    async with system("cap-resume", answer=lambda seg: None, navigator=False) as s:
        def spawn() -> subprocess.Popen:
            return subprocess.Popen([sys.executable, "-m", "codger.map_navigator", "--map", "campus", "--ns", "cap-resume",
                                     "--connect", s.node.endpoint, "--heartbeat", "0.2"], cwd=str(ROOT),
                                    stdout=subprocess.PIPE, text=True)

        async def ready(p: subprocess.Popen) -> None:
            line = await asyncio.wait_for(asyncio.to_thread(p.stdout.readline), 30.0)
            assert line.strip() == "SIDEWALK-READY map_navigator", line

        nav = spawn()
        try:
            await ready(nav)
            acc = await s.missions.submit("mission: k\nsteps:\n  - destination: quad\n")
            await s.pilot.wait_segments(1)
            first = s.pilot.seen[0]
            nav.send_signal(signal.SIGKILL)
            nav.wait(10)
            nav = spawn()
            await ready(nav)
            # the PILOT finishes the segment it was driving; the new navigator carries on from there
            await s.pilot.reply(first, True, "", first.exit.point)
            await s.pilot.wait_segments(2)
            nxt = s.pilot.seen[1]
            assert nxt.plan_id != first.plan_id and nxt.centreline[0] == pytest.approx(first.exit.point, abs=0.5)
            s.pilot.answer = lambda seg: (True, "", seg.exit.point)
            await s.pilot.reply(nxt, True, "", nxt.exit.point)
            st = await s.wait_status(acc.mission_id, lambda st: st.terminal)
            assert st.state == "succeeded", st
            nav.send_signal(signal.SIGTERM)  # a clean stop: session closed, exit code 0
            assert await asyncio.to_thread(nav.wait, 20) == 0
        finally:
            if nav.poll() is None:
                nav.send_signal(signal.SIGTERM)
                try:
                    nav.wait(15)
                except subprocess.TimeoutExpired:
                    nav.kill()
                    nav.wait()
            nav.stdout.close()


def test_captain_refuses_a_bad_mission_file_at_start(tmp_path: Path) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text("mission: b\nsteps:\n  - destination: quad\n    trigger: fly\n")
    p = subprocess.run([sys.executable, "-m", "codger.captain", "--mission", str(bad), "--connect", "tcp/127.0.0.1:9"],
                       cwd=str(ROOT), capture_output=True, text=True, timeout=60)
    assert p.returncode == 2
    assert f"{bad}:4:14: steps[0].trigger:" in p.stderr


def test_navigator_refuses_a_missing_map() -> None:
    p = subprocess.run([sys.executable, "-m", "codger.map_navigator", "--map", "atlantis", "--connect", "tcp/127.0.0.1:9"],
                       cwd=str(ROOT), capture_output=True, text=True, timeout=60)
    assert p.returncode == 2 and "atlantis" in p.stderr


async def test_pilot_gone_fails_the_step_with_the_reason() -> None:
    from runtime import Link

    async with system("cap-pilot", answer=lambda seg: None, pilot_grace=1.0) as s:
        pilot_link = Link.open(s.net)  # the PILOT's liveliness, as the real module declares it
        try:
            pilot_link.declare_alive(s.keys.alive("pilot"))
            acc = await s.missions.submit("mission: p\nsteps:\n  - destination: gym\n")
            await s.pilot.wait_segments(1)
        finally:
            pilot_link.close()  # the PILOT dies mid-segment
        st = await s.wait_status(acc.mission_id, lambda st: st.terminal)
        assert st.state == "failed" and "pilot stopped" in st.reason and "segment 0 (follow-road)" in st.reason
        segs = await s.bb.retrieve(Spec(type="route_segment", where=(_eq("segment_id", s.pilot.seen[0].segment_id),)))
        assert segs[0].attrs.state == "cancelled"


async def test_missions_submitted_back_to_back_each_run_to_their_own_end() -> None:
    # a mission queued while the CAPTAIN is busy must already have its status token when it is picked up
    bad = "mission: nowhere-{i}\nsteps:\n  - name: to the library\n    destination: library\n    constraints: [avoid_stairs, avoid_slope]\n"
    async with system("cap-burst") as s:
        accs = await asyncio.gather(*(s.missions.submit(bad.format(i=i)) for i in range(6)))
        for acc in accs:
            done = await s.wait_status(acc.mission_id, lambda st: st.terminal)
            assert done.state == "failed", done
            assert "no route" in done.reason and "captain error" not in done.reason, done.reason
