"""The fault injectors of `sidewalk run --fault`, each shown to happen in a real run (real processes, loopback Zenoh)."""

import math
from pathlib import Path

import numpy as np
import pytest

from sidewalk.compare.faults import JUMP_M, WEDGE_S, FaultSpec
from sidewalk.launcher import RECORD_FILE, RunConfig, run_mission
from sidewalk.run_record import load_record

DATA = Path(__file__).parent / "data"


@pytest.mark.missions
@pytest.mark.e2e
@pytest.mark.timeout(400)
@pytest.mark.parametrize("lockstep", [False, True], ids=["realtime", "lockstep"])
async def test_kill_wedge_and_jump_each_happen_in_a_run(tmp_path, lockstep):
    # the kill comes once the recorder has heard the first life's heartbeats (1 s wall each), so both lives count
    faults = (FaultSpec(name="kill-perception", at_s=12.0), FaultSpec(name="wedge-planner", at_s=20.0),
              FaultSpec(name="position-jump", at_s=30.0))
    cfg = RunConfig(world="campus", mission=str(DATA / "short-hop.yaml"), rtf=10.0, seed=3, out=tmp_path, faults=faults,
                    max_wall_time_s=240.0, pilot_grace_s=60.0, lockstep=lockstep)
    report = await run_mission(cfg)
    rec = load_record(tmp_path / RECORD_FILE)
    by_name = {f.name: f for f in report.faults}
    assert set(by_name) == {"kill-perception", "wedge-planner", "position-jump"}
    assert all(f.injected for f in report.faults), [f.detail for f in report.faults]
    # the killed PERCEPTION came back: two lives, and its restart was after the kill
    kp = by_name["kill-perception"]
    assert kp.target == "perception" and kp.restored_sim_s >= kp.at_sim_s
    assert report.exit_codes.get("perception") is not None
    assert len({p.pid for p in rec.processes if p.name == "perception"}) == 2 or report.modules["perception"].incarnations == 2
    # the wedged PILOT stayed stopped for the wedge's sim time (in lock-step too: the barrier stops waiting for it)
    w = by_name["wedge-planner"]
    # stamps are tenths of a sim second: 67.1 - 62.1 is 4.999… in floating point
    assert w.target == "pilot" and w.restored_sim_s - w.at_sim_s >= WEDGE_S - 1e-6, w
    # the jump shows in the estimate the recorder sampled: its error against truth rose by about JUMP_M
    j = by_name["position-jump"]
    est = np.asarray(rec.estimate)
    truth = np.asarray(rec.truth)
    assert j.target == "sim"  # the odometry slipped: the PILOT's estimate, built on it, jumps whatever the fix gate does
    err = np.hypot(est[:, 1] - np.interp(est[:, 0], truth[:, 0], truth[:, 1]), est[:, 2] - np.interp(est[:, 0], truth[:, 0], truth[:, 2]))
    before = err[(est[:, 0] < j.at_sim_s - 1.0) & (est[:, 0] > j.at_sim_s - 6.0)]  # clear of the injection's own stamp
    after = err[(est[:, 0] > j.at_sim_s) & (est[:, 0] < j.at_sim_s + 5.0)]
    assert len(before) and len(after)
    assert after.max() >= before.max() + 0.5 * JUMP_M, (before.max(), after.max())
    assert math.isfinite(report.sim_time_s)
