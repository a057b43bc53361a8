"""The mission contract's forms: cancel requests, rejections, mission ids."""

from __future__ import annotations

import pytest

from modules.captain import MissionFileError, parse_mission, rejection_from
from wire.mission import MissionRequestError, new_mission_id, parse_cancel
from runtime import check_name


def test_cancel_takes_a_bare_id_or_json() -> None:
    assert parse_cancel(b"  tour-abc123\n").mission_id == "tour-abc123"
    req = parse_cancel(b'{"mission_id": "m-1", "reason": "rain"}')
    assert (req.mission_id, req.reason) == ("m-1", "rain")
    with pytest.raises(MissionRequestError, match="needs a mission id"):
        parse_cancel(b"   ")
    with pytest.raises(MissionRequestError, match="bad cancel request"):
        parse_cancel(b'{"id": "m-1"}')


def test_rejection_carries_every_problem() -> None:
    with pytest.raises(MissionFileError) as ei:
        parse_mission("mission: x\nsteps:\n  - destination: {x: a, y: b}\n")
    rej = rejection_from(ei.value)
    assert rej.error == "invalid_mission"
    assert [(p.line, p.field) for p in rej.problems] == [(3, "steps[0].destination.x"), (3, "steps[0].destination.y")]
    assert rej.model_validate_json(rej.to_bytes()) == rej


@pytest.mark.parametrize("name", ["campus-tour", "a b/c*d", "", "ünïcode tour"])
def test_mission_ids_are_single_key_chunks(name: str) -> None:
    mid = new_mission_id(name)
    assert check_name(mid) == mid
    assert new_mission_id(name) != mid  # fresh each time
