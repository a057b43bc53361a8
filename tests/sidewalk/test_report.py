"""The report is a pure function of a recorded run: every figure checked by hand.

Two records: a small one written here whose figures are worked out by hand below, and a real one
(`data/two-hop.run_record.json.gz`, recorded by
`sidewalk run --mission tests/sidewalk/data/two-hop.yaml --rtf 25 --seed 3 --no-perception --pose-error 1.5,3`)
whose figures are recomputed here from its rows without the report's code.
"""

import json
import math
from pathlib import Path

import numpy as np
import pytest

from modules.vocabulary import Destination, Mission, MissionStatus, MissionStepSpec, StepOutcome, Trigger
from sidewalk.report import build_report
from sidewalk.run_record import (
    ProcessCost, RecordedPlan, RunRecord, RunRecordError, StampedStatus, load_record, save_record,
)
from wire.drive import SimEvent
from wire.health import ProcessUsage

FIXTURE = Path(__file__).parent / "data" / "two-hop.run_record.json.gz"


def _truth() -> tuple:
    rows = [(99.0, -5.0, 0.0, 0.0)]  # before the submission: not part of the mission
    rows += [(float(t), float(t - 100), 0.0, 0.0) for t in range(100, 111)]  # east along y = 0 to (10, 0)
    rows += [(float(t), 10.0, float(t - 110), 1.5708) for t in range(111, 120)]  # north along x = 10 to (10, 9)
    rows += [(float(t), 10.0, 9.5, 1.5708) for t in range(120, 124)]  # (10, 9.5), standing from t = 120
    return tuple(rows)


def _status(state="succeeded", reason="", last_state="succeeded") -> MissionStatus:
    return MissionStatus(
        mission_id="m-1", name="hand", state=state, step_count=2, reason=reason, submitted_at=100.5, finished_at=121.0,
        steps=(StepOutcome(step_index=0, name="a", state="succeeded", started_at=100.5, finished_at=109.5),
               StepOutcome(step_index=1, name="b", state=last_state, started_at=109.5, finished_at=121.0)),
    )


def _record(**changes) -> RunRecord:
    mission = Mission(mission_id="m-1", name="hand", steps=(
        MissionStepSpec(name="a", destination=Destination(xy=(10.0, 0.0))),
        MissionStepSpec(name="b", destination=Destination(xy=(10.0, 10.0)), trigger=Trigger(action="stop"), tolerance=1.0),
    ))
    usage = ProcessUsage
    base = dict(
        architecture="codger", mission=mission, world="hand", vehicle="terregator", seed=1, perception=False,
        rtf_requested=20.0, destinations=((10.0, 0.0), (10.0, 10.0)),
        submitted_wall_s=10.0, submitted_sim_s=100.0, ended_wall_s=12.1, ended_sim_s=121.0, rest_sim_s=122.0,
        truth=_truth(),
        estimate=((99.0, 9.0, 9.0, 0.0), (101.0, 1.0, 0.3, 0.0), (105.0, 5.0, -0.4, 0.0), (115.0, 10.5, 5.0, 1.57)),
        events=(SimEvent(stamp=98.0, kind="off-path", x=0, y=0), SimEvent(stamp=99.5, kind="collision", x=0, y=0),
                SimEvent(stamp=100.2, kind="on-path", x=0, y=0), SimEvent(stamp=103.0, kind="off-path", x=0, y=0),
                SimEvent(stamp=104.5, kind="on-path", x=0, y=0), SimEvent(stamp=121.5, kind="off-path", x=0, y=0)),
        statuses=(StampedStatus(wall_s=10.0, sim_s=100.0, status=_status(state="running", last_state="pending")),
                  StampedStatus(wall_s=12.1, sim_s=121.0, status=_status())),
        plans=(RecordedPlan(step_index=0, revision=0, stamp=100.5, polyline=((0.0, 1.0), (10.0, 1.0))),
               RecordedPlan(step_index=1, revision=0, stamp=109.6, polyline=((12.0, 0.0), (12.0, 10.0))),
               RecordedPlan(step_index=1, revision=1, stamp=115.5, polyline=((10.0, 0.0), (10.0, 10.0)))),
        processes=(ProcessCost(name="pilot", pid=1, usage=usage(cpu_s=2.0, rss_bytes=100_000_000, msgs_out=10, bytes_out=1000)),
                   ProcessCost(name="pilot", pid=2, usage=usage(cpu_s=1.5, rss_bytes=120_000_000, msgs_out=5, bytes_out=500, msgs_in=7, bytes_in=70)),
                   ProcessCost(name="helm", pid=3, usage=usage(cpu_s=0.25, rss_bytes=50_000_000))),
        blackboard={"posts": 5, "retrieves": 2, "monitors_registered": 3, "bytes_in": 100, "bytes_out": 50},
        exit_codes={"pilot": 0, "helm": 0},
    )
    return RunRecord(**{**base, **changes})


