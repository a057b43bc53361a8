"""What switches a triggered EDDIE module: the mission service's `ModuleSwitch` and the map manager's triggers."""

from __future__ import annotations

import base64

from eddie.messages.map_manager import ResumeVision, TriggerMessage
from eddie.messages.modules import ModuleSwitch
from eddie.modules.switched import Switch
from eddie.toolkit.message import encode_envelope


def _trigger(data) -> TriggerMessage:  # noqa: ANN001 - any trigger data message
    return TriggerMessage(annotation_id="a1", trigger_type="resume_vision", x=0.0, y=0.0, crossed_wall=0.0,
                          data_base64=base64.b64encode(encode_envelope("map_manager", data, 1.0)).decode())


def test_the_mission_service_switch_names_its_mission_and_a_trigger_keeps_it() -> None:
    s = Switch(awake=True)
    assert s.mission_id == ""
    s.take("road_following", ModuleSwitch(on=False, mission_id="m-1", reason="mission m-1 cancelled"))
    assert (s.awake, s.mission_id, s.mission_running, s.taken) == (False, "m-1", False, 1)
    s.take("road_following", _trigger(ResumeVision(node_id="n3", segment_index=2)))  # a trigger wakes it; the mission stays ended
    assert (s.awake, s.mission_id, s.mission_running, s.taken) == (True, "m-1", False, 2)
    s.take("road_following", ModuleSwitch(on=True, mission_id="m-2", reason="mission m-2 started"))
    assert (s.awake, s.mode, s.mission_id, s.mission_running, s.taken) == (True, "", "m-2", True, 3)
    s.take("road_following", ModuleSwitch(on=False, mode="dead_reckon"))  # a switch naming no mission keeps the last one
    assert (s.awake, s.mission_id, s.mission_running) == (False, "m-2", True)
