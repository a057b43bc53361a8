"""The CAPTAIN's sequencer: one step at a time, triggers, failures, cancel, status."""

from __future__ import annotations

import pytest

from modules.captain import MissionRun, SequenceError, parse_mission
from modules.vocabulary import StepResult

MISSION = parse_mission("""
mission: seq
steps:
  - {name: a, destination: quad, trigger: continue}
  - {name: b, destination: gym, trigger: wait 3}
  - {name: c, destination: hall}
""", mission_id="seq-1")


def _ok(i: int) -> StepResult:
    return StepResult(mission_id="seq-1", step_index=i, success=True)


def test_steps_run_in_order_with_continue_and_wait() -> None:
    run = MissionRun(MISSION, submitted_at=0.0)
    assert run.status.state == "queued"
    step = run.start(1.0)
    assert (step.step_index, step.name, step.destination.place) == (0, "a", "quad")
    assert run.status.state == "running" and run.status.steps[0].state == "running"
    nxt = run.step_finished(_ok(0), 10.0)
    assert nxt.kind == "step" and nxt.step.step_index == 1
    nxt = run.step_finished(_ok(1), 20.0)
    assert nxt.kind == "wait" and nxt.until == 23.0
    assert run.status.steps[1].state == "waiting"
    nxt = run.wait_over(23.0)
    assert nxt.kind == "step" and nxt.step.step_index == 2
    nxt = run.step_finished(_ok(2), 30.0)
    assert nxt.kind == "done"
    st = run.status
    assert st.state == "succeeded" and st.finished_at == 30.0 and st.current_step is None
    assert [s.state for s in st.steps] == ["succeeded"] * 3
    assert st.steps[0].started_at == 1.0 and st.steps[0].finished_at == 10.0


def test_a_failed_step_fails_the_mission_with_its_reason() -> None:
    run = MissionRun(MISSION)
    run.start(0.0)
    nxt = run.step_finished(StepResult(mission_id="seq-1", step_index=0, success=False, reason="unknown place 'quad'"), 5.0)
    assert nxt.kind == "done"
    st = run.status
    assert st.state == "failed" and "step 1 (a) failed: unknown place 'quad'" == st.reason
    assert [s.state for s in st.steps] == ["failed", "cancelled", "cancelled"]


def test_stop_trigger_ends_the_mission_successfully() -> None:
    m = parse_mission("mission: s\nsteps:\n  - {destination: a, trigger: stop}\n  - {destination: b}\n", mission_id="s-1")
    run = MissionRun(m)
    run.start(0.0)
    nxt = run.step_finished(StepResult(mission_id="s-1", step_index=0, success=True), 1.0)
    assert nxt.kind == "done" and run.status.state == "succeeded"
    assert "stopped by the trigger" in run.status.reason
    assert run.status.steps[1].state == "cancelled"


def test_cancel_and_out_of_order_results() -> None:
    run = MissionRun(MISSION)
    run.start(0.0)
    with pytest.raises(SequenceError, match="does not match"):
        run.step_finished(_ok(1), 1.0)
    with pytest.raises(SequenceError, match="not waiting"):
        run.wait_over(1.0)
    run.cancel(2.0, "operator said so")
    st = run.status
    assert st.state == "cancelled" and st.reason == "operator said so" and st.steps[0].state == "cancelled"
    with pytest.raises(SequenceError):
        run.step_finished(_ok(0), 3.0)
    run.fail(4.0, "late")  # no effect once finished
    assert run.status.state == "cancelled"