def test_every_figure_of_a_hand_made_record():
    r = build_report(_record())
    assert (r.architecture, r.success, r.claimed_success, r.reason) == ("codger", True, True, "")
    # the mission took 20.5 s by the CAPTAIN's clock (100.5 → 121); the launcher saw 21 s sim in 2.1 s wall
    assert (r.sim_time_s, r.wall_time_s, r.rtf_achieved) == (20.5, pytest.approx(2.1), pytest.approx(10.0))
    # 10 m east, 9 m north, 0.5 m on; the 5 m before the submission do not count
    assert r.distance_m == pytest.approx(19.5)
    a, b = r.steps
    # step a passed through (10, 0) at t = 110 although it was declared done at x = 9.5
    assert (a.success, a.claimed_success, a.distance_m, a.distance_at_claim_m) == (True, True, 0.0, 0.5)
    assert (a.started_s, a.finished_s, a.tolerance_m, a.replans) == (0.0, 9.0, 1.5, 0)
    # step b: at rest at (10, 9.5), 0.5 m from (10, 10), tolerance 1.0 m
    assert (b.success, b.distance_m, b.distance_at_claim_m, b.finished_s, b.tolerance_m) == (True, 0.5, 0.5, 20.5, 1.0)
    assert r.goal_error_m == 0.5
    # cross-track: a's 9 samples (t = 101…109) are 1 m off its plan, b's 12 (t = 110…121) 2 m off its first plan
    assert (a.cross_track_error_m.rms, a.cross_track_error_m.n) == (1.0, 9)
    assert (b.cross_track_error_m.rms, b.cross_track_error_m.max, b.cross_track_error_m.final, b.cross_track_error_m.n) == (2.0, 2.0, 2.0, 12)
    # ... and against the plan in force: the replan posted at 115.5 lies on the track (6 samples at 2 m, 6 at 0)
    assert b.cross_track_error_newest_m.rms == pytest.approx(math.sqrt(2.0), abs=1e-4)
    assert b.cross_track_error_newest_m.final == 0.0
    assert (b.replans, r.replans) == (1, 1)
    assert r.cross_track_error_m.rms == pytest.approx(math.sqrt((9 * 1 + 12 * 4) / 21), abs=1e-4)
    assert (r.cross_track_error_m.n, r.cross_track_error_m.final) == (21, 2.0)
    assert r.cross_track_error_newest_m.rms == pytest.approx(math.sqrt((9 * 1 + 6 * 4) / 21), abs=1e-4)
    # position error at t = 101, 105, 115: 0.3, 0.4, 0.5 m (the one at t = 99 is before the submission)
    assert r.position_error_m.rms == pytest.approx(math.sqrt((0.09 + 0.16 + 0.25) / 3), abs=1e-4)
    assert (r.position_error_m.max, r.position_error_m.final, r.position_error_m.n) == (0.5, 0.5, 3)
    # off the path 100→100.2, 103→104.5 and 121.5→122 (the rest); the collision at 99.5 came before the submission
    assert r.off_path_s == pytest.approx(0.2 + 1.5 + 0.5)
    assert r.collisions == 0
    assert r.sim_events == {"on-path": 2, "off-path": 2}
    # per process: the PILOT lived twice
    p = r.modules["pilot"]
    assert (p.cpu_s, p.rss_mb, p.msgs_out, p.bytes_out, p.msgs_in, p.bytes_in, p.incarnations) == (3.5, 120.0, 15, 1500, 7, 70, 2)
    assert (r.modules["helm"].cpu_s, r.modules["helm"].incarnations) == (0.25, 1)
    assert (r.blackboard.posts, r.blackboard.monitors, r.blackboard.bytes) == (5, 3, 150)


def test_a_claimed_success_the_truth_contradicts_names_the_disagreement():
    far = _record(destinations=((10.0, 0.0), (10.0, 12.0)))
    r = build_report(far)
    assert (r.success, r.claimed_success) == (False, True)
    assert r.steps[1].distance_m == 2.5 and not r.steps[1].success
    assert r.reason == "the robot claimed success, but by truth step 2 'b' ended 2.50 m from its destination (tolerance 1.00 m)"
    hit = _record(events=(SimEvent(stamp=115.0, kind="collision", x=10, y=5, object_id="tree_1"),))
    r = build_report(hit)
    assert (r.success, r.claimed_success, r.collisions) == (False, True, 1)
    assert r.reason == "the robot claimed success, but by truth 1 collision(s)"


@pytest.mark.parametrize("kind, words", [("tip-over", "tipped over"), ("high-centred", "high-centred")])
def test_a_vehicle_stranded_on_rough_ground_fails_by_truth_whatever_it_claims(kind, words):
    r = build_report(_record(events=(SimEvent(stamp=115.0, kind=kind, x=10, y=5, object_kind="terrain"),)))
    assert (r.success, r.claimed_success, r.collisions) == (False, True, 0)
    assert r.reason == f"the robot claimed success, but by truth the vehicle {words}"
    before = build_report(_record(events=(SimEvent(stamp=90.0, kind=kind, x=0, y=0, object_kind="terrain"),)))
    assert before.success  # before the submission: not this mission's


def test_a_claimed_failure_keeps_its_reason_or_names_the_disagreement():
    statuses = (StampedStatus(wall_s=12.1, sim_s=121.0, status=_status(state="failed", reason="no progress", last_state="failed")),)
    r = build_report(_record(statuses=statuses))  # it failed, yet the vehicle stood 0.5 m from (10, 10)
    assert (r.success, r.claimed_success) == (True, False)
    assert r.reason == "the robot claimed failure (no progress), but by truth every destination was reached without collision"
    r = build_report(_record(statuses=statuses, destinations=((10.0, 0.0), (0.0, 30.0))))
    assert (r.success, r.claimed_success, r.reason) == (False, False, "no progress")
    # a launcher that gave up says why; the step still running is judged where the vehicle stood
    running = (StampedStatus(wall_s=10.0, sim_s=100.0, status=_status(state="running", last_state="running")),)
    r = build_report(_record(statuses=running, stop_reason="wall-time budget of 5 s used up"))
    assert (r.success, r.claimed_success, r.reason) == (True, False, "the robot claimed failure (wall-time budget of 5 s used up), "
                                                        "but by truth every destination was reached without collision")


def test_a_step_never_started_was_never_reached():
    st = _status(state="failed", reason="no route", last_state="pending")
    st = st.model_copy(update={"steps": (st.steps[0], StepOutcome(step_index=1, name="b"))})
    r = build_report(_record(statuses=(StampedStatus(wall_s=12.1, sim_s=121.0, status=st),)))
    assert (r.steps[1].success, r.steps[1].distance_m, r.steps[1].started_s) == (False, None, None)
    assert not r.success


def test_a_record_round_trips_and_a_bad_file_is_named(tmp_path):
    rec = _record()
    for name in ("r.json", "r.json.gz"):
        assert load_record(save_record(rec, tmp_path / name)) == rec
    bad = tmp_path / "bad.json"
    bad.write_text('{"architecture": "codger"}')
    with pytest.raises(RunRecordError, match=r"bad\.json: not a run record: mission: Field required"):
        load_record(bad)
    bad.write_text("{")
    with pytest.raises(RunRecordError, match=r"bad\.json: not JSON \(line 1"):
        load_record(bad)


# ---- the real recording -----------------------------------------------------------------------


def _segment_distance(p: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Distance of points p (N,2) to a polyline (M,2), by projecting onto each segment."""
    best = np.full(len(p), np.inf)
    for a, b in zip(line[:-1], line[1:]):
        ab = b - a
        L2 = float(ab @ ab)
        u = np.zeros(len(p)) if L2 == 0 else np.clip(((p - a) @ ab) / L2, 0.0, 1.0)
        best = np.minimum(best, np.hypot(*(p - (a + u[:, None] * ab)).T))
    return best


def test_the_recorded_two_hop_run_figure_by_figure():
    rec = load_record(FIXTURE)
    raw = json.loads(__import__("gzip").decompress(FIXTURE.read_bytes()))
    r = build_report(rec)
    t0, t1, rest = raw["submitted_sim_s"], raw["ended_sim_s"], raw["rest_sim_s"]
    settled = max(t1, rest)
    truth = np.array(raw["truth"])
    in_run = truth[(truth[:, 0] >= t0) & (truth[:, 0] <= settled)]
    # the run: the dead-reckoning robot says it arrived, but it drove into the hall on the way
    assert (r.success, r.claimed_success) == (False, True)
    collisions = [e for e in raw["events"] if e["kind"] == "collision" and t0 <= e["stamp"] <= settled]
    assert r.collisions == len(collisions) == 8
    assert {e["object_id"] for e in collisions} == {"b_hall"}
    assert r.reason == "the robot claimed success, but by truth 8 collision(s)"
    final = raw["statuses"][-1]["status"]
    assert r.sim_time_s == pytest.approx(final["finished_at"] - final["submitted_at"], abs=1e-3)
    wall = raw["ended_wall_s"] - raw["submitted_wall_s"]
    assert r.wall_time_s == pytest.approx(wall, abs=1e-3)
    assert r.rtf_achieved == pytest.approx((t1 - t0) / wall, abs=1e-3)
    assert r.distance_m == pytest.approx(float(np.sum(np.hypot(*np.diff(in_run[:, 1:3], axis=0).T))), abs=1e-3)
    sub = final["submitted_at"]
    walk, hall = r.steps
    assert rec.destinations == ((0.0, 0.0), (30.0, 8.0))  # i_dorm_walk and the hall in the world file
    s0, s1 = final["steps"]
    assert walk.finished_s == pytest.approx(s0["finished_at"] - sub, abs=1e-3)
    assert hall.started_s == pytest.approx(s1["started_at"] - sub, abs=1e-3)
    assert hall.finished_s == pytest.approx(s1["finished_at"] - sub, abs=1e-3)
    # the walk: closest pass from its start to the hall step's end; its own tolerance of 2 m
    seen = truth[(truth[:, 0] >= s0["started_at"]) & (truth[:, 0] <= s1["finished_at"])]
    assert walk.distance_m == pytest.approx(float(np.min(np.hypot(seen[:, 1], seen[:, 2]))), abs=1e-3)
    assert (walk.tolerance_m, walk.success) == (2.0, True)
    # the hall: where the vehicle stood at the end
    last = in_run[-1]
    assert hall.distance_m == pytest.approx(math.hypot(last[1] - 30.0, last[2] - 8.0), abs=1e-3) == r.goal_error_m
    assert hall.success == (hall.distance_m <= 1.5)
    # cross-track against each step's first plan over the step's span; one replan of the hall step
    plans = {(p["step_index"], p["revision"]): np.array(p["polyline"]) for p in raw["plans"]}
    assert (walk.replans, hall.replans, r.replans) == (0, 1, 1)
    errs = []
    for i, s in enumerate((s0, s1)):
        rows = truth[(truth[:, 0] >= s["started_at"]) & (truth[:, 0] <= s["finished_at"])]
        errs.append(_segment_distance(rows[:, 1:3], plans[(i, 0)]))
    assert walk.cross_track_error_m.max == pytest.approx(errs[0].max(), abs=1e-3)
    e = np.concatenate(errs)
    assert r.cross_track_error_m.rms == pytest.approx(float(np.sqrt(np.mean(e**2))), abs=1e-3)
    assert r.cross_track_error_m.n == len(e)
    # position error: each estimate against the truth interpolated at its stamp
    est = np.array(raw["estimate"])
    est = est[(est[:, 0] >= t0) & (est[:, 0] <= settled)]
    tx = np.interp(est[:, 0], truth[:, 0], truth[:, 1])
    ty = np.interp(est[:, 0], truth[:, 0], truth[:, 2])
    pe = np.hypot(est[:, 1] - tx, est[:, 2] - ty)
    assert (r.position_error_m.max, r.position_error_m.final) == (pytest.approx(pe.max(), abs=1e-3), pytest.approx(pe[-1], abs=1e-3))
    # every process of the run reported its cost in its last heartbeat
    assert set(r.modules) == {"router", "blackboard", "sim", "helm", "pilot", "map_navigator", "captain"}
    assert all(m.cpu_s > 0 and m.rss_mb > 10 and m.msgs_out > 0 for m in r.modules.values())
    assert r.map_error is not None and r.map_error.requested_m is None and r.map_error.missing == 1


def test_a_keep_right_step_is_judged_in_its_lane_not_on_the_centre():
    # b keeps right on a 6 m path arrived at heading north: its point is 1.5 m right of (10, 10), (11.5, 10);
    # standing at (10, 9.5) on the centre is 1.58 m from it (tolerance 1.0 m)
    lane = dict(lane_offsets=(0.0, -1.5), goal_points=((10.0, 0.0), (11.5, 10.0)))
    r = build_report(_record(**lane))
    b = r.steps[1]
    assert b.success is False and b.distance_m == pytest.approx(math.hypot(1.5, 0.5), abs=1e-3)
    assert r.goal_error_m == pytest.approx(math.hypot(1.5, 0.5), abs=1e-3) and r.success is False
    # the same stop in the lane, 0.5 m short of the lane point, is reached
    lane_truth = tuple((t, x + 1.5 if t >= 110 else x, y, yaw) for t, x, y, yaw in _truth())
    ok = build_report(_record(truth=lane_truth, **lane)).steps[1]
    assert ok.success and ok.distance_m == pytest.approx(0.5, abs=1e-3)


def test_the_lane_point_does_not_turn_with_the_vehicle():
    # the same stop in the lane, the vehicle facing south (backwards, turned on the spot at the end): judged at the
    # same point, 0.5 m from it; judged from its heading, the lane would be west of the centre, 3.04 m away
    lane = dict(lane_offsets=(0.0, -1.5), goal_points=((10.0, 0.0), (11.5, 10.0)))
    fwd = tuple((t, x + 1.5 if t >= 110 else x, y, yaw) for t, x, y, yaw in _truth())
    back = tuple((t, x, y, yaw - math.pi if t >= 120 else yaw) for t, x, y, yaw in fwd)
    a, b = build_report(_record(truth=fwd, **lane)), build_report(_record(truth=back, **lane))
    assert b.steps[1].success and b.success == a.success
    assert b.steps[1].distance_m == a.steps[1].distance_m == pytest.approx(0.5, abs=1e-3)
    assert b.goal_error_m == a.goal_error_m == pytest.approx(0.5, abs=1e-3)


